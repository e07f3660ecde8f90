"""motionkit.retarget in a real Blender, checked against Blender's own evaluation (depsgraph pose matrices).

The brief's lab check both ways
(T-pose walk60 onto an A-pose copy and back, world joints to 1e-6 of the
height), random bone rolls (directions to 0.01 deg), walk60 onto each sample
character (mapped directions to 0.1 deg, foot heights scaled by the leg
ratio), and errors that change nothing.
"""
import importlib
import json
import math
import os

import bpy
import numpy as np
import pytest
from mathutils import Vector

import characters
import generate
import shared_data
import stances
from pointing import MATCH_EVERY_CHAIN, pointing_pairs
from rotations import matrix_angles

FEET = {  # per rig kind: (ankle bone, toe bone) for each side
    "walk60": (("lAnkle", "lToeJoint"), ("rAnkle", "rToeJoint")),
}


@pytest.fixture()
def retargeting(mk):
    return mk.retargeting


def load(mk, path, name):
    return mk.bvh.load(path, name=name)


SHOULDERS = (("lShoulder", -45.0), ("rShoulder", 45.0))
HIPS = (("lHip", 45.0), ("rHip", -45.0))  # the legs spread sideways, as the lab's own A-pose has them


def a_pose_file(native, walk60, path, turns=SHOULDERS):
    """walk60's skeleton with the joints below each of turns turned about the file's Z, as in the brief:
    lShoulder (0, 0, -45 deg) and rShoulder (0, 0, +45 deg) bring the arms down; HIPS spreads the legs."""
    skeleton, motion = native.read_bvh(walk60)
    offsets = np.array(skeleton.offsets)
    parents = list(skeleton.parents)

    def below(joint):
        out = []
        for i, p in enumerate(parents):
            if p == joint:
                out += [i] + below(i)
        return out

    for side, degrees in turns:
        c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
        rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        for i in below(skeleton.names.index(side)):
            offsets[i] = rz @ offsets[i]
    moved = native.Skeleton(list(skeleton.names), parents, offsets, list(skeleton.end_sites),
                            [list(c) for c in skeleton.channels])
    native.write_bvh(str(path), moved, motion)
    return str(path)


def joints(obj, frames):
    """World heads and tails of every bone, (frames, 2 * bones, 3), as the depsgraph poses them."""
    scene = bpy.context.scene
    out = []
    names = sorted(b.name for b in obj.data.bones)
    for frame in frames:
        scene.frame_set(int(frame))
        world = obj.matrix_world
        row = []
        for name in names:
            pose_bone = obj.pose.bones[name]
            row += [tuple(world @ pose_bone.head), tuple(world @ pose_bone.tail)]
        out.append(row)
    return np.array(out)


def directions(obj, names, frames):
    """World Y axes of the bones, (frames, bones, 3)."""
    return world_rotations(obj, names, frames)[..., 1]


def world_rotations(obj, names, frames):
    """World rotations (frames, bones, 3, 3) of the pose bones as the depsgraph poses them (frame_set,
    matrix_world @ pose_bone.matrix), columns made unit (an object's scale is no turn)."""
    out = np.empty((len(frames), len(names), 3, 3))
    for i, frame in enumerate(frames):
        bpy.context.scene.frame_set(int(frame))
        world = obj.matrix_world
        for j, n in enumerate(names):
            out[i, j] = np.array((world @ obj.pose.bones[n].matrix).to_3x3())
    return out / np.linalg.norm(out, axis=-2, keepdims=True)


def rest_rotations(obj, names):
    """World rotations (bones, 3, 3) of the bones at rest (matrix_world @ bone.matrix_local)."""
    out = np.array([np.array((obj.matrix_world @ obj.data.bones[n].matrix_local).to_3x3()) for n in names])
    return out / np.linalg.norm(out, axis=-2, keepdims=True)


def _swing(a, b):
    """(n, 3, 3) the shortest turns taking unit vectors a onto b (n, 3) (Rodrigues' formula)."""
    axis = np.cross(a, b)
    c = np.sum(a * b, axis=-1)[:, None, None]
    k = np.zeros((len(a), 3, 3))
    k[:, 0, 1], k[:, 0, 2], k[:, 1, 2] = -axis[:, 2], axis[:, 1], -axis[:, 0]
    k -= np.swapaxes(k, 1, 2)
    return np.eye(3) + k + k @ k / (1.0 + c)


def expected_rotations(source, target, pairs, frames):
    """Each target bone's world rotation, independently of the retarget: the source bone's turn from its
    rest (in the world) applied to the target bone's rest, once the shortest swing has laid the target's
    rest Y axis along the source's (identity where the rests agree). (frames, pairs, 3, 3)."""
    source_rest = rest_rotations(source, [a for a, _ in pairs])
    target_rest = rest_rotations(target, [b for _, b in pairs])
    align = _swing(target_rest[:, :, 1], source_rest[:, :, 1])
    posed = world_rotations(source, [a for a, _ in pairs], frames)
    return posed @ np.swapaxes(source_rest, -1, -2) @ align @ target_rest


def angles_deg(a, b):
    cross = np.linalg.norm(np.cross(a, b), axis=-1)
    return np.degrees(np.arctan2(cross, np.sum(a * b, axis=-1)))


def same_names(obj):
    return [(b.name, b.name) for b in obj.data.bones]


def height(obj):
    z = [p[2] for b in obj.data.bones for p in (b.head_local, b.tail_local)]
    return max(z) - min(z)


# Whole-rotation bounds: measured 0.00003 deg at most on Blender 3.4, 4.3, 5.2 (random rolls, and walk60 onto
# each character), Blender's float32 pose matrices; about ten times that.
ROLLED_DEG = 3e-4
CHARACTER_DEG = 3e-4


def test_t_pose_to_a_pose_and_back_keeps_every_world_joint(mk, native, walk60, tmp_path):
    source, action = load(mk, walk60, "walkT")
    a_rig, _ = load(mk, a_pose_file(native, walk60, tmp_path / "walk60_A.bvh"), "walkA")
    # The A-pose rig really is another rest pose: its arms point 45 deg down.
    arm = a_rig.data.bones["lShoulder"]
    assert abs((arm.tail_local - arm.head_local).normalized().z + math.sin(math.radians(45))) < 1e-6
    frames = np.arange(1, 183)
    tolerance = 1e-6 * height(source)

    # The plain retarget (feet not planted: the cleanup would also hold walk60's own slight foot slides).
    mk.retarget(source, a_rig, bone_map=same_names(a_rig), plant_feet=False)
    expected = joints(source, frames)
    there = joints(a_rig, frames)
    assert np.abs(there - expected).max() < tolerance

    back, _ = load(mk, walk60, "walkT2")
    mk.retarget(a_rig, back, bone_map=same_names(back), plant_feet=False)
    again = joints(back, frames)
    assert np.abs(again - expected).max() < tolerance


