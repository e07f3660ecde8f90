"""World-space key reduction (reduce_keys(space='WORLD')): every joint and the points 10 cm along each
bone's axes stay within the distance of where they were, on every frame and between frames, as Blender
itself poses the armature (scene.frame_set with its subframe and pose_bone.matrix, read before and after;
never the reducer's own figures).

Slack: Blender's pose matrices are float32, so each point is known to about 4 float32 ulps of its
coordinates (8 * 1.2e-7 * the largest coordinate, world units) plus 1e-7 for the float32 keys and handles
Blender stores; the bound is asserted at distance + that.
"""
import math
import os

import bpy
import numpy as np
import pytest
from blender_eval import world_points

AXIS = 0.1
DISTANCE = 1e-3
FLOAT32 = 1.2e-7


def import_fbx(path):
    before = set(bpy.data.objects)
    bpy.ops.import_scene.fbx(filepath=path)
    return next(o for o in bpy.data.objects if o not in before and o.type == 'ARMATURE')


def frames_of(action):
    first, last = action.frame_range
    return np.arange(int(round(first)), int(round(last)) + 1)


def between_frames(action):
    """Every frame and the thirds between them: the reduced curves interpolate between frames, where the
    bound holds as well (a motion-blurred render, or a retime, samples there)."""
    first, last = action.frame_range
    return np.arange(3 * int(round(first)), 3 * int(round(last)) + 1) / 3.0


def slack(points):
    return 8 * FLOAT32 * float(np.abs(points).max()) + 1e-7


def key_count(action, animdata, obj):
    return sum(len(fc.keyframe_points) for fc in animdata.fcurves(action, obj))


def all_keys(action, animdata, obj):
    return {(fc.data_path, fc.array_index): np.array([tuple(p.co) + tuple(p.handle_left) + tuple(p.handle_right)
                                                      for p in fc.keyframe_points])
            for fc in animdata.fcurves(action, obj)}


def reduce_and_measure(mk, animdata, obj, action, capsys, label, **options):
    frames = between_frames(action)
    before_points = world_points(obj, frames, AXIS)
    before = key_count(action, animdata, obj)
    counted = mk.reduce_keys(obj, space='WORLD', distance=DISTANCE, axis_length=AXIS, **options)
    after_points = world_points(obj, frames, AXIS)
    error = np.linalg.norm(after_points - before_points, axis=-1)
    worst = float(error.max())
    after = key_count(action, animdata, obj)
    with capsys.disabled():
        print(f"\n{label}: world reduction {before} keys -> {after} ({100 * after / before:.1f} %), worst "
              f"error {worst * 1e3:.4f} mm over {len(frames)} frames and thirds of frames (on whole frames "
              f"{error[::3].max() * 1e3:.4f} mm)")
    assert counted == (before, after)
    assert after < before
    bone, point = np.unravel_index(np.argmax(error.max(axis=0)), error.shape[1:])
    assert worst <= DISTANCE + slack(before_points), \
        f"{obj.pose.bones[int(bone)].name} point {point}: {worst * 1e3:.4f} mm"
    return before, after, worst


def test_walk60_stays_within_a_millimetre(mk, animdata, walk60, capsys):
    obj, action = mk.bvh.load(walk60)
    before, after, _ = reduce_and_measure(mk, animdata, obj, action, capsys, "walk60")
    assert after < before / 2


def test_mixamo_punch_stays_within_a_millimetre(mk, animdata, shared_dir, capsys):
    path = os.path.join(shared_dir, "data", "fbx", "ybot@punch.fbx")
    if not os.path.isfile(path):
        if os.environ.get("CI") == "true":
            pytest.fail(f"{path} is missing, and CI=true requires it")
        pytest.skip(f"{path} is absent (set up ../shared to run this test)")
    obj = import_fbx(path)
    action = animdata.assigned_action(obj)
    assert obj.scale[0] == pytest.approx(0.01)  # armature in centimetres: the bound goes through the scale
    reduce_and_measure(mk, animdata, obj, action, capsys, "ybot@punch")


