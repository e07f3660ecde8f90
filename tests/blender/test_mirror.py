"""motionkit.mirror in a real Blender: mirroring twice gives the action back, a capture's and a Mixamo FBX
clip's joints land on the reflections of their partners', rolls and rests that are not mirror images,
centre bones, a prop without a partner, another armature, root motion, an unpaired marker, the operator,
and the side names against Blender's own flip_name.

Positions and orientations are read through Blender's own evaluation (frame_set, pose_bone.head,
pose_bone.matrix), never the mirror's own numbers.
"""
import importlib
import math
import os

import bpy
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

FRAMES = np.arange(1, 25, dtype=np.float64)
REFLECT_X = np.diag([-1.0, 1.0, 1.0])

# name, parent, head, tail (the .R side is the .L side with x negated)
_LEFT = [("upper_arm.L", "spine", (0.2, 0.0, 1.45), (0.45, 0.03, 1.3)),
         ("forearm.L", "upper_arm.L", (0.45, 0.03, 1.3), (0.7, 0.05, 1.2)),
         ("hand.L", "forearm.L", (0.7, 0.05, 1.2), (0.8, 0.05, 1.15)),
         ("thigh.L", "hips", (0.1, 0.0, 1.0), (0.11, -0.02, 0.55)),
         ("shin.L", "thigh.L", (0.11, -0.02, 0.55), (0.1, 0.0, 0.1))]
_CENTRE = [("hips", None, (0.0, 0.0, 1.0), (0.0, 0.0, 1.1)), ("spine", "hips", (0.0, 0.0, 1.1), (0.0, 0.02, 1.5)),
           ("head", "spine", (0.0, 0.02, 1.5), (0.0, 0.02, 1.7))]
_PROP = ("prop", "hand.R", (-0.8, 0.05, 1.15), (-0.8, 0.3, 1.15))
MODES = {"hips": "QUATERNION", "spine": "XYZ", "upper_arm.L": "ZXY", "upper_arm.R": "QUATERNION",
         "forearm.R": "YZX", "hand.L": "AXIS_ANGLE", "prop": "XYZ"}


def _body(name="Body", rolls=None, left_only=False, bend=0.0):
    """An armature of a small body, symmetric about X = 0 in its heads; rolls {bone: radians} (default 0,
    which Blender mirrors onto 0), bend: how far the left forearm's tail moves off the right's mirror image;
    left_only: hand.R renamed so that hand.L has no partner."""
    rolls = rolls or {}
    armature = bpy.data.armatures.new(name)
    obj = bpy.data.objects.new(name, armature)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode='EDIT')
    right = [(n[:-1] + "R", p if p in ("spine", "hips") else p[:-1] + "R", (-h[0], h[1], h[2]), (-t[0], t[1], t[2]))
             for n, p, h, t in _LEFT]
    for bone_name, parent, head, tail in _CENTRE + _LEFT + right + [_PROP]:
        bone = armature.edit_bones.new(bone_name)
        bone.head, bone.tail, bone.roll = head, tail, rolls.get(bone_name, 0.0)
        if bone_name == "forearm.L":
            bone.tail = (tail[0], tail[1] + bend, tail[2] - bend)
        bone.parent = armature.edit_bones[parent] if parent else None
    if left_only:
        armature.edit_bones["hand.R"].name = "glove"
    bpy.ops.object.mode_set(mode='OBJECT')
    for bone_name, mode in MODES.items():
        if bone_name in obj.pose.bones:
            obj.pose.bones[bone_name].rotation_mode = mode
    return obj


def _random_rolls(seed):
    rng = np.random.default_rng(seed)
    return {n: float(rng.uniform(-math.pi, math.pi)) for n, *_ in _CENTRE + _LEFT}  \
        | {n[:-1] + "R": float(rng.uniform(-math.pi, math.pi)) for n, *_ in _LEFT}


