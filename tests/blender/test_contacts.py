"""motionkit.contacts: foot contacts on the action and footskate cleanup, checked with Blender's own
evaluation (scene.frame_set and the pose bones' heads and tails) on every real capture."""
import glob
import importlib
import os
import time

import bpy
import numpy as np
import pytest

import characters
import generate
import made_characters as made
import san_protocol as sp
import stances
from rotations import quaternion_angles

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BVH = os.path.join(os.path.dirname(ROOT), "shared", "data", "bvh")
CLIPS = sorted(os.path.relpath(p, BVH) for p in glob.glob(os.path.join(BVH, "*.bvh"))
               + glob.glob(os.path.join(BVH, "more", "*.bvh")))
MM = {"more/bandai_dash_normal_001.bvh": 0.1}  # armature units per millimetre (that file is in cm)
POP_ALLOWANCE = 5.0  # millimetres a frame, see check_plant
# A held point's slide: measured 0.0015 mm at most on Blender 3.4, 4.3 and 5.2 on the detected contacts (every
# capture and character), 0.0011 mm on the clear stances; about ten times that.
HELD_MM = 0.02


@pytest.fixture(scope="module")
def contacts(mk):
    return importlib.import_module(mk.__name__ + ".features.contacts")


@pytest.fixture(scope="module")
def pose_channels(mk):
    return importlib.import_module(mk.__name__ + ".blender.pose_channels")


def test_the_real_captures_are_there():
    """The captures test_plant_holds_every_contact_on_real_capture runs on: none found fails under CI=true
    (the parametrised test would be skipped unseen), and skips elsewhere."""
    if CLIPS:
        return
    message = f"no .bvh files under {BVH}"
    if os.environ.get("CI") == "true":
        pytest.fail(message + ", and CI=true requires them")
    pytest.skip(message)


def load(mk, path, name=None):
    obj, action = mk.bvh.load(path, name=name, update_scene_fps=True)
    return obj, action


def frames_of(action):
    start, end = action.frame_range
    return np.arange(int(start), int(end) + 1)


def evaluated(obj, frames):
    """World heads and tails of every pose bone (frames, bones, 2, 3), by Blender's depsgraph."""
    scene = bpy.context.scene
    world = np.array(obj.matrix_world)
    names = [b.name for b in obj.pose.bones]
    out = np.empty((len(frames), len(names), 2, 3))
    for i, f in enumerate(frames):
        scene.frame_set(int(f))
        for j, pose_bone in enumerate(obj.pose.bones):
            out[i, j, 0] = pose_bone.head
            out[i, j, 1] = pose_bone.tail
    return out @ world[:3, :3].T + world[:3, 3], names


def channels(obj, pose_channels, frames):
    action = obj.animation_data.action
    bones = pose_channels.depth_first(obj.data)
    rotations = pose_channels.rotations(obj, action, bones, frames.astype(np.float64))
    locations, _ = pose_channels.locations(obj, action, bones, frames.astype(np.float64))
    return [b.name for b in bones], rotations, locations


def knee_flexion(points, names, feet):
    """Per foot the thigh's and the shin's world vectors (frames, 3) each."""
    out = []
    for foot in feet:
        t = points[:, names.index(foot.thigh)]
        s = points[:, names.index(foot.shin)]
        thigh = t[:, 1] - t[:, 0]
        shin = s[:, 1] - s[:, 0]
        out.append((thigh, shin))
    return out


def signed_angles(thigh, shin, axis):
    cross = np.cross(thigh, shin)
    return np.arctan2(np.einsum("fk,fk->f", cross, axis), np.einsum("fk,fk->f", thigh, shin))


@pytest.mark.parametrize("clip", CLIPS)
def test_plant_holds_every_contact_on_real_capture(mk, contacts, pose_channels, clip, shared_dir):
    obj, action = load(mk, os.path.join(BVH, clip))
    check_plant(mk, contacts, pose_channels, obj, clip, MM.get(clip, 0.001))


@pytest.mark.parametrize("spec", characters.CHARACTERS, ids=lambda s: s.name)
def test_plant_on_walk60_retargeted_onto_each_sample_character(mk, contacts, pose_channels, walk60, spec):
    """Other proportions and bone rolls (the knees' hinge axis differs from rig to rig)."""
    source, _ = load(mk, walk60, "walk60")
    target = generate.build_armature(spec)
    mk.retarget(source, target)
    check_plant(mk, contacts, pose_channels, target, f"walk60 onto {spec.name}", 0.001)