def test_a_pose_with_spread_legs_keeps_every_world_joint_both_ways(mk, retargeting, native, walk60, tmp_path):
    """The lab's own A-pose turns the hips 45 deg too: the rig stands lower without shorter legs."""
    source, _ = load(mk, walk60, "walkT")
    a_rig, _ = load(mk, a_pose_file(native, walk60, tmp_path / "walk60_AA.bvh", SHOULDERS + HIPS), "walkAA")
    thigh = a_rig.data.bones["lHip"]
    assert abs((thigh.tail_local - thigh.head_local).normalized().x - math.sin(math.radians(45))) < 1e-6
    frames = np.arange(1, 183)
    tolerance = 1e-6 * height(source)

    plan = retargeting.plan(source, a_rig, same_names(a_rig), plant_feet=False)
    # The same legs, measured along them: 1 to Blender's float32 bone storage (the hip height gave 0.724).
    assert plan.path_scale == pytest.approx(1.0, abs=1e-6)
    retargeting.apply(plan)
    expected = joints(source, frames)
    assert np.abs(joints(a_rig, frames) - expected).max() < tolerance

    back, _ = load(mk, walk60, "walkT2")
    plan = retargeting.plan(a_rig, back, same_names(back), plant_feet=False)
    assert plan.path_scale == pytest.approx(1.0, abs=1e-6)
    retargeting.apply(plan)
    assert np.abs(joints(back, frames) - expected).max() < tolerance


def test_random_rolls_and_euler_modes_still_point_every_bone_where_the_source_does(mk, walk60):
    source, _ = load(mk, walk60, "walkT")
    target, _ = load(mk, walk60, "rolled")
    animated = target.animation_data.action
    target.animation_data.action = None
    bpy.data.actions.remove(animated)
    rng = np.random.default_rng(11)
    bpy.context.view_layer.objects.active = target
    bpy.ops.object.mode_set(mode='EDIT')
    for bone in target.data.edit_bones:
        bone.roll = float(rng.uniform(-math.pi, math.pi))
    bpy.ops.object.mode_set(mode='OBJECT')
    modes = ('QUATERNION', 'XYZ', 'ZXY', 'YZX', 'AXIS_ANGLE')
    for i, pose_bone in enumerate(target.pose.bones):
        pose_bone.rotation_mode = modes[i % len(modes)]
    action = mk.retarget(source, target, bone_map=same_names(target), plant_feet=False)
    names = [b.name for b in target.data.bones]
    frames = np.arange(1, 183)
    # Whole rotations, the roll included: the source bone's turn from its rest, on the rolled bone's rest.
    got = world_rotations(target, names, frames)
    worst = np.degrees(matrix_angles(got, expected_rotations(source, target, same_names(target), frames))).max()
    print(f"\nrandom rolls: worst whole-rotation error {worst:.6f} deg")
    assert worst < ROLLED_DEG
    # Euler curves come out continuous: no jump of more than 90 deg between frames.
    from_curves = [fc for fc in mk.animdata.fcurves(action, target) if fc.data_path.endswith("rotation_euler")]
    assert from_curves
    for fc in from_curves:
        values = mk.animdata.read_keys(fc)[1]
        assert np.abs(np.diff(values)).max() < math.radians(90), fc.data_path


@pytest.mark.parametrize("spec", characters.CHARACTERS, ids=lambda s: s.name)
def test_walk60_onto_each_sample_character(mk, retargeting, walk60, spec):
    source, _ = load(mk, walk60, "walk60")
    target = generate.build_armature(spec)
    pairs = retargeting.auto_map(source, target)
    canonical = {b.name: b.canonical for b in spec.bones}
    mapped_limbs = {canonical[t] for _, t in pairs}
    for limb in ("upper_arm", "forearm", "hand", "thigh", "shin", "foot"):
        assert {f"{limb}.L", f"{limb}.R"} <= mapped_limbs, (limb, pairs)
    # Planting and the legs' floor fit move the legs on purpose; every chain set to match the source's direction
    # (by default the target keeps its own posture: test_walk60_keeps_each_characters_posture).
    plan = retargeting.plan(source, target, pairs, plant_feet=False, floor_fit="hips", chain_modes=MATCH_EVERY_CHAIN)
    retargeting.apply(plan)
    frames = np.arange(1, 183)
    got = world_rotations(target, [t for _, t in pairs], frames)
    posed = world_rotations(source, [s for s, _ in pairs], frames)
    # Each bone points as the source's (its Y axis), and turns as the source's does from frame to frame, the
    # roll included: G_b(t) = D_a(t) A_b with A_b constant (docs/retargeting.md), so G_b(t) G_b(1)^-1 is
    # the source's G_a(t) G_a(1)^-1 in the world, whatever constant twist the match pose gives A_b.
    direction = angles_deg(posed[..., 1], got[..., 1]).max()
    turns = lambda r: r @ np.swapaxes(r[:1], -1, -2)  # noqa: E731
    per_bone = np.degrees(matrix_angles(turns(got), turns(posed))).max(axis=0)
    print(f"\nwalk60 onto {spec.name}: direction {direction:.6f} deg, whole turn from frame 1 {per_bone.max():.6f} "
          f"deg ({pairs[int(per_bone.argmax())]})")
    assert direction < CHARACTER_DEG and per_bone.max() < CHARACTER_DEG

    # Legs measured along thigh, shin and the ankle's height above the sole, the samples' known proportions;
    # where the feet stand: test_feet_stand_on_the_floor.
    p = spec.proportions
    assert plan.path_scale * 0.85 < p.hip_height < plan.path_scale * 1.15  # walk60's legs are about 0.9 m


def rest_y_axes(obj, names):
    """World Y axes (bones, 3) of the bones at rest (matrix_world @ bone.matrix_local), unit."""
    axes = np.array([(obj.matrix_world.to_3x3() @ obj.data.bones[n].matrix_local.to_3x3()).col[1] for n in names])
    return axes / np.linalg.norm(axes, axis=1, keepdims=True)


