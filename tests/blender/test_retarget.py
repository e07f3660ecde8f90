"""motionkit.retarget in a real Blender, checked against Blender's own evaluation (depsgraph pose matrices).

The done-means of the retargeting issue: the brief's lab check both ways
(T-pose walk60 onto an A-pose copy and back, world joints to 1e-6 of the
height), random bone rolls (directions to 0.01 deg), walk60 onto each sample
character (mapped directions to 0.1 deg, foot heights scaled by the leg
ratio), and errors that change nothing.
"""
import math
import os

import bpy
import numpy as np
import pytest
from mathutils import Vector

import characters
import generate

FEET = {  # per rig kind: (ankle bone, toe bone) for each side
    "walk60": (("lAnkle", "lToeJoint"), ("rAnkle", "rToeJoint")),
}


@pytest.fixture()
def retargeting(mk):
    return mk.retargeting


def load(mk, path, name):
    return mk.bvh.load(path, name=name)


def a_pose_file(native, walk60, path):
    """walk60's skeleton with lShoulder turned (0, 0, -45 deg) and rShoulder (0, 0, +45 deg), as in the brief."""
    skeleton, motion = native.read_bvh(walk60)
    offsets = np.array(skeleton.offsets)
    parents = list(skeleton.parents)

    def below(joint):
        out = []
        for i, p in enumerate(parents):
            if p == joint:
                out += [i] + below(i)
        return out

    for side, degrees in (("lShoulder", -45.0), ("rShoulder", 45.0)):
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
    scene = bpy.context.scene
    out = []
    for frame in frames:
        scene.frame_set(int(frame))
        world = obj.matrix_world.to_3x3()
        out.append([tuple((world @ obj.pose.bones[n].matrix.to_3x3()).col[1].normalized()) for n in names])
    return np.array(out)


def angles_deg(a, b):
    cross = np.linalg.norm(np.cross(a, b), axis=-1)
    return np.degrees(np.arctan2(cross, np.sum(a * b, axis=-1)))


def same_names(obj):
    return [(b.name, b.name) for b in obj.data.bones]


def height(obj):
    z = [p[2] for b in obj.data.bones for p in (b.head_local, b.tail_local)]
    return max(z) - min(z)


def test_t_pose_to_a_pose_and_back_keeps_every_world_joint(mk, native, walk60, tmp_path):
    source, action = load(mk, walk60, "walkT")
    a_rig, _ = load(mk, a_pose_file(native, walk60, tmp_path / "walk60_A.bvh"), "walkA")
    # The A-pose rig really is another rest pose: its arms point 45 deg down.
    arm = a_rig.data.bones["lShoulder"]
    assert abs((arm.tail_local - arm.head_local).normalized().z + math.sin(math.radians(45))) < 1e-6
    frames = np.arange(1, 183)
    tolerance = 1e-6 * height(source)

    mk.retarget(source, a_rig, bone_map=same_names(a_rig))
    expected = joints(source, frames)
    there = joints(a_rig, frames)
    assert np.abs(there - expected).max() < tolerance

    back, _ = load(mk, walk60, "walkT2")
    mk.retarget(a_rig, back, bone_map=same_names(back))
    again = joints(back, frames)
    assert np.abs(again - expected).max() < tolerance


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
    action = mk.retarget(source, target, bone_map=same_names(target))
    names = [b.name for b in target.data.bones]
    frames = np.arange(1, 183)
    worst = angles_deg(directions(source, names, frames), directions(target, names, frames)).max()
    assert worst < 0.01
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
    plan = retargeting.plan(source, target, pairs)
    retargeting.apply(plan)
    frames = np.arange(1, 183)
    src_dirs = directions(source, [s for s, _ in pairs], frames)
    tgt_dirs = directions(target, [t for _, t in pairs], frames)
    assert angles_deg(src_dirs, tgt_dirs).max() < 0.1

    # Feet: height above the floor (Z = 0 for both: the capture's floor, the
    # character's ground; walk60's rest pose hangs below it, its root OFFSET
    # being zero), the source's scaled by the ratio of leg lengths.
    def leg_length(obj, hips):
        bones = obj.data.bones
        return bones[hips].head_local.z - min(min(b.head_local.z, b.tail_local.z) for b in bones)

    ratio = leg_length(target, spec.canonical["hips"]) / leg_length(source, "RootJoint")
    floor_s = floor_t = 0.0
    errors = []
    for side, (ankle, toe) in zip("LR", FEET["walk60"]):
        t_ankle, t_toe = spec.canonical[f"foot.{side}"], spec.canonical[f"toe.{side}"]
        for frame in frames[::3]:
            bpy.context.scene.frame_set(int(frame))
            h_s = min(source.pose.bones[ankle].head.z, source.pose.bones[toe].tail.z) - floor_s
            h_t = min(target.pose.bones[t_ankle].head.z, target.pose.bones[t_toe].tail.z) - floor_t
            errors.append(abs(h_t - ratio * h_s))
    worst = max(errors)
    print(f"\n{spec.name}: leg ratio {ratio:.3f}, worst foot height error {100 * worst:.2f} cm")
    assert worst < 0.02  # measured 0.8-1.5 cm: the rigs' thigh:shin:foot proportions differ


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

    def hips_path(root, ground=False):
        retargeting.apply(retargeting.plan(source, target, pairs, root=root, ground=ground))
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
    retargeting.apply(retargeting.plan(source, target, pairs, ground=True))
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
    settings.source_kind = 'BVH'
    settings.target = target
    settings.bvh_path = str(tmp_path / "missing.bvh")
    objects = set(bpy.data.objects)
    assert not bpy.ops.motionkit.retarget.poll()
    broken = tmp_path / "broken.bvh"
    broken.write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 zero\n")
    settings.bvh_path = str(broken)
    with pytest.raises(RuntimeError, match="broken.bvh"):
        bpy.ops.motionkit.retarget()
    assert set(bpy.data.objects) == objects
    settings.bvh_path = walk60
    assert bpy.ops.motionkit.bone_map_auto() == {'FINISHED'}
    assert len(settings.pairs) >= 16
    assert bpy.ops.motionkit.retarget() == {'FINISHED'}
    assert target.animation_data.action is not None
    assert len(mk.animdata.fcurves(target.animation_data.action, target)) > 40


def test_batch_retargets_a_folder_of_files(mk, walk60, shared_dir):
    target = generate.build_armature(characters.RIGIFY_A)
    files = sorted(os.path.join(shared_dir, "data", "bvh", f) for f in os.listdir(os.path.join(shared_dir, "data", "bvh"))
                   if f.endswith(".bvh"))
    objects = set(bpy.data.objects)
    actions = mk.retarget_files(files, target)
    assert [a.name for a in actions] == [os.path.splitext(os.path.basename(f))[0] for f in files]
    assert set(bpy.data.objects) == objects  # the imported sources are gone again
    assert all(a.use_fake_user for a in actions)


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
    assert bpy.ops.motionkit.bone_map_add() == {'FINISHED'}
    assert len(settings.pairs) == len(pairs) + 1
    settings.active_pair = 0
    assert bpy.ops.motionkit.bone_map_remove() == {'FINISHED'}
    assert settings.bone_map() == pairs[1:]
    assert bpy.ops.motionkit.bone_map_load(filepath=path) == {'FINISHED'}
    assert settings.bone_map() == pairs
    assert bpy.ops.motionkit.bone_map_scheme(source_scheme="games105", target_scheme="rigify_metarig") == {'FINISHED'}
    assert dict(settings.bone_map())["lHip"] == "thigh.L"