def check_plant(mk, contacts, pose_channels, obj, clip, mm):
    """plant() on obj's action, then every check of the brief, measured by Blender's own evaluation."""
    action = obj.animation_data.action
    frames = frames_of(action)
    plain, names = evaluated(obj, frames)
    names_before, rot_before, loc_before = channels(obj, pose_channels, frames)
    started = time.perf_counter()
    report = contacts.plant(obj)
    elapsed = time.perf_counter() - started
    after, _ = evaluated(obj, frames)
    names_after, rot_after, loc_after = channels(obj, pose_channels, frames)
    feet = contacts.find_feet(obj)

    # Each contact held (every detected one but slides and pivots, which stand on the floor and move as the
    # clip moves them; foot_contacts.plantable): the point moves at most HELD_MM.
    worst = 0.0
    point_bones = [b for foot in feet for b in (foot.shin, foot.foot)]
    held = [[(frames[s], frames[e - 1]) for s, e in mk.foot_contacts.intervals(report.held[:, p])]
            for p in range(report.held.shape[1])]
    for p, runs in enumerate(held):
        j = names.index(point_bones[p])
        for first, last in runs:
            track = after[int(first - frames[0]):int(last - frames[0]) + 1, j, 1]
            worst = max(worst, float(np.max(np.linalg.norm(track - track[0], axis=1))))
    assert sum(len(r) for r in held) >= 2, held
    assert not (report.held & ~report.contacts).any()  # only contacts are held
    assert worst <= HELD_MM * mm, f"{clip}: a contact slides {worst / mm:.4f} mm"
    _check_stances(mk, action, clip, mm, plain, after, names, feet)

    # Only the legs' rotations and the hips' location changed; everything else equals the input.
    assert names_before == names_after
    changed = set(report.bones[1:])
    for j, name in enumerate(names_before):
        if name not in changed:
            assert np.max(np.abs(rot_after[:, 4 * j:4 * j + 4] - rot_before[:, 4 * j:4 * j + 4])) <= 1e-9, name
        if name != report.bones[0]:
            assert np.max(np.abs(loc_after[:, 3 * j:3 * j + 3] - loc_before[:, 3 * j:3 * j + 3])) <= 1e-9, name

    # No popping: each joint's (each bone's head and tail) largest frame-to-frame move at most 1.5 times the
    # input's own largest for that joint, and POP_ALLOWANCE millimetres (the hips' shift, which every joint
    # above them carries, is spread over the blend frames: measured up to 3.6 mm a frame beyond 1.5 times
    # the input's, walk_and_turn_left's spine).
    plain_move = np.max(np.linalg.norm(np.diff(plain, axis=0), axis=-1), axis=0)
    after_move = np.max(np.linalg.norm(np.diff(after, axis=0), axis=-1), axis=0)
    excess = after_move - (1.5 * plain_move + POP_ALLOWANCE * mm)
    worst_joint = np.unravel_index(np.argmax(excess), excess.shape)
    moving = plain_move > mm
    ratio = float(np.max(after_move[moving] / plain_move[moving]))  # for the print: joints the input moves
    assert excess.max() <= 0.0, (f"{clip}: {names[worst_joint[0]]} {('head', 'tail')[worst_joint[1]]} moves "
                                 f"{after_move[worst_joint] / mm:.2f} mm a frame, the input "
                                 f"{plain_move[worst_joint] / mm:.2f} mm")

    # No knee bends backwards: its signed flexion about the plain clip's knee axis never goes below the
    # plain clip's least (nor below 0 where the plain never straightens).
    for foot, (thigh, shin), (thigh2, shin2) in zip(feet, knee_flexion(plain, names, feet),
                                                   knee_flexion(after, names, feet)):
        axis = np.cross(thigh, shin)
        bent = np.linalg.norm(axis, axis=1) > 0.05 * np.linalg.norm(thigh, axis=1) * np.linalg.norm(shin, axis=1)
        mean_axis = axis[bent].mean(axis=0) if bent.any() else axis.mean(axis=0)
        # Per frame, the knee axis as the thigh carries it (turn the mean axis with the thigh).
        mean_axis /= np.linalg.norm(mean_axis)
        axes = np.cross(np.cross(thigh, mean_axis), thigh)
        axes = -axes / np.linalg.norm(axes, axis=1, keepdims=True)
        axes = np.where(np.einsum("fk,k->f", axes, mean_axis)[:, None] < 0, -axes, axes)
        before_angle = signed_angles(thigh, shin, axes)
        after_angle = signed_angles(thigh2, shin2, axes)
        least = min(float(before_angle.min()), 0.0)
        assert after_angle.min() >= least - np.radians(1.0), \
            f"{clip}: knee {foot.side} bends {np.degrees(least - after_angle.min()):.2f} deg backwards"

    # The contacts are on the action as 0/1 constant curves, and read back the same.
    for path, index, _ in contacts.contact_channels(feet):
        fcurve = mk.animdata.find_fcurve(obj.animation_data.action, obj, path, index)
        assert fcurve is not None, path
        assert all(k.interpolation == 'CONSTANT' for k in fcurve.keyframe_points)
    stored = contacts.read_contacts(obj, obj.animation_data.action, feet, frames)
    assert np.array_equal(stored, report.contacts)
    print(f"\n{clip}: {len(frames)} frames, contacts {[len(r) for r in report.intervals]}, worst slide "
          f"{worst / mm:.4f} mm, max joint move ratio {ratio:.3f} (excess over 1.5x {float(np.max(after_move - 1.5 * plain_move)) / mm:.2f} mm), cleanup {report.seconds * 1000:.1f} ms "
          f"(solve {report.solve_seconds * 1000:.1f} ms, {report.iterations} iterations), plant() "
          f"{elapsed * 1000:.1f} ms, knees {report.knee_axes}, max IK error {report.max_error.max() / mm:.4f} mm")