def _mixed_modes(mk, animdata, obj, action):
    """walk60 with some bones turned to Euler and axis-angle rotation modes, their curves rewritten."""
    pose_channels = mk.pose_channels
    modes = {"lHip": 'XYZ', "lKnee": 'ZXY', "rHip": 'AXIS_ANGLE', "rKnee": 'YZX', "lowerback_torso": 'AXIS_ANGLE',
             "lShoulder": 'YXZ'}
    names = [name for name in modes if name in obj.pose.bones]
    assert len(names) >= 4, [b.name for b in obj.pose.bones]
    frames = frames_of(action).astype(np.float64)
    bones = [obj.data.bones[name] for name in names]
    q = pose_channels.rotations(obj, action, bones, frames)
    for name in names:
        obj.pose.bones[name].rotation_mode = modes[name]
        for fc in [fc for fc in animdata.fcurves(action, obj)
                   if fc.data_path == pose_channels.bone_path(name) + ".rotation_quaternion"]:
            animdata.fcurves(action, obj).remove(fc)
    channels, values = pose_channels.rotation_keys(obj, names, q)
    animdata.write_keys(obj, action, channels, frames, values, 'LINEAR')
    return names, modes


def test_a_mix_of_rotation_modes(mk, animdata, walk60, capsys):
    obj, action = mk.bvh.load(walk60)
    names, modes = _mixed_modes(mk, animdata, obj, action)
    reduce_and_measure(mk, animdata, obj, action, capsys, "walk60, mixed rotation modes")
    for name in names:
        prop = {'AXIS_ANGLE': "rotation_axis_angle"}.get(modes[name], "rotation_euler")
        curves = [fc for fc in animdata.fcurves(action, obj) if fc.data_path.endswith(f'"{name}"].{prop}')]
        assert curves and all(fc.keyframe_points[0].interpolation == 'BEZIER' for fc in curves)


@pytest.mark.parametrize("setting, value", [("distance", 0.0), ("distance", -1e-3), ("distance", math.nan),
                                            ("distance", math.inf), ("axis_length", -0.1),
                                            ("axis_length", math.nan)])
def test_a_bad_setting_raises_and_changes_nothing(mk, animdata, walk60, setting, value):
    obj, action = mk.bvh.load(walk60)
    keys = all_keys(action, animdata, obj)
    with pytest.raises(ValueError, match=setting):
        mk.reduce_keys(obj, space='WORLD', **{setting: value})
    after = all_keys(action, animdata, obj)
    assert keys.keys() == after.keys()
    assert all(np.array_equal(keys[k], after[k]) for k in keys)


def test_world_space_needs_an_armature(mk, animdata):
    obj = bpy.data.objects.new("holder", None)
    bpy.context.scene.collection.objects.link(obj)
    action = animdata.new_action("moving")
    frames = np.arange(1.0, 21.0)
    animdata.write_keys(obj, action, [("location", 0)], frames, np.sin(frames / 5)[None], 'LINEAR')
    animdata.assign(obj, action)
    with pytest.raises(ValueError, match="armature"):
        mk.reduce_keys(obj, space='WORLD')
    assert len(animdata.find_fcurve(action, obj, "location", 0).keyframe_points) == 20


def test_the_operator_reduces_in_world_space(mk, animdata, walk60):
    obj, action = mk.bvh.load(walk60)
    for other in bpy.context.view_layer.objects:
        other.select_set(other == obj)
    bpy.context.view_layer.objects.active = obj
    frames = between_frames(action)[::7]  # every seventh third of a frame: whole frames and between
    before_points = world_points(obj, frames, AXIS)
    before = key_count(action, animdata, obj)
    assert bpy.ops.motionkit.reduce_keys('EXEC_DEFAULT', space='WORLD', distance=2e-3, axis_length=AXIS) == \
        {'FINISHED'}
    assert key_count(action, animdata, obj) < before
    error = np.linalg.norm(world_points(obj, frames, AXIS) - before_points, axis=-1)
    assert error.max() <= 2e-3 + slack(before_points)