@pytest.mark.parametrize("spec", characters.CHARACTERS, ids=lambda s: s.name)
def test_walk60_keeps_each_characters_posture(mk, retargeting, walk60, spec):
    """By default the target keeps its own posture where the two rigs stand alike (a reference pose is a pose, not a body shape): its trunk
    (a character's spine curve and head carriage) moves from its own rest as the capture's moves from its
    rest, so each trunk bone stays at its rest angle from the capture's bone on every frame, and each limb
    is either matched (at 0) or kept (at its rest angle): a constant angle, never a drift. Every bone turns
    from frame to frame as its source bone does either way."""
    source, _ = load(mk, walk60, "walk60")
    target = generate.build_armature(spec)
    pairs = retargeting.auto_map(source, target)
    plan = retargeting.plan(source, target, pairs, plant_feet=False, floor_fit="hips")
    modes = {c.chain: c.mode for c in plan.chains}
    print(f"\nwalk60 onto {spec.name}: " + ", ".join(f"{c.chain} {c.mode} ({c.angle:.1f})" for c in plan.chains))
    assert modes["trunk"] == "KEEP" and not any(c.by_user for c in plan.chains)
    retargeting.apply(plan)
    frames = np.arange(1, 183, 4)
    names = [[s for s, _ in pairs], [t for _, t in pairs]]
    got, posed = world_rotations(target, names[1], frames), world_rotations(source, names[0], frames)
    turns = lambda r: r @ np.swapaxes(r[:1], -1, -2)  # noqa: E731
    assert np.degrees(matrix_angles(turns(got), turns(posed))).max() < CHARACTER_DEG
    angle = angles_deg(posed[..., 1], got[..., 1])
    assert np.ptp(angle, axis=0).max() < CHARACTER_DEG
    rest = angles_deg(rest_y_axes(source, names[0]), rest_y_axes(target, names[1]))
    trunk = [i for i, (_, t) in enumerate(pairs) if any(k in t.lower() for k in ("spine", "neck", "head", "hips"))]
    assert trunk and np.abs(angle[:, trunk] - rest[trunk]).max() < CHARACTER_DEG, (angle[0, trunk], rest[trunk])


def test_reference_pose_is_decided_shown_switched_and_saved_with_the_map(mk, walk60, tmp_path):
    """The panel's Reference Pose: Auto-map decides each chain (walk60's T arms against RigifyA's A arms: turned
    onto the capture's; the trunks alike: kept), a chain switched by hand is saved with the bone map and
    read back, and the Retarget button retargets with it, as the call with the same chain modes does."""
    source, _ = load(mk, walk60, "walk60")
    target = generate.build_armature(characters.RIGIFY_A)
    settings = bpy.context.scene.motionkit_retarget
    try:
        check_reference_pose_panel(mk, settings, source, target, tmp_path)
    finally:  # the scene's panel settings as they were, for the tests after this one
        settings.pairs.clear()
        for name in ("source_kind", "source", "target", "use_frame_range", "scene_from_clip", "plant_feet"):
            settings.property_unset(name)
        for name in settings.reference_pose.bl_rna.properties.keys():
            if name != "rna_type":
                settings.reference_pose.property_unset(name)


def check_reference_pose_panel(mk, settings, source, target, tmp_path):
    settings.source_kind, settings.source, settings.target = 'ARMATURE', source, target
    assert bpy.ops.motionkit.bone_map_auto() == {'FINISHED'}
    decided = settings.reference_pose.decided()
    assert decided["trunk"][0] == "KEEP" and decided["arm.L"][0] == decided["arm.R"][0] == "MATCH", decided
    assert decided["leg.L"][0] == "KEEP" and float(decided["arm.L"][1]) > 30.0, decided
    settings.reference_pose.chain_trunk, settings.reference_pose.chain_arm_l = 'MATCH', 'KEEP'
    path = tmp_path / "map.json"
    assert bpy.ops.motionkit.bone_map_save(filepath=str(path)) == {'FINISHED'}
    saved = json.loads(path.read_text())
    assert saved["version"] == 2 and saved["chains"] == {"trunk": "MATCH", "arm.L": "KEEP"}
    settings.reference_pose.chain_trunk = settings.reference_pose.chain_arm_l = 'AUTO'
    assert bpy.ops.motionkit.bone_map_load(filepath=str(path)) == {'FINISHED'}
    assert (settings.reference_pose.chain_trunk, settings.reference_pose.chain_arm_l) == ('MATCH', 'KEEP')
    settings.use_frame_range, settings.scene_from_clip, settings.plant_feet = False, False, False
    assert bpy.ops.motionkit.retarget() == {'FINISHED'}
    by_button = target.animation_data.action
    by_call = mk.retarget(source, target, bone_map=settings.bone_map(), plant_feet=False,
                          chain_modes={"trunk": "MATCH", "arm.L": "KEEP"})
    curves = {(c.data_path, c.array_index): c for c in mk.animdata.fcurves(by_call, target)}
    for curve in mk.animdata.fcurves(by_button, target):
        other = curves[(curve.data_path, curve.array_index)]
        for frame in (1.0, 60.0, 120.0):
            assert curve.evaluate(frame) == pytest.approx(other.evaluate(frame), abs=1e-6)
    # The arm kept by hand moves from its own A-pose rest: it points 45 degrees off the capture's T-pose arm.
    frames = np.array([1, 90])
    arm = [("lShoulder", "upper_arm.L")]
    left = angles_deg(*pointing_pairs(source, target, arm, frames))
    assert left.min() > 30.0, left


def test_errors_change_nothing(mk, walk60):
    source, _ = load(mk, walk60, "walkT")
    target = generate.build_armature(characters.MIXAMO_T)
    before = set(bpy.data.actions)
    cases = [
        (dict(bone_map=[]), "no common bones"),
        (dict(bone_map=[("RootJoint", "nope")]), "'nope' is not a bone of the target"),
        (dict(bone_map=[("lElbow", "mixamorig:LeftArm"), ("lShoulder", "mixamorig:LeftForeArm")]), "cycle"),
        (dict(bone_map=[("RootJoint", "mixamorig:Hips")], root="sideways"), "unknown root motion"),
    ]
    for kwargs, message in cases:
        with pytest.raises(ValueError, match=message):
            mk.retarget(source, target, **kwargs)
    with pytest.raises(ValueError, match="same armature"):
        mk.retarget(source, source, bone_map=same_names(source))
    with pytest.raises(ValueError, match="no source armature"):
        mk.retarget(None, target, bone_map=[])
    with pytest.raises(ValueError, match="has no action"):
        mk.retarget(target, source, bone_map=[("mixamorig:Hips", "RootJoint")])
    assert set(bpy.data.actions) == before
    assert target.animation_data is None or target.animation_data.action is None


def test_the_users_action_is_kept_and_overwrite_writes_into_it(mk, walk60):
    source, _ = load(mk, walk60, "walkT")
    target, _ = load(mk, walk60, "target")
    own = target.animation_data.action
    new = mk.retarget(source, target, bone_map=same_names(target))
    assert new != own and target.animation_data.action == new
    assert own.name in bpy.data.actions and own.use_fake_user
    target.animation_data.action = own
    assert mk.retarget(source, target, bone_map=same_names(target), overwrite=True) == own