def _check_stances(mk, action, clip, mm, plain, after, names, feet):
    """Stances by the tests' own rule on the input (stances.stance), whether the detector found them or not:
    where the foot clearly stands (within 2 % of the leg of its lowest, slower than a fifth of a leg a second,
    for 0.08 s) held to HELD_MM; on the looser stances (4 %, half a leg a second, any length) never sliding
    further than the input's own point there."""
    point_bones = [b for foot in feet for b in (foot.shin, foot.foot)]
    columns = [names.index(b) for b in point_bones]
    leg = float(np.mean([sum(np.linalg.norm(plain[0, names.index(b), 1] - plain[0, names.index(b), 0])
                             for b in (f.thigh, f.shin)) for f in feet]))
    fps = mk.animdata.frame_rate(action)
    track, moved = plain[:, columns, 1], after[:, columns, 1]
    clear = stances.slides(moved, stances.stance(track[..., 2], track, leg, fps, 0.02, 0.2), int(np.ceil(0.08 * fps)))
    clear_worst = max((s for *_, s in clear), default=0.0)
    loose = stances.stance(track[..., 2], track, leg, fps)
    beyond = max(s - own for (*_, s), (*_, own) in zip(stances.slides(moved, loose), stances.slides(track, loose)))
    print(f"\n{clip}: clear stances {len(clear)}, worst slide {clear_worst / mm:.4f} mm; any stance's slide beyond "
          f"the input's own {beyond / mm:.4f} mm")
    assert clear_worst <= HELD_MM * mm, f"{clip}: a clear stance slides {clear_worst / mm:.4f} mm"
    assert beyond <= HELD_MM * mm, f"{clip}: a stance slides {beyond / mm:.4f} mm further than the input's"


def test_rerun_reads_the_curves_and_honours_an_edit(mk, contacts, walk60):
    obj, action = load(mk, walk60, "edited")
    first = contacts.plant(obj)
    assert first.source == "detected"
    again = contacts.plant(obj)
    assert again.source == "curves"
    assert np.array_equal(again.contacts, first.contacts)

    # A fresh copy of the clip whose left foot's second contact the animator removed.
    fresh, fresh_action = load(mk, walk60, "fresh")
    frames = frames_of(fresh_action)
    feet = contacts.find_feet(fresh)
    edited = first.contacts.copy()
    first_frame, last_frame = first.intervals[0][-1]
    span = slice(int(first_frame - frames[0]), int(last_frame - frames[0]) + 1)
    edited[span, 0:2] = False
    edited[(span.start - 12):(span.stop + 12), 0:2] = False
    contacts.write_contacts(fresh, fresh_action, feet, frames, edited)
    plain, names = evaluated(fresh, frames)
    report = contacts.plant(fresh)
    assert report.source == "curves"
    assert np.array_equal(report.contacts, edited)
    after, _ = evaluated(fresh, frames)
    # The freed ankle follows the plain clip there (it slides as captured), to the IK's tolerance.
    j = names.index(feet[0].shin)
    middle = slice(span.start + 3, span.stop - 3)
    assert np.max(np.linalg.norm(after[middle, j, 1] - plain[middle, j, 1], axis=1)) < 1e-4
    assert np.ptp(plain[middle, j, 1], axis=0).max() > 0.005  # and the capture's own ankle does move


