"""Retargets held to Mixamo's own: the same Mixamo clip on two characters (../shared/data/pairs/san, Aj and
Kaya) is the reference answer for retargeting one onto the other. Measured by the SAN protocol
(tests/common/san_protocol.py, numpy only, no MotionKit code): the 22 main body joints of the target in
world space, as Blender evaluates them, against the target's own clip, in % of its height; over all
joints and for the pose alone (joints relative to the hips). The baseline is the plain rotation copy.
The bench with every clip, Blender's constraints and the FBX pairs: bench/mixamo_pairs.py."""
import os

import numpy as np
import pytest

import made_characters as made
import mixamo_pairs as mp
import san_protocol as sp

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SHARED = os.path.join(os.path.dirname(ROOT), "shared")

# Getting Up: the body rising from the floor on planted feet (the hips held on the source's scaled path but
# where the legs alone cannot hold the feet).
CASES = [("Jumping", "Aj", "Kaya"), ("Jumping", "Kaya", "Aj"), ("Running", "Aj", "Kaya"), ("Running", "Kaya", "Aj"),
         ("Getting Up", "Aj", "Kaya")]
IDS = [f"{clip}-{a}-to-{b}" for clip, a, b in CASES]

# Blender's evaluation of a target's own imported clip against san_protocol's float64 forward kinematics:
# Blender keeps bone matrices and keys in float32 (relative precision 6e-8) and a hand sits about ten
# joints from the root, each adding the rounding of a rotation and an offset of up to the body's size;
# measured at most 6.2e-6 of the height on these clips (Blender 3.4, 4.3 and 5.2; 1.4e-5 on the 909-frame
# Catwalk Walk in the bench), bounded at about 10x that.
SANITY = 5e-5
# What a retarget is asked to come within of Mixamo's own here, means over the clips (% of the height).
TARGET_ALL, TARGET_POSE = 3.0, 1.0
# MotionKit's defaults over these cases, measured on Blender 3.4, 4.3 and 5.2 (means, % of the height):
# what a change may not make worse by more than REGRESSION (about a millimetre on these 1.5 m characters;
# the figures agree across the Blenders to 1e-4 %).
MEASURED_ALL, MEASURED_POSE = 2.10, 0.49
REGRESSION = 0.05
# Two methods whose joints Blender evaluates alike differ by the evaluation's own noise (SANITY), in %: a
# retarget that keeps the plain copy's pose exactly ties with it to that.
TIE = 100 * SANITY

_results = {}


@pytest.fixture(scope="module")
def pairs(mk):
    """../shared/data/pairs: required under CI, a visible skip elsewhere."""
    if not os.path.isdir(os.path.join(SHARED, "data", "pairs", "san")):
        if os.environ.get("CI") == "true":
            pytest.fail(f"{SHARED}/data/pairs/san is missing, and CI=true requires it")
        pytest.skip(f"{SHARED}/data/pairs/san is absent (set up ../shared to run this test)")
    return SHARED


def measured(mk, shared, case):
    """The case's figures (plain copy and MotionKit's defaults), measured once per session."""
    if case not in _results:
        clip, source, target = case
        _results[case] = mp.measure_san(mk, shared, source, target, clip, methods=("plain copy", "MotionKit"))
    return _results[case]


def test_plain_copy_of_a_clip_onto_itself_is_the_clip(pairs):
    """The baseline's own check: copying a clip onto its own skeleton gives the clip back exactly."""
    clip = sp.read_bvh(mp.san_path(pairs, "Kaya", "Running"))
    np.testing.assert_allclose(sp.plain_copy(clip, clip), sp.clip_positions(clip), rtol=0, atol=1e-9)


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_blender_evaluates_the_target_clip_as_the_protocol(mk, pairs, case):
    """The protocol's sanity check: the target's own clip through Blender's BVH importer and evaluation
    (frame_set, pose bone heads in world) stands where the numpy reference puts it."""
    result = measured(mk, pairs, case)
    print(f"{case}: Blender against numpy {result['sanity']:.2e} of the height")
    assert result["sanity"] <= SANITY


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_motionkit_defaults_at_least_as_close_to_mixamo_as_the_plain_copy(mk, pairs, case):
    errors = measured(mk, pairs, case)["errors"]
    plain, ours = errors["plain copy"], errors["MotionKit"]
    print(f"{case}: all joints {ours['all']:.2f} % (plain copy {plain['all']:.2f} %), "
          f"pose alone {ours['pose']:.2f} % (plain copy {plain['pose']:.2f} %)")
    assert ours["all"] <= plain["all"] + TIE and ours["pose"] <= plain["pose"] + TIE, (ours, plain)