def test_root_motion_modes_and_feet_on_the_floor(mk, retargeting, walk60):
    source, _ = load(mk, walk60, "walk60")
    target = generate.build_armature(characters.UNREAL_A)
    pairs = retargeting.auto_map(source, target)
    hips = characters.UNREAL_A.canonical["hips"]

    def hips_path(root, **options):
        retargeting.apply(retargeting.plan(source, target, pairs, root=root, plant_feet=False, **options))
        out = []
        for frame in (1, 60, 120, 182):
            bpy.context.scene.frame_set(frame)
            out.append(tuple(target.matrix_world @ target.pose.bones[hips].head))
        return np.array(out)

    scaled, in_place, offset, none = (hips_path(r) for r in ("scaled", "in_place", "offset", "none"))
    rest = np.array(target.data.bones[hips].head_local)
    assert np.ptp(scaled[:, :2], axis=0).max() > 0.3  # walk60 walks
    np.testing.assert_allclose(in_place[:, :2], np.tile(rest[:2], (4, 1)), atol=1e-6)
    np.testing.assert_allclose(in_place[:, 2], scaled[:, 2], atol=1e-6)
    np.testing.assert_allclose(offset[:, :2], scaled[:, :2], atol=1e-6)
    np.testing.assert_allclose(none, np.tile(rest, (4, 1)), atol=1e-6)
    # Scale Horizontal: the stride 1.4 times the scaled one from the rest's place, the height untouched.
    for root, path in (("scaled", scaled), ("offset", offset)):
        wider = hips_path(root, scale_horizontal=1.4)
        np.testing.assert_allclose(wider[:, :2] - rest[:2], 1.4 * (path[:, :2] - rest[:2]), atol=1e-5)
        np.testing.assert_allclose(wider[:, 2], path[:, 2], atol=1e-6)
    retargeting.apply(retargeting.plan(source, target, pairs, floor_fit="first_frame", plant_feet=False))
    bpy.context.scene.frame_set(1)
    lowest = min(min(target.matrix_world @ pb.head, target.matrix_world @ pb.tail, key=lambda v: v.z).z
                 for pb in target.pose.bones)
    assert abs(lowest) < 1e-5


def test_target_match_pose_sets_the_twist(mk, walk60):
    source, _ = load(mk, walk60, "walkT")
    target = generate.build_armature(characters.MIXAMO_T)
    pairs = [("RootJoint", "mixamorig:Hips"), ("lElbow", "mixamorig:LeftForeArm")]
    rest_action = mk.retarget(source, target, bone_map=pairs)
    target.animation_data.action = None
    forearm = target.pose.bones["mixamorig:LeftForeArm"]
    forearm.rotation_mode = 'QUATERNION'
    forearm.rotation_quaternion = (math.cos(math.radians(15)), 0.0, math.sin(math.radians(15)), 0.0)
    posed_action = mk.retarget(source, target, bone_map=pairs, target_match='CURRENT')
    # Same direction, 30 deg more twist about the bone on every frame.
    for frame in (1, 90, 182):
        target.animation_data.action = rest_action
        bpy.context.scene.frame_set(frame)
        a = forearm.matrix.to_quaternion()
        target.animation_data.action = posed_action
        bpy.context.scene.frame_set(frame)
        b = forearm.matrix.to_quaternion()
        twist = a.rotation_difference(b)  # in the bone's own frame
        assert abs(math.degrees(twist.angle) - 30.0) < 1e-3
        assert abs(abs(twist.axis.normalized().y) - 1) < 1e-5
        assert (a @ Vector((0, 1, 0))).angle(b @ Vector((0, 1, 0))) < 1e-5


def test_operator_retargets_a_bvh_file_and_errors_cancel(mk, walk60, tmp_path):
    target = generate.build_armature(characters.MIXAMO_T)
    settings = bpy.context.scene.motionkit_retarget
    settings.source_kind = 'FILE'
    settings.target = target
    settings.source_path = str(tmp_path / "missing.bvh")
    objects = set(bpy.data.objects)
    assert not bpy.ops.motionkit.retarget.poll()
    broken = tmp_path / "broken.bvh"
    broken.write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 zero\n")
    settings.source_path = str(broken)
    with pytest.raises(RuntimeError, match="broken.bvh"):
        bpy.ops.motionkit.retarget()
    assert set(bpy.data.objects) == objects
    settings.source_path = walk60
    assert bpy.ops.motionkit.bone_map_auto() == {'FINISHED'}
    assert len(settings.pairs) >= 16
    assert settings.plant_feet and settings.floor_root == "auto"  # the defaults: feet planted
    settings.contacts.blend = 0.2
    assert bpy.ops.motionkit.retarget() == {'FINISHED'}
    assert target.animation_data.action is not None
    curves = mk.animdata.fcurves(target.animation_data.action, target)
    assert len(curves) > 40
    contact_curves = [fc for fc in curves if "motionkit_contact" in fc.data_path]
    assert len(contact_curves) == 4  # heel and ball of each foot, where the animator sees them
    assert set(np.unique(mk.animdata.read_keys(contact_curves[0])[1])) <= {0.0, 1.0}


def test_batch_retargets_a_folder_of_files(mk, walk60, shared_dir):
    target = generate.build_armature(characters.RIGIFY_A)
    files = shared_data.bvh_files(os.path.join(shared_dir, "data", "bvh"))
    objects = set(bpy.data.objects)
    actions = mk.retarget_files(files, target)
    assert [a.name for a in actions] == [os.path.splitext(os.path.basename(f))[0] for f in files]
    assert set(bpy.data.objects) == objects  # the imported sources are gone again
    assert all(a.use_fake_user for a in actions)
    # Each action holds its own file's motion: a key per source frame, planted-feet curves and all.
    for path, action in zip(files, actions):
        _, motion = mk.native().read_bvh(path)
        curves = mk.animdata.fcurves(action, target)
        hips = next(fc for fc in curves if fc.data_path.endswith(".location") and fc.array_index == 0)
        assert len(hips.keyframe_points) == motion.frames, path
        assert any("motionkit_contact" in fc.data_path for fc in curves), path


def test_a_bvh_path_as_source_stays_in_the_scene_and_a_failure_removes_it(mk, walk60):
    target = generate.build_armature(characters.UNREAL_A)
    objects = set(bpy.data.objects)
    with pytest.raises(ValueError, match="no common bones"):
        mk.retarget(walk60, target, bone_map=[])
    assert set(bpy.data.objects) == objects
    action = mk.retarget(walk60, target)
    imported = set(bpy.data.objects) - objects
    assert len(imported) == 1 and next(iter(imported)).type == 'ARMATURE'
    assert target.animation_data.action == action