def _all_keys(obj):
    action = obj.animation_data.action
    out = {}
    for fcurve in mk_fcurves(action, obj):
        co = np.empty(2 * len(fcurve.keyframe_points), dtype=np.float32)
        fcurve.keyframe_points.foreach_get("co", co)
        out[(fcurve.data_path, fcurve.array_index)] = co
    return out


def mk_fcurves(action, obj):
    import sys
    animdata = sys.modules[os.environ["MOTIONKIT_MODULE"] + ".blender.animdata"]
    return list(animdata.fcurves(action, obj))


def test_errors_name_foot_bone_and_frame_and_change_nothing(mk, contacts, walk60):
    obj, action = load(mk, walk60, "broken")
    before = _all_keys(obj)
    with pytest.raises(ValueError, match=r"foot L: shin bone 'nope'"):
        contacts.plant(obj, feet=[("lHip", "nope", "lAnkle", None), ("rHip", "rKnee", "rAnkle", None)])
    with pytest.raises(ValueError, match=r"foot R: bone 'rHip' is not a child of 'rHip'"):
        contacts.plant(obj, feet=[("lHip", "lKnee", "lAnkle", None), ("rHip", "rHip", "rAnkle", None)])
    with pytest.raises(ValueError, match="detect=False"):
        contacts.plant(obj, detect=False)
    # A broken key on the left shin at Blender frame 11.
    fcurve = next(f for f in mk_fcurves(action, obj) if f.data_path.startswith('pose.bones["lKnee"].rotation'))
    saved = fcurve.keyframe_points[10].co[1]
    fcurve.keyframe_points[10].co[1] = float("nan")
    before = _all_keys(obj)
    with pytest.raises(ValueError, match=r"foot L: bone 'lKnee'.*frame 11"):
        contacts.plant(obj)
    after = _all_keys(obj)
    assert after.keys() == before.keys()
    for key in before:
        assert np.array_equal(before[key], after[key], equal_nan=True), key
    assert "motionkit_contact_heel" not in obj.pose.bones["lAnkle"].keys()
    fcurve.keyframe_points[10].co[1] = saved


def test_plain_contacts_given_and_cleanup_signature(mk, contacts, pose_channels, walk60):
    """The call retargeting makes: contacts given, arrays in, arrays out, the file untouched."""
    obj, action = load(mk, walk60, "given")
    frames = frames_of(action).astype(np.float64)
    rig = pose_channels.read_rig(obj)
    rotations = pose_channels.rotations(obj, action, rig.names, frames)
    locations, _ = pose_channels.locations(obj, action, rig.names, frames)
    feet = contacts.find_feet(obj)
    none = np.zeros((frames.size, 4), dtype=bool)
    before = _all_keys(obj)
    rot, loc, report = contacts.cleanup(rig, frames, rotations, locations, feet, none, None)
    # Nothing to hold: the legs keep their pose (to the solver's round trip) and the hips stay.
    assert quaternion_angles(rot.reshape(len(frames), -1, 4), rotations.reshape(len(frames), -1, 4)).max() < 1e-6
    assert np.max(np.abs(loc - locations)) < 1e-9
    assert report.source == "given"
    assert _all_keys(obj).keys() == before.keys()
    with pytest.raises(ValueError, match="contacts must have shape"):
        contacts.cleanup(rig, frames, rotations, locations, feet, none[:, :2], None)