def _key(mk, animdata, obj, seed=1, root_x=0.0, frames=FRAMES):
    """Keys every bone with a smooth rotation in its own mode, and the hips' location moving root_x per
    frame along armature X over a small sway."""
    rng = np.random.default_rng(seed)
    action = animdata.new_action(f"{obj.name}Action")
    animdata.assign(obj, action)
    t = frames / 24.0
    for pose_bone in obj.pose.bones:
        waves = sum(rng.normal(0.0, 0.35, 3) * np.sin(2 * math.pi * hz * t[:, None] + rng.uniform(0, 6, 3))
                    for hz in (0.3, 0.7))
        xyzw = Rotation.from_rotvec(waves).as_quat()
        values = mk.rotation_channels.from_quaternions(mk.native(), pose_bone.rotation_mode,
                                                       np.hstack([xyzw[:, 3:], xyzw[:, :3]]))
        path, size = mk.rotation_channels.channel_property(pose_bone.rotation_mode)
        name = pose_bone.name
        animdata.write_keys(obj, action, [(f'pose.bones["{name}"].{path}', k, name) for k in range(size)],
                            frames, values.T, 'BEZIER')
    # The root's location channel is in its rest frame: head = rest head + Rest location.
    rest = np.array(obj.data.bones["hips"].matrix_local.to_3x3())
    moved = np.stack([root_x * (frames - frames[0]), 0.02 * np.sin(frames), 0.0 * frames], axis=1) @ rest
    animdata.write_keys(obj, action, [('pose.bones["hips"].location', k, "hips") for k in range(3)], frames,
                        moved.T, 'BEZIER')
    return action


def _posed(obj, frames):
    """Blender's evaluation: heads and tails (frames, 2 bones, 3: every head, then every tail) and
    orientations (frames, bones, 3, 3) in armature space, in the order of obj.pose.bones."""
    points, turns = [], []
    for f in frames:
        bpy.context.scene.frame_set(int(f))
        points.append([tuple(pb.head) for pb in obj.pose.bones] + [tuple(pb.tail) for pb in obj.pose.bones])
        turns.append([np.array(pb.matrix.to_3x3()) for pb in obj.pose.bones])
    return np.array(points), np.array(turns)


def _names(obj):
    return [pb.name for pb in obj.pose.bones]


@pytest.fixture(scope="module")
def side_names(mk):
    return importlib.import_module(mk.__name__ + ".core.side_names")


def _partner_columns(side_names, names, target_names=None):
    """Per bone of target_names (default names), its partner's index in names."""
    index = {n: i for i, n in enumerate(names)}
    return [index[side_names.flip_name(n)] for n in (target_names or names)]


def _curves(animdata, obj, action):
    return {(fc.data_path, fc.array_index): fc for fc in animdata.fcurves(action, obj)}


def _reflection_error(before, after, partners, reflect=REFLECT_X, skip=(), tails=True):
    """The worst distance between each bone's head (and tail) after and its partner's before, reflected;
    before and after as _posed gives them. tails=False: heads only (bones whose rests differ from their
    partners' in length or direction put their tails elsewhere)."""
    count = len(partners)
    columns = list(partners) + [count + p for p in partners]  # the partner's head, then its tail
    want = before[:, columns] @ reflect.T
    keep = [b for b in range(count) if b not in skip]
    keep += [count + b for b in keep] if tails else []
    return float(np.max(np.linalg.norm(after[:, keep] - want[:, keep], axis=-1)))


def test_mirroring_twice_gives_the_action_back(mk, animdata):
    """Every curve of the original, evaluated by Blender on and between the keys, comes back within 1e-6,
    whatever the rotation modes and rolls."""
    obj = _body(rolls=_random_rolls(4))
    original = _key(mk, animdata, obj, root_x=0.05)
    once = mk.mirror(obj)
    assert animdata.assigned_action(obj).name == once.action != original.name
    twice = mk.mirror(obj)
    back = _curves(animdata, obj, bpy.data.actions[twice.action])
    times = np.arange(FRAMES[0], FRAMES[-1] + 1e-9, 0.25)
    worst = 0.0
    for key, fcurve in _curves(animdata, obj, original).items():
        assert key in back, key
        worst = max(worst, max(abs(fcurve.evaluate(t) - back[key].evaluate(t)) for t in times))
    assert worst < 1e-6, worst


def test_a_mirrored_walk_has_the_reflected_world_joint_positions(mk, walk60, side_names):
    obj, action = mk.bvh.load(walk60)
    frames = np.linspace(*action.frame_range, 7).round()
    before, _ = _posed(obj, frames)
    report = mk.mirror(obj)
    after, _ = _posed(obj, frames)
    assert report.kept_local == [] and ("lHip", "rHip") in [tuple(sorted(p)) for p in report.pairs]
    height = float(np.ptp(before[..., 2]))
    assert _reflection_error(before, after, _partner_columns(side_names, _names(obj))) < 1e-5 * height
    assert np.max(np.abs(before[..., 0])) > 0.1 * height  # the limbs do stand off the plane