def test_bone_map_operators_save_load_and_edit_the_list(mk, walk60, tmp_path):
    source, _ = load(mk, walk60, "walk60")
    target = generate.build_armature(characters.RIGIFY_A)
    settings = bpy.context.scene.motionkit_retarget
    settings.source_kind, settings.source, settings.target = 'ARMATURE', source, target
    assert bpy.ops.motionkit.bone_map_auto() == {'FINISHED'}
    pairs = settings.bone_map()
    path = str(tmp_path / "map.json")
    assert bpy.ops.motionkit.bone_map_save(filepath=path) == {'FINISHED'}
    assert bpy.ops.motionkit.list_edit(list="bone_map", action='ADD') == {'FINISHED'}
    assert len(settings.pairs) == len(pairs) + 1 and settings.active_pair == len(pairs)
    settings.active_pair = 0
    assert bpy.ops.motionkit.list_edit(list="bone_map", action='REMOVE') == {'FINISHED'}
    assert settings.bone_map() == pairs[1:]
    settings.active_pair = -1  # nothing selected: nothing removed, and the user is told why
    with pytest.raises(RuntimeError, match="Select a pair"):
        bpy.ops.motionkit.list_edit(list="bone_map", action='REMOVE')
    assert settings.bone_map() == pairs[1:]
    assert bpy.ops.motionkit.bone_map_load(filepath=path) == {'FINISHED'}
    assert settings.bone_map() == pairs
    assert bpy.ops.motionkit.bone_map_scheme(source_scheme="games105", target_scheme="rigify_metarig") == {'FINISHED'}
    assert dict(settings.bone_map())["lHip"] == "thigh.L"


# ---------------------------------------------------------------------------
# Game rigs: a floor root above the hips, and a rest pose that is neither T nor A


@pytest.fixture()
def bandai(shared_dir):
    return os.path.join(shared_dir, "data", "bvh", "more", "bandai_dash_normal_001.bvh")


def test_auto_map_pairs_floor_roots_with_each_other_and_hips_with_hips(mk, retargeting, bandai):
    source, _ = load(mk, bandai, "dash")
    target = generate.build_armature(characters.UNREAL_A)
    pairs = dict(retargeting.auto_map(source, target))
    assert pairs["joint_Root"] == "root" and pairs["Hips"] == "pelvis"
    assert pairs["UpperLeg_L"] == "thigh_l" and pairs["Toes_R"] == "ball_r"


def test_a_retarget_says_what_its_automatic_map_left_out_without_reading_the_rigs_again(mk, retargeting, bandai):
    """The automatic map's report (what the Retarget button warns of) comes with the retarget, as
    bone_mapping.auto_map_report reads the two armatures afresh; none where a map was given."""
    bone_mapping = importlib.import_module(mk.__name__ + ".core.bone_mapping")
    pose_channels = importlib.import_module(mk.__name__ + ".blender.pose_channels")
    source, _ = load(mk, bandai, "dash")
    target = generate.build_armature(characters.UNREAL_A)
    expected = bone_mapping.auto_map_report(pose_channels.armature_mapping_rig(source, upright=True),
                                            pose_channels.armature_mapping_rig(target, upright=True))
    made = retargeting.retarget_clip(source, target, plant_feet=False)
    assert made.map_report is not None
    assert made.map_report.message() == expected.message()
    assert sorted(made.pairs) == sorted(expected.pairs)
    assert retargeting.retarget_clip(source, target, list(made.pairs), plant_feet=False).map_report is None


def world_tracks(obj, names, frames):
    """World heads and Y axes of the named bones, (frames, bones, 3) each, as the depsgraph poses them."""
    heads, axes = [], []
    for frame in frames:
        bpy.context.scene.frame_set(int(frame))
        world = obj.matrix_world
        heads.append([tuple(world @ obj.pose.bones[n].head) for n in names])
        axes.append([tuple((world.to_3x3() @ obj.pose.bones[n].matrix.to_3x3()).col[1].normalized())
                     for n in names])
    return np.array(heads), np.array(axes)


@pytest.mark.parametrize("spec", characters.CHARACTERS, ids=lambda s: s.name)
def test_bandai_dash_onto_each_sample_character_points_every_mapped_bone_alike(mk, retargeting, bandai, spec):
    source, action = load(mk, bandai, "dash")
    target = generate.build_armature(spec)
    plan = retargeting.plan(source, target, plant_feet=False, floor_fit="hips")  # the others move the legs
    assert plan.hips == ("Hips", spec.canonical["hips"])
    retargeting.apply(plan)
    pairs = [(s, t) for s, t in plan.pairs if s != "joint_Root"]
    assert len(pairs) >= 20
    frames = np.arange(int(action.frame_range[0]), int(action.frame_range[1]) + 1)
    src_dirs, tgt_dirs = pointing_pairs(source, target, pairs, frames)
    assert angles_deg(src_dirs, tgt_dirs).max() < 0.1
    # The dash runs forward as far as the source's, scaled by the legs (centimetres onto metres).
    src_hips, _ = world_tracks(source, ["Hips"], frames[[0, -1]])
    tgt_hips, _ = world_tracks(target, [spec.canonical["hips"]], frames[[0, -1]])
    travelled = np.linalg.norm(np.diff(src_hips[:, 0, :2], axis=0))
    assert np.linalg.norm(np.diff(tgt_hips[:, 0, :2], axis=0)) == pytest.approx(plan.path_scale * travelled, rel=1e-6)
    assert 0.005 < plan.path_scale < 0.02


@pytest.mark.parametrize("mode", ["still", "copy", "extract", "auto"])
@pytest.mark.parametrize("source_kind", ["bandai", "walk60"])
def test_floor_root_modes_keep_the_world_pose(mk, retargeting, walk60, bandai, source_kind, mode):
    """Onto UnrealA (root on the floor above pelvis), from a file with a floor root and from one without:
    whatever the floor root does, every bone stands where it stands with the root kept still."""
    source, action = load(mk, bandai if source_kind == "bandai" else walk60, "source")
    target = generate.build_armature(characters.UNREAL_A)
    frames = np.arange(int(action.frame_range[0]), int(action.frame_range[1]) + 1)
    names = [b.name for b in target.data.bones]
    retargeting.apply(retargeting.plan(source, target, floor_root="still"))
    still_heads, still_axes = world_tracks(target, names, frames)
    plan = retargeting.plan(source, target, floor_root=mode)
    assert plan.floor_roots == ("joint_Root" if source_kind == "bandai" else None, "root")
    retargeting.apply(plan)
    heads, axes = world_tracks(target, names, frames)
    root = names.index("root")
    hips = names.index("pelvis")
    body = [i for i in range(len(names)) if i != root]
    assert np.abs(heads[:, body] - still_heads[:, body]).max() < 1e-5  # Blender's float32 pose matrices
    assert angles_deg(axes[:, body], still_axes[:, body]).max() < 1e-3
    expected = {"auto": "copy" if source_kind == "bandai" else "still"}.get(mode, mode)
    if expected == "copy" and source_kind == "walk60":
        expected = "still"  # nothing to copy from a source without a floor root
    assert plan.floor_root == expected
    if expected == "still":
        assert np.abs(heads[:, root] - heads[:1, root]).max() < 1e-9
    elif expected == "copy":  # the dash's joint_Root runs forward; the root follows it, scaled
        src_root, _ = world_tracks(source, ["joint_Root"], frames)
        moved = np.linalg.norm(heads[-1, root, :2] - heads[0, root, :2])
        assert moved == pytest.approx(plan.path_scale * np.linalg.norm(src_root[-1, 0, :2] - src_root[0, 0, :2]),
                                      rel=1e-6)
        assert np.abs(heads[:, root, 2]).max() < 1e-6
        retargeting.apply(retargeting.plan(source, target, floor_root=mode, scale_horizontal=1.4))
        wider, _ = world_tracks(target, ["root"], frames)
        assert np.linalg.norm(wider[-1, 0, :2] - wider[0, 0, :2]) == pytest.approx(1.4 * moved, rel=1e-6)
    else:  # extract: on the floor, under the hips on average, turning with them
        assert np.abs(heads[:, root, 2]).max() < 1e-6
        gap = np.linalg.norm(heads[:, root, :2] - heads[:, hips, :2], axis=1)
        travel = np.linalg.norm(heads[-1, hips, :2] - heads[0, hips, :2])
        assert travel > 0.5 and gap.max() < 0.15, (travel, gap.max())