def test_motionkit_defaults_within_the_issue_targets_on_average(mk, pairs):
    """Mean over the clips: within 3 % of the height over all joints and 1 % for the pose alone (the issue's
    targets), and no worse than measured."""
    figures = [measured(mk, pairs, case)["errors"]["MotionKit"] for case in CASES]
    mean_all = float(np.mean([f["all"] for f in figures]))
    mean_pose = float(np.mean([f["pose"] for f in figures]))
    print(f"MotionKit's defaults: all joints {mean_all:.2f} %, pose alone {mean_pose:.2f} %")
    assert mean_all <= TARGET_ALL and mean_pose <= TARGET_POSE, (mean_all, mean_pose)
    assert mean_all <= MEASURED_ALL + REGRESSION and mean_pose <= MEASURED_POSE + REGRESSION, (mean_all, mean_pose)


# A pop is a joint's sudden change of speed: its largest second difference over the frames. Mixamo's own clip
# on the target has its own (a foot landing, 0.3-0.5 % of the height a frame squared on these clips); the
# retarget's hips and feet may land harder, not pop: measured at most 2.4 times Mixamo's own on Blender 3.4
# (Getting Up's toes; 6 times when a foot's lift off the floor was eased out over a tenth of a second
# whatever its size), bounded at 3 times.
POP_RATIO = 3.0
POP_JOINTS = ("Hips", "LeftFoot", "RightFoot", "LeftToeBase", "RightToeBase")


def largest_jolt(joints) -> float:
    """The largest second difference of any of POP_JOINTS over the frames (metres)."""
    picked = joints[:, [sp.BODY_JOINTS.index(j) for j in POP_JOINTS]]
    return float(np.linalg.norm(np.diff(picked, 2, axis=0), axis=-1).max())


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_motionkit_hips_and_feet_land_no_harder_than_mixamo_s_by_a_pop(mk, pairs, case):
    result = measured(mk, pairs, case)
    ours, theirs = largest_jolt(result["positions"]["MotionKit"]), largest_jolt(result["reference"])
    print(f"{case}: largest jolt of the hips and feet {100 * ours / result['height']:.2f} % of the height "
          f"(Mixamo's own {100 * theirs / result['height']:.2f} %)")
    assert ours <= POP_RATIO * theirs, (ours, theirs)

# Four more characters of the same set (tests/data/mixamo_excerpts: Mixamo's own clips on each, a run of frames
# from the start of Jumping and one from the middle of each of the four clips), each the target of Aj's and
# Kaya's whole clip: characters MotionKit was not tuned on.
EXCERPT_CASES = [(source, target, clip, part) for source in ("Aj", "Kaya") for target in mp.EXCERPT_CHARACTERS
                 for clip, part in mp.EXCERPT_RUNS]
EXCERPT_IDS = [f"{clip}-{part}-{a}-to-{b}" for a, b, clip, part in EXCERPT_CASES]
# Blender's evaluation of an excerpt against the numpy reference, measured on Blender 3.4 and 5.2: at most
# 9.7e-5 of the height over all joints (BigVegas's root, 4.7 m out along his Catwalk Walk, imported 0.17 mm
# from the file's; 5.4e-6 on the other characters) and 1.6e-5 relative to the hips (where the root's offset
# cancels); bounded at about 10x each. Two methods whose joints Blender evaluates alike tie to the bound, in %
# (EXCERPT_TIE over all joints, EXCERPT_POSE_TIE for the pose alone).
EXCERPT_SANITY, EXCERPT_POSE_SANITY = 1e-3, 2e-4
EXCERPT_TIE, EXCERPT_POSE_TIE = 100 * EXCERPT_SANITY, 100 * EXCERPT_POSE_SANITY
# MotionKit's defaults over these 40 retargets on Blender 3.4 (means, % of the height; the plain copy 11.01 and
# 0.92): what a change may not make worse by more than REGRESSION; closer than the copy on average. The known
# gap (the xfail below): how far Mixamo carries each character across the floor (its path's scale is
# none of the skeleton's measures: docs/benchmarks.md), and the legs of some of them.
EXCERPT_MEASURED_ALL, EXCERPT_MEASURED_POSE = 10.47, 0.90
# The same for the hips' height alone (mean distance along up from Mixamo's, % of the height; the copy 3.46,
# MotionKit 3.12 while its hips kept the source's scaled height wherever the legs could reach the floor).
EXCERPT_MEASURED_HIPS_HEIGHT = 2.68
_excerpts = {}