@pytest.fixture()
def punch(shared_dir):
    path = os.path.join(shared_dir, "data", "fbx", "ybot@punch.fbx")
    if not os.path.isfile(path):
        if os.environ.get("CI") == "true":
            pytest.fail(f"{path} is missing, and CI=true requires it")
        pytest.skip(f"{path} is absent")
    before = set(bpy.data.objects)
    bpy.ops.import_scene.fbx(filepath=path)
    return next(o for o in bpy.data.objects if o not in before and o.type == 'ARMATURE')


def test_a_mixamo_clip_mirrored_puts_the_left_hand_where_the_right_was(mk, animdata, punch, side_names):
    action = animdata.assigned_action(punch)
    frames = np.linspace(*action.frame_range, 6).round()
    before, _ = _posed(punch, frames)
    report = mk.mirror(punch)
    after, _ = _posed(punch, frames)
    names = _names(punch)
    assert ("mixamorig:LeftHand", "mixamorig:RightHand") in report.pairs + [p[::-1] for p in report.pairs]
    assert "mixamorig:Hips" in report.centre and report.kept_local == []
    height = float(np.ptp(before[..., 1]))  # Mixamo's armature space is Y-up
    assert _reflection_error(before, after, _partner_columns(side_names, names)) < 1e-5 * height
    left, right = names.index("mixamorig:LeftHand"), names.index("mixamorig:RightHand")
    assert np.max(np.linalg.norm(after[:, left] - before[:, right] @ REFLECT_X, axis=-1)) < 1e-5 * height
    assert np.max(np.linalg.norm(after[:, left] - before[:, left], axis=-1)) > 0.05 * height  # it did move


def test_rolls_and_rests_that_are_not_mirror_images(mk, animdata, side_names):
    """Each bone turns from its own rest as its partner turned from its rest, reflected: R'_b Rest_b^-1 =
    L (R_p Rest_p^-1) L as whole rotations, and heads land on the partners' reflected heads."""
    obj = _body(rolls=_random_rolls(9), bend=0.08)
    _key(mk, animdata, obj, seed=5, root_x=0.03)
    frames = FRAMES[::5]
    before, turns_before = _posed(obj, frames)
    mk.mirror(obj)
    after, turns_after = _posed(obj, frames)
    names = _names(obj)
    partners = _partner_columns(side_names, names)
    rests = np.array([np.array(obj.data.bones[n].matrix_local.to_3x3()) for n in names])
    skip = {names.index("prop")}
    assert _reflection_error(before, after, partners, skip=skip, tails=False) < 1e-5
    bent = skip | {names.index("forearm.L"), names.index("forearm.R")}  # their tails are not mirror images
    assert _reflection_error(before, after, partners, skip=bent) < 1e-5
    for b, p in enumerate(partners):
        if b in skip:
            continue
        mirrored = turns_after[:, b] @ rests[b].T
        want = REFLECT_X @ turns_before[:, p] @ rests[p].T @ REFLECT_X
        assert np.max(np.abs(mirrored - want)) < 1e-5, names[b]


def test_centre_bones_are_mirrored_onto_themselves(mk, animdata):
    """The spine turned about the up axis turns the other way; the report names the centre bones."""
    obj = _body()
    action = animdata.new_action("Twist")
    animdata.assign(obj, action)
    angles = np.radians([0.0, 30.0])
    animdata.write_keys(obj, action, [('pose.bones["spine"].rotation_euler', k, "spine") for k in range(3)],
                        [1.0, 2.0], [[0.0, 0.0], angles, [0.0, 0.0]])  # about the bone's Y: the spine's length
    report = mk.mirror(obj)
    assert sorted(report.centre) == ["head", "hips", "spine"]
    bpy.context.scene.frame_set(2)
    assert obj.pose.bones["spine"].rotation_euler[1] == pytest.approx(-math.radians(30.0), abs=1e-6)


def test_a_prop_without_partner_keeps_its_local_transform(mk, animdata):
    obj = _body()
    original = _key(mk, animdata, obj, seed=2)
    report = mk.mirror(obj)
    assert report.kept_local == ["prop"]
    back = _curves(animdata, obj, animdata.assigned_action(obj))
    for (path, index), fcurve in _curves(animdata, obj, original).items():
        if '"prop"' in path:
            assert max(abs(fcurve.evaluate(f) - back[(path, index)].evaluate(f)) for f in FRAMES) < 1e-6