@pytest.mark.parametrize("mode", ["still", "copy", "extract"])
def test_walk60_onto_the_bandai_skeleton(mk, retargeting, walk60, bandai, mode):
    """Onto a zero pose (every joint along one axis at rest) with a floor root: directions still follow the
    source, in every floor-root mode ("copy" from a source without one keeps it still), the body where
    "still" puts it."""
    source, action = load(mk, walk60, "walk60")
    target, _ = load(mk, bandai, "dash")
    frames = np.arange(1, 183, 5)
    body = [b.name for b in target.data.bones if b.name != "joint_Root"]
    retargeting.apply(retargeting.plan(source, target, floor_root="still", plant_feet=False, floor_fit="hips"))
    still_heads, _ = world_tracks(target, body, frames)
    plan = retargeting.plan(source, target, floor_root=mode, plant_feet=False, floor_fit="hips")
    assert plan.floor_roots == (None, "joint_Root") and plan.hips == ("RootJoint", "Hips")
    retargeting.apply(plan)
    pairs = [(s, t) for s, t in plan.pairs if t != "joint_Root"]
    src_dirs, tgt_dirs = pointing_pairs(source, target, pairs, frames)
    assert angles_deg(src_dirs, tgt_dirs).max() < 0.1
    assert 50 < plan.path_scale < 150  # metres onto centimetres
    heads, _ = world_tracks(target, body, frames)
    assert np.abs(heads - still_heads).max() < 1e-3  # centimetres: float32 pose matrices 100 units from 0
    if mode == "extract":
        root, _ = world_tracks(target, ["joint_Root"], frames)
        assert np.ptp(root[:, 0, :2], axis=0).max() > 50  # it walks along, in centimetres


# ---------------------------------------------------------------------------
# Planted feet: one representative clip and character here; every real clip onto every sample character in
# the long tier (tests/long/test_retarget_long.py), through the same check_planted_feet.

# Bounds, measured on Blender 3.4, 4.3 and 5.2 over every clip and character (the long tier).
# The retarget holds a contact point within the source's own slide there, scaled by the leg ratio: where the
# source stands still (the Bandai dash) the target's point moves 0.0007 mm at most; HELD_M is the floor.
HELD_M = 1e-5
# No joint's largest frame-to-frame move exceeds 1.5 times the plain retarget's for that joint: measured
# -0.11 % of the leg at most over the joints planting moves (0 where it moves none); POP_EXCESS, in legs,
# is float noise only (Blender's float32 pose matrices, a micrometre on a metre's leg).
POP_EXCESS = 1e-6
KNEE_SLACK_DEG = 2.0   # the capture's own knee may pass straight by a degree or two
POINTS = ("L ankle", "L ball", "R ankle", "R ball")  # contacts.POINTS


def point_tracks(obj, feet, frames):
    """World ankle (foot bone's head) and ball (its tail) per side, (frames, 4, 3) in contacts.POINTS order,
    and per side the thigh's and shin's world Y axes and the thigh's world rotation, by the depsgraph."""
    points, legs = [], []
    for frame in frames:
        bpy.context.scene.frame_set(int(frame))
        world = obj.matrix_world
        row, leg = [], []
        for foot in feet:
            bone = obj.pose.bones[foot.foot]
            row += [tuple(world @ bone.head), tuple(world @ bone.tail)]
            thigh, shin = (world @ obj.pose.bones[foot.thigh].matrix, world @ obj.pose.bones[foot.shin].matrix)
            leg.append((np.array(thigh.to_3x3()), np.array(shin.to_3x3().col[1])))
        points.append(row)
        legs.append(leg)
    return np.array(points), legs


def channel_values(mk, obj, action):
    return {(fc.data_path, fc.array_index): mk.animdata.read_keys(fc)[1] for fc in mk.animdata.fcurves(action, obj)}


def world_leg(obj, foot):
    """One leg's length (thigh and shin) in world units."""
    return obj.matrix_world.to_scale()[0] * (obj.data.bones[foot.thigh].length + obj.data.bones[foot.shin].length)


def planted_case(mk, retargeting, path, spec):
    """path onto spec's character, plain (the legs as the source's) and planted, read back by Blender's
    evaluation: a dict of the plans, actions, source stances (stances.stance, the tests' own rule) and
    tracks."""
    source, _ = mk.bvh.load(path)  # the Bandai file in centimetres: the leg ratio converts
    target = generate.build_armature(spec)
    plain = retargeting.plan(source, target, plant_feet=False, floor_fit="hips")
    planted = retargeting.plan(source, target)
    assert planted.contacts is not None and planted.contacts.any(), path
    frames, feet = planted.frames, planted.feet
    source_of = {t: s for s, t in plain.pairs}
    source_feet = [retargeting.contacts.Foot(f.side, *(source_of[b] for b in (f.thigh, f.shin, f.foot)))
                   for f in feet]
    source_points, _ = point_tracks(source, source_feet, frames)
    # Each point stands (the tests' rule, on the source): low and slow, the point's own height and pace.
    stand = stances.stance(source_points[..., 2], source_points, world_leg(source, source_feet[0]),
                           planted.frame_rate)
    case = dict(source=source, target=target, plain=plain, planted=planted, frames=frames, feet=feet,
                stand=stand, source_points=source_points, leg=world_leg(target, feet[0]))
    case["plain_action"] = retargeting.apply(plain)
    case["plain_points"], case["plain_legs"] = point_tracks(target, feet, frames)
    case["plain_heads"] = joints(target, frames)
    case["planted_action"] = retargeting.apply(planted)
    case["points"], case["legs"] = point_tracks(target, feet, frames)
    case["heads"] = joints(target, frames)
    return case