def measured_excerpt(mk, shared, case):
    if case not in _excerpts:
        source, target, clip, part = case
        _excerpts[case] = mp.measure_excerpt(mk, mp.san_path(shared, source, clip), target, part, clip=clip)
    return _excerpts[case]


@pytest.mark.parametrize("case", EXCERPT_CASES, ids=EXCERPT_IDS)
def test_blender_evaluates_each_excerpt_as_the_protocol(mk, pairs, case):
    result = measured_excerpt(mk, pairs, case)
    errors = result["errors"]
    print(f"{case}: frames {result['start']}+{result['frames']}, sanity {result['sanity']:.1e} "
          f"(pose {result['pose_sanity']:.1e}); all joints {errors['MotionKit']['all']:.2f} % (plain copy "
          f"{errors['plain copy']['all']:.2f} %), pose alone {errors['MotionKit']['pose']:.2f} % (plain copy "
          f"{errors['plain copy']['pose']:.2f} %)")
    assert result["sanity"] <= EXCERPT_SANITY and result["pose_sanity"] <= EXCERPT_POSE_SANITY


def test_motionkit_defaults_on_more_characters_closer_than_the_copy_on_average(mk, pairs):
    figures = [measured_excerpt(mk, pairs, case)["errors"] for case in EXCERPT_CASES]
    ours = {k: float(np.mean([f["MotionKit"][k] for f in figures])) for k in ("all", "pose")}
    plain = {k: float(np.mean([f["plain copy"][k] for f in figures])) for k in ("all", "pose")}
    print(f"more characters: MotionKit all joints {ours['all']:.2f} %, pose alone {ours['pose']:.2f} % "
          f"(plain copy {plain['all']:.2f} %, {plain['pose']:.2f} %)")
    assert ours["all"] <= plain["all"] and ours["pose"] <= plain["pose"] + EXCERPT_POSE_TIE, (ours, plain)
    assert ours["all"] <= EXCERPT_MEASURED_ALL + REGRESSION and ours["pose"] <= EXCERPT_MEASURED_POSE + REGRESSION


def _hips_height_error(result, method):
    """Mean distance along up (Blender's Z) of the hips from Mixamo's, % of the height."""
    positions = result["positions"][method]
    return 100 * float(np.abs(positions[:, 0, 2] - result["reference"][:, 0, 2]).mean()) / result["height"]


def test_a_crouching_or_walking_body_settles_its_hips_as_mixamo_s_does(mk, pairs):
    """Where the feet would float the hips come down until they stand, the legs keeping the source's bend:
    Goblin's bent knees crouch (Getting Up) and walk (Catwalk Walk) at Mixamo's height, closer than the copy
    on each of those four (MotionKit 2.8-7.3 % of his height off while it held the source's scaled height,
    the copy 2.8-8.7), and over all 40 the hips' height no farther from Mixamo's than measured."""
    goblin = [case for case in EXCERPT_CASES if case[1] == "Goblin_m" and case[2] in ("Getting Up", "Catwalk Walk")]
    for case in goblin:
        result = measured_excerpt(mk, pairs, case)
        ours, plain = _hips_height_error(result, "MotionKit"), _hips_height_error(result, "plain copy")
        print(f"{case}: hips' height {ours:.2f} % of the height from Mixamo's (plain copy {plain:.2f} %)")
        assert ours <= plain, (case, ours, plain)
    means = {m: float(np.mean([_hips_height_error(measured_excerpt(mk, pairs, case), m) for case in EXCERPT_CASES]))
             for m in ("MotionKit", "plain copy")}
    print(f"hips' height over the 40: MotionKit {means['MotionKit']:.2f} %, plain copy {means['plain copy']:.2f} %")
    assert means["MotionKit"] <= min(means["plain copy"], EXCERPT_MEASURED_HIPS_HEIGHT + REGRESSION), means


JUMPING_CASES = [case for case in EXCERPT_CASES if case[2] == "Jumping"]