def test_onto_another_armature(mk, animdata, side_names):
    """The other armature (other rolls, same names) plays the mirrored motion; the source keeps its own."""
    source = _body("Source", rolls=_random_rolls(1))
    target = _body("Target", rolls=_random_rolls(2))
    action = _key(mk, animdata, source, seed=3, root_x=0.02)
    frames = FRAMES[::6]
    before, _ = _posed(source, frames)
    report = mk.mirror(source, target=target, action_name="Onto")
    assert animdata.assigned_action(source) == action
    assert report.action == "Onto" and animdata.assigned_action(target).name == "Onto"
    after, _ = _posed(target, frames)
    partners = _partner_columns(side_names, _names(source), _names(target))
    assert _reflection_error(before, after, partners, skip={_names(target).index("prop")}) < 1e-5


def test_root_motion_is_mirrored(mk, animdata):
    """The hips walking 5 cm a frame along +X walk along -X."""
    obj = _body()
    _key(mk, animdata, obj, root_x=0.05)
    bpy.context.scene.frame_set(int(FRAMES[-1]))
    x_before = obj.pose.bones["hips"].head.x
    mk.mirror(obj)
    bpy.context.scene.frame_set(int(FRAMES[-1]))
    assert x_before > 1.0
    assert obj.pose.bones["hips"].head.x == pytest.approx(-x_before, abs=1e-5)


def test_the_plane_can_be_moved_or_given(mk, animdata):
    """Across X = 0.5 a head at x lands at 1 - x; a (normal, point) plane says the same."""
    for plane in ({"plane": "X", "plane_offset": 0.5}, {"plane": ((2.0, 0.0, 0.0), (0.5, 0.0, 0.0))}):
        obj = _body(f"Body{len(bpy.data.objects)}")
        _key(mk, animdata, obj, seed=6)
        before, _ = _posed(obj, FRAMES[:1])
        mk.mirror(obj, **plane)
        after, _ = _posed(obj, FRAMES[:1])
        names = _names(obj)
        hand, partner = names.index("hand.L"), names.index("hand.R")
        assert after[0, hand] == pytest.approx(before[0, partner] * [-1, 1, 1] + [1.0, 0, 0], abs=1e-5)


def test_a_frame_range_mirrors_those_frames_only(mk, animdata):
    obj = _body()
    _key(mk, animdata, obj, seed=8, frames=np.array([1.0, 4.0, 9.0, 15.0]))
    calls = []
    report = mk.mirror(obj, frame_range=(3, 12), progress=lambda done, total: calls.append((done, total)))
    keys = {tuple(k.co[0] for k in fc.keyframe_points) for fc in animdata.fcurves(animdata.assigned_action(obj), obj)}
    assert keys == {(3.0, 4.0, 9.0, 12.0)} and report.frames == 4  # the range's ends and the keys inside it
    assert calls and calls[0] == (0, 2)


def _snapshot(animdata, obj):
    """Every action's keys as obj would play them."""
    return {a.name: {(fc.data_path, fc.array_index): tuple(k.co[1] for k in fc.keyframe_points)
                     for fc in animdata.fcurves(a, obj)} for a in bpy.data.actions}


def test_an_unpaired_marker_raises_naming_the_bone_and_changes_nothing(mk, animdata):
    obj = _body(left_only=True)
    action = _key(mk, animdata, obj)
    before = _snapshot(animdata, obj)
    with pytest.raises(ValueError, match=r"'hand\.L'.*'hand\.R' is missing"):
        mk.mirror(obj)
    assert animdata.assigned_action(obj) == action and _snapshot(animdata, obj) == before
    report = mk.mirror(obj, pairs=[("hand.L", "glove")])  # pairing them by hand mirrors
    assert ("hand.L", "glove") in report.pairs + [p[::-1] for p in report.pairs]


def test_bad_input_is_refused(mk, animdata):
    obj = _body()
    with pytest.raises(ValueError, match="no action"):
        mk.mirror(obj)
    _key(mk, animdata, obj)
    for options, message in ((dict(plane="W"), "unknown plane"), (dict(plane=((0, 0, 0), (0, 0, 0))), "non-zero"),
                             (dict(frame_range=(500, 600)), "no bone keys"),
                             (dict(target=bpy.data.objects.new("Empty", None)), "not an armature")):
        with pytest.raises(ValueError, match=message):
            mk.mirror(obj, **options)
    assert len(bpy.data.actions) == 1