def test_frame_range_holds_contacts_there_only_and_keeps_the_rest(mk, contacts, walk60):
    obj, action = load(mk, walk60, "ranged")
    frames = frames_of(action)
    plain, names = evaluated(obj, frames)
    report = contacts.plant(obj, frame_range=(60, 120))
    after, _ = evaluated(obj, frames)
    for runs in report.intervals:
        for first, last in runs:
            assert 60 <= first and last <= 120
    # Every key is still there; away from the range (and its blends) the pose is the input's.
    for fcurve in mk_fcurves(obj.animation_data.action, obj):
        if not fcurve.data_path.endswith('"]'):
            assert len(fcurve.keyframe_points) == len(frames), fcurve.data_path
    blend = 8
    outside = (frames < 60 - blend) | (frames > 120 + blend)
    assert np.max(np.abs(after[outside] - plain[outside])) < 1e-5
    assert np.max(np.abs(after[~outside] - plain[~outside])) > 1e-3  # and inside it did something
    # The curves show every contact found, outside the range too.
    stored = contacts.read_contacts(obj, obj.animation_data.action, contacts.find_feet(obj), frames)
    assert stored[frames < 50].any()


def test_source_contacts_kept_on_a_retarget(mk, contacts, pose_channels, walk60):
    """The retarget's call: contacts found on the source, the target cleaned with them; the cleaned pose keyed
    and evaluated by Blender (frame_set, the pose bones' tails in world space) holds each contact to 1 mm."""
    source, source_action = load(mk, walk60, "source")
    target = generate.build_armature(characters.RIGIFY_A)
    mk.retarget(source, target)
    frames = frames_of(source_action).astype(np.float64)
    rig_s = pose_channels.read_rig(source)
    found = contacts.find_contacts(rig_s, pose_channels.rotations(source, source_action, rig_s.names, frames),
                                   pose_channels.locations(source, source_action, rig_s.names, frames)[0],
                                   contacts.find_feet(source), fps=60)
    assert found.sum() > 100
    action = target.animation_data.action
    rig = pose_channels.read_rig(target)
    rotations = pose_channels.rotations(target, action, rig.names, frames)
    locations, _ = pose_channels.locations(target, action, rig.names, frames)
    feet = contacts.find_feet(target)
    rot, loc, report = contacts.cleanup(rig, frames, rotations, locations, feet, found, None, fps=60)
    assert report.source == "given" and np.array_equal(report.contacts, found)
    names = list(rig.names)
    channels, values = pose_channels.rotation_keys(target, names, rot)
    channels += [(f"{pose_channels.bone_path(n)}.location", k) for n in names for k in range(3)]
    values = np.vstack([values, loc.T])
    mk.animdata.write_keys(target, action, channels, frames, values)
    after, evaluated_names = evaluated(target, frames)
    point_bones = [b for foot in feet for b in (foot.shin, foot.foot)]
    worst = 0.0
    for p, runs in enumerate(report.intervals):
        j = evaluated_names.index(point_bones[p])
        for first, last in runs:
            track = after[int(first - frames[0]):int(last - frames[0]) + 1, j, 1]
            worst = max(worst, float(np.max(np.linalg.norm(track - track[0], axis=1))))
    print(f"\nsource contacts on {target.name}: worst slide {1000 * worst:.4f} mm in Blender's evaluation")
    assert worst < 1e-3


def test_operator_fixes_sliding_and_reports_errors(mk, walk60):
    """The operator as a user runs it: registered by the add-on, in the Pose menu, one undo step."""
    assert hasattr(bpy.types, "MOTIONKIT_OT_fix_foot_sliding")
    assert "menu_pose" in [getattr(f, "__name__", "") for f in bpy.types.VIEW3D_MT_pose._dyn_ui_initialize()]
    obj, action = load(mk, walk60, "operated")
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.motionkit.fix_foot_sliding() == {'FINISHED'}
    contacts = importlib.import_module(mk.__name__ + ".features.contacts")
    stored = contacts.read_contacts(obj, obj.animation_data.action, contacts.find_feet(obj), frames_of(action))
    assert stored is not None and stored.any()
    # Nothing selected that it can work on: the poll says why.
    obj.animation_data.action = None
    assert not bpy.ops.motionkit.fix_foot_sliding.poll()