@pytest.mark.parametrize("case", JUMPING_CASES, ids=[f"{c}-{p}-{a}-to-{b}" for a, b, c, p in JUMPING_CASES])
def test_motionkit_keeps_each_character_s_pose_as_mixamo_does(mk, pairs, case):
    """The pose alone at least as close as the plain copy (which has Mixamo's own upper-body rotations): Goblin's
    and Mousey's `*_split` clavicles (2.8-4.3 % of the height off the copy's when the clavicle was aimed at its
    split joint, 60 degrees up its chest) included. Jumping's: on the other clips some legs trail (the xfail
    below)."""
    errors = measured_excerpt(mk, pairs, case)["errors"]
    assert errors["MotionKit"]["pose"] <= errors["plain copy"]["pose"] + EXCERPT_POSE_TIE, errors


# Catwalk Walk's 8 with Mixamo's own stride given (Scale Horizontal, mixamo_pairs.STRIDE): MotionKit measured
# 1.77 % of the height over all joints on average on Blender 3.4 (1.47-2.09 each; 23.05 with its defaults, the
# copy 23.57). The factor is read from these same files (MIXAMO_STRIDE): what this shows is that the one number
# Mixamo takes from outside the skeleton is all that keeps its defaults off Mixamo's walk.
STRIDE_MEASURED_ALL = 1.77


def test_given_mixamo_s_stride_the_walk_lands_on_mixamo_s(mk, pairs):
    cases = [case for case in EXCERPT_CASES if case[2] == "Catwalk Walk"]
    given = []
    for case in cases:
        source, target, clip, part = case
        errors = mp.measure_excerpt(mk, mp.san_path(pairs, source, clip), target, part, (mp.STRIDE,),
                                    clip=clip)["errors"][mp.STRIDE]
        defaults = measured_excerpt(mk, pairs, case)["errors"]["MotionKit"]
        print(f"{case}: given Mixamo's stride {errors['all']:.2f} % over all joints, {errors['pose']:.2f} % in the "
              f"pose (defaults {defaults['all']:.2f} %, {defaults['pose']:.2f} %)")
        assert errors["all"] < defaults["all"], case
        given.append(errors["all"])
    assert float(np.mean(given)) <= STRIDE_MEASURED_ALL + REGRESSION, given


@pytest.mark.xfail(strict=True, reason="what is left: over all joints MotionKit trails the copy on 11 of the 40 "
                                       "(10 from Kaya: Mixamo's path across the floor scales apart from any skeleton "
                                       "measure; Granny's Getting Up from Aj by 0.12 %), and the pose alone on 5 "
                                       "(legs: Goblin's Getting Up from both and Catwalk from Aj, Mousey's Getting "
                                       "Up and Granny's Catwalk from Kaya; 0.03-0.45 %)")
def test_motionkit_defaults_on_more_characters_at_least_as_close_as_the_plain_copy(mk, pairs):
    behind = []
    for case in EXCERPT_CASES:
        errors = measured_excerpt(mk, pairs, case)["errors"]
        plain, ours = errors["plain copy"], errors["MotionKit"]
        if not (ours["all"] <= plain["all"] + EXCERPT_TIE and ours["pose"] <= plain["pose"] + EXCERPT_POSE_TIE):
            behind.append(case)
    assert not behind, behind


# girl2 onto girl1 (../shared/data/pairs/fbx), girl1 playing another clip of her own when the retarget starts,
# as a character downloaded from Mixamo with an animation does (her rest's hips sit at her origin, 55 % of her
# height above the floor her clips walk on: her own clip tells where that floor is).
OWN_CASES = [("Happy Walk Backward", "Right Strafe Walk"), ("Right Strafe Walk", "Left Strafe Walk")]
# The whole body's error beyond the pose's alone: where she stands. Measured at most 1.02 % of her height on
# Blender 3.4 (the hips' path scaled by the legs' ratio, her feet on her floor); 43-53 % when her rest's soles
# were taken for her floor. Bounded at 2 %: about a twentieth of a stride, far under the defect's size.
STANDS_OFF = 2.0


