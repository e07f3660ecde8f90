"""The pose channels as Blender poses them (blender/pose_channels.py), judged by Blender's own evaluation
(frame_set, pose_bone.head and pose_bone.matrix): a bone connected to its parent ignores its location
channel in Blender, so the native pose of the channels read here must ignore it too, keyed or not."""
import importlib

import bpy
import numpy as np
import pytest
from mathutils import Quaternion

import characters
import generate
from rotations import matrix_angles

# float32 rest matrices and keys posed through up to nine bones (the Mixamo sample's hand), native doubles
# against Blender's float32 evaluation: measured at most 3.6e-7 m and 3.4e-5 degrees (3.4); about ten times.
SHIFT = 4e-6
TURN_DEG = 4e-4
FRAMES = 12


@pytest.fixture()
def pose_channels(mk):
    return importlib.import_module(mk.__name__ + ".blender.pose_channels")


def _keyed_everywhere(mk, obj):
    """Every bone turned and moved (location keyed on connected bones too, where Blender ignores it)."""
    t = np.linspace(0.0, 1.0, FRAMES)
    rows, channels = [], []
    for i, bone in enumerate(obj.data.bones):
        axis = (np.cos(i), 1.0, np.sin(i))
        rows.append(np.array([Quaternion(axis, 0.3 * np.sin(2 * np.pi * x + i)) for x in t]).T)
        rows.append(np.stack([0.02 * np.sin(2 * np.pi * t + i), 0.03 * t, 0.01 * np.cos(3 * t + i)]))
        path = f'pose.bones["{bone.name}"]'
        channels += [(f"{path}.rotation_quaternion", k) for k in range(4)]
        channels += [(f"{path}.location", k) for k in range(3)]
    action = mk.animdata.new_action("everywhere")
    mk.animdata.write_keys(obj, action, channels, np.arange(1.0, FRAMES + 1), np.vstack(rows))
    mk.animdata.assign(obj, action)
    return action


def _blender_pose(obj, bones):
    heads, matrices = [], []
    for frame in range(1, FRAMES + 1):
        bpy.context.scene.frame_set(frame)
        heads.append([tuple(obj.pose.bones[b.name].head) for b in bones])
        matrices.append([np.array(obj.pose.bones[b.name].matrix) for b in bones])
    return np.array(heads), np.array(matrices)


def _quaternion_matrices(q):
    return np.array([Quaternion(row).to_matrix() for row in q.reshape(-1, 4)]).reshape(q.shape[:-1] + (3, 3))


def test_a_keyed_clip_is_posed_where_blender_puts_it(mk, pose_channels):
    obj = generate.build_armature(characters.MIXAMO_T)
    connected = [b.name for b in obj.data.bones if b.use_connect]
    assert connected, "the sample must have connected bones for this test to mean anything"
    action = _keyed_everywhere(mk, obj)
    rig, bones = pose_channels.native_rig(obj.data)
    rotations, heads = pose_channels.armature_motion(obj, action, np.arange(1.0, FRAMES + 1), rig, bones)
    theirs_heads, theirs = _blender_pose(obj, bones)
    shift = float(np.abs(heads.reshape(FRAMES, -1, 3) - theirs_heads).max())
    turn = float(np.degrees(matrix_angles(_quaternion_matrices(rotations.reshape(FRAMES, -1, 4)), theirs).max()))
    print(f"\nposed natively against Blender ({len(connected)} connected bones keyed): {shift:.1e} m, {turn:.1e} deg")
    assert shift <= SHIFT
    assert turn <= TURN_DEG
    _, animated = pose_channels.locations(obj, action, bones, np.arange(1.0, FRAMES + 1))
    assert not any(moves for b, moves in zip(bones, animated) if b.use_connect)
    assert all(moves for b, moves in zip(bones, animated) if not b.use_connect)


def test_the_pose_as_it_stands_reads_a_connected_bone_unmoved(mk, pose_channels):
    obj = generate.build_armature(characters.MIXAMO_T)
    for pose_bone in obj.pose.bones:
        pose_bone.location = (0.1, 0.2, 0.3)
    bones = pose_channels.depth_first(obj.data)
    _, moved = pose_channels.current_pose(obj, bones)
    rig, _ = pose_channels.native_rig(obj.data, bones)
    rotations, heads = mk.native().armature_pose(rig, np.tile([1.0, 0, 0, 0], (1, len(bones))),
                                                  np.ascontiguousarray(moved.reshape(1, -1)))
    bpy.context.view_layer.update()
    theirs = np.array([tuple(obj.pose.bones[b.name].head) for b in bones])
    assert np.abs(heads.reshape(-1, 3) - theirs).max() <= SHIFT
    assert all((moved[i] == 0).all() == b.use_connect for i, b in enumerate(bones))


def test_a_read_rig_carries_each_bone_s_mode_and_pose_as_it_stands(mk, pose_channels):
    """RigData.channels, read with the rest: each bone's rotation mode and value as the pose bone holds them,
    and the pose's quaternions as Blender's own matrix_basis turns them."""
    obj = generate.build_armature(characters.MIXAMO_T)
    modes = ("QUATERNION", "XYZ", "ZXY", "AXIS_ANGLE")
    for i, pose_bone in enumerate(obj.pose.bones):
        pose_bone.rotation_mode = modes[i % 4]
        pose_bone.rotation_quaternion = Quaternion((np.cos(i), 1.0, np.sin(i)), 0.4)
        pose_bone.rotation_euler = (0.1 * i, -0.2, 0.3)
        pose_bone.rotation_axis_angle = (0.7, 0.0, 1.0, 0.2 * i)
    rig = pose_channels.read_rig(obj)
    for i, name in enumerate(rig.names):
        pose_bone = obj.pose.bones[name]
        assert rig.channels.modes[i] == pose_bone.rotation_mode
        theirs = Quaternion(pose_bone.matrix_basis.to_quaternion())
        ours = Quaternion(rig.channels.basis[i])
        # matrix_basis is float32: its quaternion agrees to a few 1e-7 of a radian.
        assert ours.rotation_difference(theirs).angle < 1e-5, name


@pytest.mark.parametrize("name", ['arm "L"', "back\\slash", "tab\tand\nline"])
def test_a_bone_s_path_is_quoted_as_blender_quotes_it(mk, pose_channels, name):
    obj = generate.build_armature(characters.MIXAMO_T)
    bpy.context.view_layer.objects.active = obj
    obj.data.bones[0].name = name
    assert pose_channels.bone_path(name) == f'pose.bones["{bpy.utils.escape_identifier(name)}"]'
    assert obj.path_resolve(pose_channels.bone_path(name)).name == name