def test_the_rolled_knee_angles_are_derived_exactly(contacts):
    """The knee's limits read the swing-twist angles of the shin rolled about its Y axis; the cleanup derives
    them from the unrolled ones (a turn of the swing vector) instead of decomposing again: the same angles."""
    rng = np.random.default_rng(7)
    q = rng.normal(size=(2000, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    for roll in (0.3, -1.2, 2.9):
        derived = contacts._rolled(contacts.rotation_channels.ik_swing_twist(q), roll)
        rolled = contacts._mul(contacts._mul(contacts._about_y(-roll), q), contacts._about_y(roll))
        direct = contacts.rotation_channels.ik_swing_twist(rolled)
        gap = np.abs(derived - direct)
        gap[:, 1] = np.minimum(gap[:, 1], 2 * np.pi - gap[:, 1])  # the twist wraps at +-pi
        assert gap.max() < 1e-12


def _state(obj):
    action = obj.animation_data.action if obj.animation_data else None
    keys = None if action is None else {(fc.data_path, fc.array_index): [tuple(k.co) for k in fc.keyframe_points]
                                        for fc in mk_fcurves(action, obj)}
    return str(keys), sorted(a.name for a in bpy.data.actions), sorted(obj.pose.bones["lAnkle"].keys())


def test_plant_without_an_action_or_keys_says_so_and_changes_nothing(mk, contacts, walk60):
    obj, action = load(mk, walk60, "bare")
    obj.animation_data.action = None
    before = _state(obj)
    with pytest.raises(ValueError, match=r"'bare' has no action to clean up"):
        contacts.plant(obj)
    assert _state(obj) == before
    empty = bpy.data.actions.new("empty")
    obj.animation_data.action = empty
    before = _state(obj)
    with pytest.raises(ValueError, match=r"'bare': action 'empty' has no keys on its bones"):
        contacts.plant(obj)
    assert _state(obj) == before
    # Keys, but none on a bone (the object's own location only).
    obj.keyframe_insert("location", frame=1)
    obj.keyframe_insert("location", frame=30)
    before = _state(obj)
    with pytest.raises(ValueError, match=r"'bare': action 'empty' has no keys on its bones"):
        contacts.plant(obj)
    assert _state(obj) == before
    bpy.ops.mesh.primitive_cube_add()
    with pytest.raises(ValueError, match=r"'Cube' is not an armature object"):
        contacts.plant(bpy.context.active_object)


@pytest.mark.parametrize("bone,channel", [("RootJoint", "location"), ("lShoulder", "rotation")])
def test_plant_refuses_a_nan_key_away_from_the_legs_naming_bone_and_frame(mk, contacts, walk60, bone, channel):
    """A NaN on the hips' location or on a shoulder's rotation at Blender frame 21 (outside the legs, which
    test_errors_name_foot_bone_and_frame_and_change_nothing covers): named, nothing changed."""
    obj, action = load(mk, walk60, "nan")
    fcurve = next(f for f in mk_fcurves(action, obj) if f.data_path.startswith(f'pose.bones["{bone}"].{channel}'))
    fcurve.keyframe_points[20].co[1] = float("nan")
    before = _state(obj)
    with pytest.raises(ValueError, match=rf"bone '{bone}'.*frame 21"):
        contacts.plant(obj)
    assert _state(obj) == before


def test_planted_feet_hold_on_a_rig_with_longer_legs(mk, walk60, tmp_path):
    """walk60 onto a copy of its own skeleton whose legs are 30 % longer (knee, ankle and toe offsets, made
    from the file by tests/common/made_characters.py): no stance slides more than the source's own, scaled by
    the legs' ratio, plus test_feet_metarig.SLIDE_SLACK."""
    from test_feet_metarig import SLIDE_SLACK, stance_slides  # that module's fixtures stay out of this one
    longer = sp.read_bvh(walk60)
    for j, name in enumerate(longer.names):
        if any(part in name for part in ("Knee", "Ankle", "Toe")):
            longer.offsets[j] = 1.3 * longer.offsets[j]
    path = str(tmp_path / "walk60_long.bvh")
    made.write_bvh(longer, path)
    source, _ = load(mk, walk60, "source")
    target, _ = load(mk, path, "longer legs")
    target.animation_data.action = None  # its rest alone: the retarget's target
    plan = mk.retargeting.plan(source, target)
    mk.retargeting.apply(plan)
    slides = stance_slides(mk, source, target, plan)
    print("\nslides (mm, target / source scaled) " + " ".join(f"{1000 * t:.1f}/{1000 * s:.1f}" for t, s in slides))
    assert len(slides) >= 5 and all(t <= s + SLIDE_SLACK for t, s in slides), slides