@pytest.mark.parametrize("clip,own", OWN_CASES, ids=[c for c, _ in OWN_CASES])
def test_a_target_playing_its_own_clip_stands_on_the_floor_that_clip_walks_on(mk, pairs, clip, own):
    """girl2's clip onto girl1 playing one of her other clips: the whole body stands where Mixamo's girl1
    stands (its error beyond the pose alone within STANDS_OFF); on Happy Walk Backward, where the two
    characters' objects stand alike, at least as close as the plain copy in both measures."""
    result = mp.measure_fbx(mk, pairs, "girl2", "girl1", clip, methods=("plain copy", "MotionKit"), own=own)
    plain, ours = result["errors"]["plain copy"], result["errors"]["MotionKit"]
    print(f"{clip} girl2 -> girl1 playing {own}: all joints {ours['all']:.2f} % (plain copy {plain['all']:.2f} %), "
          f"pose alone {ours['pose']:.2f} % (plain copy {plain['pose']:.2f} %)")
    assert ours["all"] - ours["pose"] <= STANDS_OFF, ours
    if clip == "Happy Walk Backward":
        assert ours["all"] <= plain["all"] + TIE and ours["pose"] <= plain["pose"] + TIE, (ours, plain)


# Characters made from the excerpts (tests/common/made_characters.py), each still answered by its own Mixamo clip:
# a `*_split` joint on one side only, on its parent's head (its parent then points nowhere of its own), off the
# line between its neighbours, or taken out, in the spine or one clavicle. No rule tuned to the characters at
# hand passes them all: a retarget that copies each mapped joint's turn and leaves the splits unturned, as
# Mixamo does, ties the copy on every one, both ways.
def _made(bvh, variant):
    joint = "LeftShoulder_split" if variant.startswith("shoulder") else "Spine1_split"
    (child,) = made.children(bvh, bvh.index(joint))
    whole = bvh.offsets[bvh.index(joint)] + bvh.offsets[child]
    if variant.endswith("on its parent"):
        return made.with_joint_moved(bvh, joint, np.zeros(3))
    if variant.endswith("off the line"):  # half the span out to the side: 27 degrees off it
        side = np.cross(whole, [0.0, 0.0, 1.0] if variant.startswith("shoulder") else [1.0, 0.0, 0.0])
        return made.with_joint_moved(bvh, joint, 0.5 * whole + 0.25 * np.linalg.norm(whole) * side
                                     / np.linalg.norm(side))
    return made.without_joint(bvh, joint)


# The pose alone over every joint: the legs hold planted feet where the copy lets them slide, so they may part
# from the copy's by a little: 0.25 % of the height (4 mm on these characters), what "no worse than the copy"
# allows a character no one here has seen.
POSE_ALLOWED = 0.25
MADE_VARIANTS = ("spine split on its parent", "spine split off the line", "spine split taken out",
                 "shoulder split on its parent", "shoulder split off the line")
MADE_CASES = [(character, variant, way) for character, variant in
              [("Goblin_m", v) for v in MADE_VARIANTS] + [("Mousey_m", MADE_VARIANTS[0])]
              for way in ("onto", "from")]


@pytest.mark.parametrize("case", MADE_CASES, ids=[f"Aj-{w}-{c}-{v.replace(' ', '-')}" for c, v, w in MADE_CASES])
def test_a_split_joint_on_one_side_only_keeps_the_pose_of_a_plain_copy(mk, pairs, case, tmp_path):
    character, variant, way = case
    path = str(tmp_path / "made.bvh")
    made.write_bvh(_made(sp.read_bvh(mp.excerpt_path(character, "mid", "Running")), variant), path)
    result = mp.measure_made(mk, mp.san_path(pairs, "Aj", "Running"), path, way == "from", str(tmp_path))
    errors = result["errors"]
    print(f"{case}: pose alone {errors['MotionKit']['pose']:.3f} % (plain copy {errors['plain copy']['pose']:.3f} %), "
          f"all joints {errors['MotionKit']['all']:.2f} % ({errors['plain copy']['all']:.2f} %)")
    assert result["pose_sanity"] <= EXCERPT_POSE_SANITY
    joints = result["joint_pose"]
    upper = [j for j, name in enumerate(sp.BODY_JOINTS) if not any(k in name for k in ("Leg", "Foot", "Toe"))]
    behind = {sp.BODY_JOINTS[j]: round(float(joints["MotionKit"][j] - joints["plain copy"][j]), 3) for j in upper
              if joints["MotionKit"][j] > joints["plain copy"][j] + EXCERPT_POSE_TIE}
    assert not behind, behind  # the trunk, head and arms: the copy's to the evaluation's noise
    assert errors["MotionKit"]["pose"] <= errors["plain copy"]["pose"] + POSE_ALLOWED, errors
    if way == "onto":  # the other way the answer is Aj's clip cut short, standing where the excerpt's first frame is
        assert errors["MotionKit"]["all"] <= errors["plain copy"]["all"] + EXCERPT_TIE, errors