def test_an_action_without_bone_keys_is_named(mk, animdata):
    obj = _body()
    animdata.assign(obj, animdata.new_action("Empty"))
    before = _snapshot(animdata, obj)
    with pytest.raises(ValueError, match=r"^'Empty' has no bone keys to mirror$"):
        mk.mirror(obj)
    assert _snapshot(animdata, obj) == before and len(bpy.data.actions) == 1


def test_a_nan_key_is_named_and_changes_nothing(mk, animdata):
    """A NaN in the source action is refused naming the bone's curve and the frame, not spread into the
    mirrored action."""
    obj = _body()
    action = _key(mk, animdata, obj)
    curve = next(fc for fc in animdata.fcurves(action, obj) if fc.data_path == 'pose.bones["forearm.R"].rotation_euler')
    curve.keyframe_points[4].co.y = float("nan")
    keys = [tuple(k.co) for k in curve.keyframe_points]
    with pytest.raises(ValueError, match=r'^mirror: \'Body\' pose\.bones\["forearm\.R"\]\.rotation_euler\[' +
                       str(curve.array_index) + r"\] has a non-finite key at frame 5; nothing was changed$"):
        mk.mirror(obj)
    assert set(bpy.data.actions) == {action} and animdata.assigned_action(obj) == action
    assert np.array_equal(np.array([tuple(k.co) for k in curve.keyframe_points]), np.array(keys), equal_nan=True)


def test_linked_data_is_refused_naming_its_library(mk, animdata, tmp_path):
    """An armature linked from another .blend (library data) cannot take a new action here: the error names
    the object and its library, and nothing is added."""
    obj = _body("Linked")
    _key(mk, animdata, obj)
    path = str(tmp_path / "library.blend")
    bpy.data.libraries.write(path, {obj}, fake_user=True)
    bpy.data.objects.remove(obj)
    with bpy.data.libraries.load(path, link=True) as (data_from, data_to):
        data_to.objects = ["Linked"]
    linked = data_to.objects[0]
    bpy.context.scene.collection.objects.link(linked)
    assert linked.library is not None and animdata.assigned_action(linked) is not None
    local = _body("Local")
    _key(mk, animdata, local)
    try:
        before = _snapshot(animdata, linked), set(bpy.data.actions), set(bpy.data.objects)
        with pytest.raises(ValueError, match=r"^'Linked' is linked from '.*library\.blend' and cannot be keyed here"):
            mk.mirror(linked)
        with pytest.raises(ValueError, match=r"^'Linked' is linked from"):  # as the target of another's mirror
            mk.mirror(local, target=linked)
        assert (_snapshot(animdata, linked), set(bpy.data.actions), set(bpy.data.objects)) == before
    finally:
        bpy.data.libraries.remove(linked.library)  # its linked objects, armatures and actions with it


def test_the_operator_mirrors_the_active_armature(mk, animdata):
    obj = _body()
    bpy.context.view_layer.objects.active = obj
    assert not bpy.ops.motionkit.mirror_action.poll()
    action = _key(mk, animdata, obj)
    assert bpy.ops.motionkit.mirror_action('EXEC_DEFAULT', action_name="Flipped") == {'FINISHED'}
    assert animdata.assigned_action(obj).name == "Flipped" and action.use_fake_user


# Names Blender's rule covers: a letter after a separator at the end (before a number), one before a
# separator at the start, Left or Right at the very start or end.
BLENDER_RULE = ["hand.L", "hand.R", "upperarm_l", "foot.r", "shin-L", "arm L", "thigh.L.001", "finger_r.012",
                "L_hand", "r_foot", "L.arm", "LeftArm", "RightUpLeg", "hand_left", "right_toe", "HandRight",
                "LEFT_ARM", "ARM_RIGHT", "hips", "Spine1", "head", "root.001"]


def test_side_names_agree_with_blenders_flip_name(side_names):
    for name in BLENDER_RULE:
        assert side_names.flip_name(name) == bpy.utils.flip_name(name), name
    # Left and Right inside a name (Mixamo's) Blender leaves alone; the add-on pairs them.
    assert bpy.utils.flip_name("mixamorig:LeftHandIndex1") == "mixamorig:LeftHandIndex1"
    assert side_names.flip_name("mixamorig:LeftHandIndex1") == "mixamorig:RightHandIndex1"