def check_held(case, name):
    """Every contact the retarget held, and every stance the tests' own rule finds on the source (stances.stance:
    low and slow) there: the target's point strays across the floor no further than the source's own point
    there, scaled by the leg ratio, and HELD_M; a contact it did not hold (a slide, a pivot) no further than
    that or the plain retarget's point."""
    ratio, source = case["planted"].path_scale, case["source_points"]
    held = case["planted"].contact_report.held
    worst = 0.0
    for kind, mask in (("held", held), ("stance", case["stand"] & held), ("not held", case["planted"].contacts & ~held)):
        runs = stances.slides(case["points"], mask)
        assert kind == "not held" or len(runs) >= 2, (name, kind, runs)
        for p, first, last, slide in runs:
            own = ratio * np.linalg.norm(source[first:last + 1, p, :2] - source[first, p, :2], axis=1).max()
            if kind == "not held":  # a slide or a pivot moves as the plain retarget moves it
                plain = case["plain_points"][first:last + 1, p, :2]
                own = max(own, np.linalg.norm(plain - plain[0], axis=1).max())
            assert slide <= own + HELD_M, (name, kind, POINTS[p], case["frames"][first],
                                                       case["frames"][last], slide, own)
            worst = max(worst, slide - own)
    plain = max(s for *_, s in stances.slides(case["plain_points"], case["planted"].contacts))
    print(f"\n{name}: a contact's or stance's slide beyond the source's own, scaled: {1000 * worst:.4f} mm at most "
          f"(the largest slide of a contact in the plain retarget {1000 * plain:.1f} mm)")


def check_no_pops(case, name):
    """Each joint's (bone head's and tail's) largest frame-to-frame move at most 1.5 times the plain
    retarget's for that joint, and POP_EXCESS legs."""
    plain = np.linalg.norm(np.diff(case["plain_heads"], axis=0), axis=-1).max(axis=0)
    after = np.linalg.norm(np.diff(case["heads"], axis=0), axis=-1).max(axis=0)
    excess = (after - 1.5 * plain) / case["leg"]
    j = int(np.argmax(excess))
    print(f"{name}: worst joint move beyond 1.5x the plain retarget's {100 * excess[j]:.4f} % of the leg")
    assert excess[j] <= POP_EXCESS, (name, j, after[j], plain[j])


def check_knees(case, name):
    """Knees bend the way they bend in the plain retarget, never the other way."""
    frames = len(case["frames"])
    for side in range(2):
        local = lambda legs_, f: legs_[f][side][0].T @ legs_[f][side][1]  # noqa: E731  shin in thigh frame
        plain_local = np.array([local(case["plain_legs"], f) for f in range(frames)])
        bend = plain_local - np.outer(plain_local[:, 1], [0, 1, 0])
        bent = np.linalg.norm(bend, axis=1) > np.sin(np.radians(10))
        way = bend[bent].sum(axis=0)
        way /= np.linalg.norm(way)
        cleaned = np.array([local(case["legs"], f) for f in range(frames)])
        floor = min(0.0, float((plain_local @ way).min()))
        assert (cleaned @ way).min() > floor - np.sin(np.radians(KNEE_SLACK_DEG)), (name, side)


def check_other_bones(mk, case, name):
    """Bones outside the legs (and the hips' rotation) keep the plain retarget's keys exactly."""
    target, planted = case["target"], case["planted"]
    legs_bones = {b for f in case["feet"] for b in (f.thigh, f.shin, f.foot)}
    before = channel_values(mk, target, case["plain_action"])
    after = channel_values(mk, target, case["planted_action"])
    hips = f'pose.bones["{planted.hips[1]}"].location'
    for key, values in before.items():
        if key[0].split('"')[1] in legs_bones or key[0] == hips:
            continue
        assert np.abs(after[key] - values).max() <= 1e-9, (name, key)


def check_planted_feet(mk, retargeting, path, spec):
    """The clip onto the character: held where it stands, no popping, no knee bending the other way, the
    other bones as the plain retarget keys them."""
    name = f"{spec.name} <- {os.path.basename(path)}"
    case = planted_case(mk, retargeting, path, spec)
    check_held(case, name)
    check_no_pops(case, name)
    check_knees(case, name)
    check_other_bones(mk, case, name)
    for obj in (case["source"], case["target"]):
        importlib.import_module(mk.__name__ + ".blender.imports").remove_armature(obj)


def test_planted_feet_do_not_slide(mk, retargeting, shared_dir):
    """walk_and_turn_left (a walk that turns: stances under a turning body) onto RigifyA (an A-pose, other
    proportions)."""
    path = os.path.join(shared_dir, "data", "bvh", "more", "walk_and_turn_left.bvh")
    check_planted_feet(mk, retargeting, path, characters.RIGIFY_A)


def test_the_feet_solve_beside_the_key_writing_gives_the_same_keys_and_fails_cleanly(mk, retargeting, walk60):
    """retarget() starts the feet's IK solve on a worker thread while the plan's other bones are converted
    and their keys written: the same keys as a plan solved first; a failing solve leaves no new action and
    the target as it was."""
    source, _ = load(mk, walk60, "walk60")
    target = generate.build_armature(characters.RIGIFY_A)
    first = retargeting.apply(retargeting.plan(source, target))
    second = mk.retarget(source, target)
    a, b = channel_values(mk, target, first), channel_values(mk, target, second)
    assert a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)

    plan = retargeting.plan(source, target, defer_solve=True)
    assert plan.pending is not None and plan.contacts is not None
    plan.pending.result()  # the solve (and the rest of the cleanup) started with the plan ends here

    def failing():
        raise ValueError("foot cleanup: a failing solve")

    plan.pending.prepare = lambda: failing
    plan.pending.start()  # run again, failing this time, on the worker thread
    actions = set(bpy.data.actions)
    with pytest.raises(ValueError, match="failing solve"):
        retargeting.apply(plan)
    assert set(bpy.data.actions) == actions and target.animation_data.action == second


def test_a_bvh_source_stands_as_tall_as_the_target_and_goes_as_asked(mk, walk60, shared_dir):
    """A file retargeted straight from its path: the helper armature is sized to the target ("auto"; a
    centimetre file would stand 100 times too tall) or by a given scale, the keys are the same either way,
    and the helper is kept, hidden or removed as asked."""
    target = generate.build_armature(characters.MIXAMO_T)
    bandai = os.path.join(shared_dir, "data", "bvh", "more", "bandai_dash_normal_001.bvh")

    def height(obj):
        z = [(obj.matrix_world @ b.head_local).z for b in obj.data.bones]
        z += [(obj.matrix_world @ b.tail_local).z for b in obj.data.bones]
        return max(z) - min(z)

    objects = set(bpy.data.objects)
    auto = mk.retarget(bandai, target, plant_feet=False, bvh_source="keep")
    (helper,) = set(bpy.data.objects) - objects
    assert abs(height(helper) - height(target)) < 1e-6 * height(target)
    keys_auto = channel_values(mk, target, auto)
    objects = set(bpy.data.objects)
    given = mk.retarget(bandai, target, plant_feet=False, bvh_scale=1.0, bvh_source="hide")
    (hidden,) = set(bpy.data.objects) - objects
    assert hidden.hide_get() and hidden.hide_render and height(hidden) > 50 * height(target)  # centimetres
    keys_given = channel_values(mk, target, given)
    assert keys_auto.keys() == keys_given.keys()
    for key in keys_auto:
        np.testing.assert_allclose(keys_auto[key], keys_given[key], rtol=0, atol=1e-5, err_msg=str(key))
    objects, actions = set(bpy.data.objects), set(bpy.data.actions)
    mk.retarget(walk60, target, plant_feet=False, bvh_source="remove")
    assert set(bpy.data.objects) == objects and len(set(bpy.data.actions) - actions) == 1  # the target's only
    with pytest.raises(ValueError, match="bvh_source"):
        mk.retarget(walk60, target, bvh_source="bin")


# ---------------------------------------------------------------------------
# Bad input: a ValueError that names the place, the file as it was


def scene_state(mk, *objs):
    """Every datablock's name, and every key of objs' actions: what a refused call must leave alone."""
    names = {kind: sorted(i.name for i in getattr(bpy.data, kind))
             for kind in ("objects", "armatures", "actions", "meshes", "collections")}
    keys = {}
    for obj in objs:
        action = obj.animation_data.action if obj.animation_data else None
        keys[obj.name] = None if action is None else {
            (fc.data_path, fc.array_index): [tuple(k.co) for k in fc.keyframe_points]
            for fc in mk.animdata.fcurves(action, obj)}
    return names, keys, [tuple(map(tuple, o.matrix_world)) for o in objs]


@pytest.mark.parametrize("side", ["source", "target"])
def test_a_non_uniform_scale_is_refused_naming_the_armature(mk, walk60, side):
    source, _ = load(mk, walk60, "walkT")
    target = generate.build_armature(characters.MIXAMO_T)
    scaled = source if side == "source" else target
    scaled.scale = (1.0, 1.0, 1.5)
    bpy.context.view_layer.update()
    before = scene_state(mk, source, target)
    with pytest.raises(ValueError, match=rf"the {side} '{scaled.name}' has a non-uniform scale"):
        mk.retarget(source, target)
    assert scene_state(mk, source, target) == before
    # From a file too: the imported source goes again.
    if side == "target":
        with pytest.raises(ValueError, match=rf"the target '{scaled.name}' has a non-uniform scale"):
            mk.retarget(walk60, target)
        assert scene_state(mk, source, target) == before


BAD_OPTIONS = [
    (dict(root="sideways"), r"unknown root motion 'sideways'"),
    (dict(floor_root="up"), r"unknown floor root motion 'up'"),
    (dict(floor_fit="knees"), r"unknown floor_fit 'knees'"),
    (dict(root_smoothing=-1.0), r"root_smoothing must be a non-negative number of seconds, not -1.0"),
    (dict(root_smoothing=float("nan")), r"root_smoothing must be a non-negative number of seconds, not nan"),
    (dict(root_smoothing="soft"), r"root_smoothing must be a non-negative number of seconds, not 'soft'"),
    (dict(source_match="POSE"), r"source_match 'POSE'"),
    (dict(target_match="FRAME"), r"target_match 'FRAME'"),
    (dict(source_match="FRAME"), r"source match pose on a frame needs match_frame"),
    (dict(plant_feet="yes"), r"plant_feet must be True, False or None, not 'yes'"),
    (dict(align_facing="no"), r"align_facing must be True or False, not 'no'"),
    (dict(ground=1.5), r"ground must be True or False, not 1.5"),
    (dict(frame_range=(120, 60)), r"frame range 120\.\.60 is empty"),
    (dict(frame_range=(500, 600)), r"frame range 500\.\.600 is outside the source's action 'walkT' \(1\.\.182\)"),
    (dict(frame_range="all"), r"frame_range must be \(first, last\) frames, not 'all'"),
    (dict(source_floor="floor"), r"source_floor must be a height in metres or None, not 'floor'"),
    (dict(target_floor=float("inf")), r"target_floor must be a height in metres or None, not inf"),
    (dict(keys="some"), r"keys='source' is for control rigs|unknown keys 'some'"),
    (dict(controls="all"), r"unknown controls 'all'"),
    (dict(contact_settings="loose"), r"contact_settings must be a ContactSettings, not 'loose'"),
    (dict(bvh_scale=-2.0), r"bvh_scale must be 'auto' or a positive number, not -2.0"),
]


@pytest.mark.parametrize("options,message", BAD_OPTIONS, ids=lambda v: str(v)[:40] if isinstance(v, dict) else "")
def test_a_bad_option_is_refused_naming_it(mk, walk60, options, message):
    source, _ = load(mk, walk60, "walkT")
    target = generate.build_armature(characters.MIXAMO_T)
    before = scene_state(mk, source, target)
    with pytest.raises(ValueError, match=message):
        mk.retarget(walk60 if "bvh_scale" in options else source, target, **options)
    assert scene_state(mk, source, target) == before


@pytest.mark.parametrize("channel", ["rotation_quaternion", "location"])
def test_a_nan_key_in_the_source_is_refused_naming_bone_and_frame(mk, walk60, channel):
    """A NaN in the source's keys (a rotation of the left knee, a location of the hips) at Blender frame 11:
    the error names the bone, the channel and the frame; nothing changes."""
    source, action = load(mk, walk60, "walkT")
    target = generate.build_armature(characters.MIXAMO_T)
    bone = "lKnee" if channel.startswith("rotation") else "RootJoint"
    fcurve = next(fc for fc in mk.animdata.fcurves(action, source)
                  if fc.data_path == f'pose.bones["{bone}"].{channel}' or
                  (channel.startswith("rotation") and fc.data_path.startswith(f'pose.bones["{bone}"].rotation')))
    fcurve.keyframe_points[10].co[1] = float("nan")
    before = scene_state(mk, source, target)
    with pytest.raises(ValueError, match=rf"bone '{bone}'.*frame 11"):
        mk.retarget(source, target)
    with pytest.raises(ValueError, match=rf"bone '{bone}'.*frame 11"):
        mk.retarget(source, target, plant_feet=False)
    assert str(scene_state(mk, source, target)) == str(before)  # NaN != NaN: compared as text
