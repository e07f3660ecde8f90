"""BVH in and out of Blender: motionkit.bvh.load and motionkit.bvh.save.

The file is parsed natively, the whole clip is converted to pose channels in
one native call, and the keys are written in bulk (motionkit.animdata). The
armature's rest pose is the file's: one bone per joint, its head at the joint,
its tail at the end site, the only child, or, for several children, the child
that continues the bone's own direction (the spine, not the hips, from the
pelvis), with roll 0 in Blender's frame. Blender's Z-up frame is reached
through the same forward/up axis options as Blender's own importer.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field

import bpy
import numpy as np
from bpy_extras.io_utils import axis_conversion
from mathutils import Quaternion

from ..blender import animdata, imports, pose_channels
from ..core import bone_mapping, frame_rates, native_state, rotation_channels
from ..core.rig_data import FLOOR_PROPERTY
from .resampling import check_keys_finite

ROTATION_MODES = ('QUATERNION', 'NATIVE', 'XYZ', 'XZY', 'YXZ', 'YZX', 'ZXY', 'ZYX')
# An armature's custom property: its floor's height along its Z (a capture's floor is its origin's level,
# wherever its rest pose stands: a root OFFSET of zero hangs the rest pose below it). Retargeting reads it.
FLOOR = FLOOR_PROPERTY


@dataclass
class ImportOptions:
    scale: float = 1.0
    axis_forward: str = '-Z'
    axis_up: str = 'Y'
    rotation_mode: str = 'QUATERNION'  # or 'NATIVE' (the file's order per joint) or a Blender Euler mode
    frame_start: int = 1
    use_fps_scale: bool = False  # map file frames onto the scene's frame rate
    update_scene_fps: bool = False  # set the scene's frame rate to the file's
    update_scene_duration: bool = False  # make the scene's frame range cover the clip


def _conversion(axis_forward: str, axis_up: str):
    """BVH space to Blender armature space, as a 3x3 matrix and a w x y z quaternion."""
    matrix = axis_conversion(from_forward=axis_forward, from_up=axis_up)
    return matrix, np.array(matrix.to_quaternion(), dtype=np.float64)


def _rest_heads(skeleton) -> np.ndarray:
    offsets, parents = skeleton.offsets, skeleton.parents
    heads = np.zeros_like(offsets)
    for i, parent in enumerate(parents):
        heads[i] = offsets[i] if parent < 0 else heads[parent] + offsets[i]
    return heads


def _rest_tails(skeleton, heads: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Where each joint's bone points, in BVH space (see the module docstring)."""
    offsets, parents = skeleton.offsets, skeleton.parents
    children = [[] for _ in parents]
    for i, parent in enumerate(parents):
        if parent >= 0:
            children[parent].append(i)
    lengths = np.linalg.norm(offsets, axis=1)
    nonzero = np.sort(lengths[lengths > 0])
    typical = float(nonzero[len(nonzero) // 2]) if len(nonzero) else 1.0  # the median length
    tails = heads.copy()
    for i, kids in enumerate(children):
        kids = [k for k in kids if lengths[k] > 1e-9 * typical]
        incoming = offsets[i] / lengths[i] if parents[i] >= 0 and lengths[i] > 1e-9 * typical else up
        if kids:
            best = max(kids, key=lambda k: float(np.dot(offsets[k] / lengths[k], incoming)))
            tails[i] = heads[best]
        else:
            # A leaf without an end site: continue the incoming direction.
            size = 0.5 * (lengths[i] if parents[i] >= 0 and lengths[i] > 0 else typical)
            tails[i] = heads[i] + incoming * size
    return tails


def _edit_mode(obj):
    """Blender creates bones only in edit mode, and mode_set is the only way in.

    This is MotionKit's one operator call: it runs on the new, empty armature
    before any key exists. It pushes no undo step of its own (undo=False):
    the importing operator's single step covers it, and a headless load()
    must not serialise the whole file for the undo stack twice.
    """
    view_layer = bpy.context.view_layer
    previous = view_layer.objects.active
    view_layer.objects.active = obj
    bpy.ops.object.mode_set('EXEC_DEFAULT', False, mode='EDIT')
    return previous


def _build_armature(name: str, skeleton, heads, tails, collection):
    names, parents, end_sites = skeleton.names, skeleton.parents, skeleton.end_sites
    armature = bpy.data.armatures.new(name)
    armature[FLOOR] = 0.0
    obj = bpy.data.objects.new(name, armature)
    collection.objects.link(obj)
    previous = _edit_mode(obj)
    bone_names = {}
    try:
        edit_bones = armature.edit_bones
        for i, joint in enumerate(names):
            if end_sites[i]:
                continue
            bone = edit_bones.new(joint)
            bone.head, bone.tail, bone.roll = heads[i], tails[i], 0.0
            if parents[i] >= 0:
                bone.parent = edit_bones[bone_names[parents[i]]]
            bone_names[i] = bone.name  # Blender may shorten names beyond 63 bytes
        for i, channels in enumerate(skeleton.channels):
            if end_sites[i] or parents[i] < 0:
                continue
            bone = edit_bones[bone_names[i]]
            has_loc = any(c.endswith("position") for c in channels)
            bone.use_connect = (not has_loc) and np.allclose(bone.parent.tail, bone.head, atol=1e-7)
    finally:
        bpy.ops.object.mode_set('EXEC_DEFAULT', False, mode='OBJECT')
        bpy.context.view_layer.objects.active = previous
    return obj, bone_names


def _key_frames(motion, options: ImportOptions, scene) -> np.ndarray:
    steps = np.arange(motion.frames, dtype=np.float64)
    if options.use_fps_scale and motion.frame_time > 0:
        steps *= motion.frame_time * scene.render.fps / scene.render.fps_base
    return options.frame_start + steps


def load(filepath: str, options: ImportOptions | None = None, *, context=None, name: str | None = None,
         **option_values):
    """Imports a BVH file: returns (armature_object, action). Raises ValueError on a bad file.

    Options come as an ImportOptions or as keywords: load(path, scale=0.01,
    rotation_mode='NATIVE'). Nothing is added to the file when the BVH cannot
    be read.
    """
    options = options or ImportOptions(**option_values)
    skeleton, motion = _read_file(filepath, options)
    context = context or bpy.context
    scene = context.scene
    name = name or os.path.splitext(os.path.basename(os.fspath(filepath)))[0]
    heads, tails = _rest_bones(skeleton, options)
    obj = action = None
    try:
        obj, bone_names = _build_armature(name, skeleton, heads, tails, context.collection)
        channels, values = _channel_values(obj, bone_names, skeleton, motion, options)
        action = animdata.new_action(name)
        if channels and motion.frames:
            animdata.write_keys(obj, action, channels, _key_frames(motion, options, scene), values)
        if motion.frame_time > 0:
            # The rate the keys were captured at, per Blender frame.
            animdata.record_frame_rate(action, scene.render.fps / scene.render.fps_base if options.use_fps_scale
                                       else 1.0 / motion.frame_time)
        animdata.assign(obj, action)
    except BaseException:
        if obj is not None:
            imports.remove_armature(obj, action)
        raise
    # Every bone selected, as Blender's own importer leaves them: the Graph Editor and the Dope Sheet show
    # only selected bones' curves by default, so a fresh import would otherwise look unkeyed there.
    pose_channels.select_all(obj)
    _scene_from_clip(scene, motion, options)
    return obj, action


def _read_file(filepath, options: ImportOptions):
    """The file's (Skeleton, Motion), its options checked first."""
    filepath = os.fspath(filepath)
    if options.rotation_mode not in ROTATION_MODES:
        raise ValueError(f"bvh.load: {filepath}: unknown rotation_mode {options.rotation_mode!r}; expected one "
                         f"of {', '.join(ROTATION_MODES)}")
    if not _positive(options.scale):
        raise ValueError(f"bvh.load: {filepath}: scale must be a positive number, got {options.scale!r}")
    if not filepath or os.path.basename(filepath) == "" and os.path.isdir(filepath):
        raise ValueError("no BVH file was chosen" + (f" (only the folder {filepath})" if filepath else ""))
    if os.path.isdir(filepath):
        raise ValueError(f"{filepath} is a folder, not a BVH file")
    skeleton, motion = native_state.native().read_bvh(filepath)  # MotionKitError is a ValueError
    if all(skeleton.end_sites):
        raise ValueError(f"{filepath}: the hierarchy has no joints to make bones of")
    return skeleton, motion


def _rest_bones(skeleton, options: ImportOptions) -> tuple[np.ndarray, np.ndarray]:
    """Every joint's bone head and tail (joints, 3) in Blender's armature space, as the importer makes them."""
    conv_matrix, _ = _conversion(options.axis_forward, options.axis_up)
    up = np.array(conv_matrix).T @ np.array([0.0, 0.0, 1.0])  # Blender's up, in BVH space
    heads_bvh = _rest_heads(skeleton)
    tails_bvh = _rest_tails(skeleton, heads_bvh, up)
    to_blender = np.array(conv_matrix) * options.scale
    return heads_bvh @ to_blender.T, tails_bvh @ to_blender.T


def _joint_rotation_mode(joint_channels, mode: str) -> str:
    """The rotation mode of a joint's bone: NATIVE is the file's order of its three rotation channels."""
    if mode != 'NATIVE':
        return mode
    letters = "".join(c[0] for c in joint_channels if c.endswith("rotation"))
    return letters[::-1] if len(letters) == 3 and len(set(letters)) == 3 else 'QUATERNION'


def _channel_values(obj, bone_names, skeleton, motion, options: ImportOptions) -> tuple[list, np.ndarray]:
    """The bones' channels (their rotation modes set here) and the clip's values on them (channels, frames),
    converted from the file's in one native call."""
    native = native_state.native()
    rest = pose_channels.rest_quaternions(obj.data)
    bone_rest = np.tile([1.0, 0.0, 0.0, 0.0], (len(skeleton), 1))
    for i, bone in bone_names.items():
        bone_rest[i] = rest[bone]
    _, conv_quat = _conversion(options.axis_forward, options.axis_up)
    rotations, locations = native.bvh_to_pose(skeleton, np.ascontiguousarray(motion.values), bone_rest,
                                              conv_quat, float(options.scale))
    # Plan the channels, then fill one (channels, frames) matrix in place.
    channels, fills = [], []
    for i, bone in bone_names.items():
        joint_channels = skeleton.channels[i]
        path = pose_channels.bone_path(bone)
        if any(c.endswith("position") for c in joint_channels):
            fills.append((len(channels), 'LOCATION', i))
            channels += [(f"{path}.location", k, bone) for k in range(3)]
        if not any(c.endswith("rotation") for c in joint_channels):
            continue
        mode = _joint_rotation_mode(joint_channels, options.rotation_mode)
        obj.pose.bones[bone].rotation_mode = mode
        fills.append((len(channels), mode, i))
        prop, size = ("rotation_quaternion", 4) if mode == 'QUATERNION' else ("rotation_euler", 3)
        channels += [(f"{path}.{prop}", k, bone) for k in range(size)]
    matrix = np.empty((len(channels), motion.frames))
    eulers = {}  # Euler mode -> [(row, joint)]: one native call per mode, its joints spread over the cores
    for row, kind, i in fills:
        if kind == 'LOCATION':
            matrix[row:row + 3] = locations[:, 3 * i:3 * i + 3].T
        elif kind == 'QUATERNION':
            matrix[row:row + 4] = rotations[:, 4 * i:4 * i + 4].T
        else:
            eulers.setdefault(kind, []).append((row, i))
    for kind, joints in eulers.items():
        order, axes = rotation_channels.euler_order(kind)
        columns = (4 * np.array([i for _, i in joints])[:, None] + np.arange(4)).ravel()
        angles = native.quaternion_to_euler(np.ascontiguousarray(rotations[:, columns]), order)
        for k, (row, _) in enumerate(joints):
            matrix[[row + a for a in axes]] = angles[:, 3 * k:3 * k + 3].T
    return channels, matrix


def _scene_from_clip(scene, motion, options: ImportOptions) -> None:
    """The scene's frame rate and range from the file, as options ask."""
    if options.update_scene_fps and motion.frame_time > 0:
        # The rate the file meant: its printed frame time (0.016667 s) is 60 fps, not 59.9988.
        scene.render.fps, scene.render.fps_base = frame_rates.scene_rate(motion.frame_time)
    if options.update_scene_duration and motion.frames:
        last = _key_frames(motion, options, scene)[-1]
        scene.frame_start = options.frame_start
        scene.frame_end = max(scene.frame_end, int(np.ceil(last)))


def file_mapping_rig(filepath: str, options: ImportOptions | None = None):
    """A BVH file's skeleton as the importer would make its bones, for motionkit.bone_mapping."""
    options = options or ImportOptions()
    skeleton, _ = native_state.native().read_bvh(os.fspath(filepath))
    heads, tails = _rest_bones(skeleton, options)
    joints = [i for i, end in enumerate(skeleton.end_sites) if not end]
    index = {j: k for k, j in enumerate(joints)}
    return bone_mapping.Rig(tuple(skeleton.names[j] for j in joints),
                            tuple(index.get(skeleton.parents[j], -1) for j in joints),
                            heads[joints], tails[joints])


@dataclass
class ExportOptions:
    scale: float = 1.0  # BVH units per Blender unit
    axis_forward: str = '-Z'
    axis_up: str = 'Y'
    rotation_order: str = 'NATIVE'  # BVH channel order; NATIVE: each Euler bone's own, else ZXY
    frame_range: tuple[int, int] | None = None  # inclusive; default: the scene's


def _channel_letters(pose_bone, rotation_order: str) -> str:
    if rotation_order != 'NATIVE':
        return rotation_order
    mode = pose_bone.rotation_mode
    return mode[::-1] if mode in ROTATION_MODES[2:] else "ZXY"


def save(obj, filepath: str, options: ExportOptions | None = None, *, context=None,
         **option_values) -> None:
    """Writes obj's action (in the armature's rest frame and world placement) as BVH.

    Options come as an ExportOptions or as keywords: save(obj, path,
    frame_range=(1, 100)). Rotation and location keys of the active action are
    evaluated natively, as Blender evaluates them; constraints, drivers and the
    NLA are not baked.
    """
    options = options or ExportOptions(**option_values)
    native = native_state.native()
    scene = (context or bpy.context).scene
    _check_export(obj, options)
    frames = pose_channels.frames_between(*(options.frame_range or (scene.frame_start, scene.frame_end)))
    _, rotation, obj_scale = obj.matrix_world.decompose()
    sigma = float(np.mean(obj_scale))
    if not np.allclose(obj_scale, sigma, rtol=1e-6):
        raise ValueError(f"bvh.save: '{obj.name}' has a non-uniform scale {tuple(obj_scale)}")
    bones = pose_channels.depth_first(obj.data)
    action = animdata.assigned_action(obj)
    if action is not None:
        check_keys_finite(obj, [fc for fc in animdata.fcurves(action, obj) if fc.data_path.startswith("pose.bones")],
                          "bvh.save")
    rotations = pose_channels.rotations(obj, action, bones, frames)
    locations, animated = pose_channels.locations(obj, action, bones, frames)
    locations *= sigma

    conv_matrix, conv_quat = _conversion(options.axis_forward, options.axis_up)
    world = np.array(obj.matrix_world)
    to_bvh = np.array(conv_matrix).T * options.scale
    points = (np.vstack([pose_channels.heads(bones), pose_channels.tails(bones)]) @ world[:3, :3].T
              + world[:3, 3]) @ to_bvh.T
    rest = pose_channels.rest_quaternions(obj.data)
    rest_world = [np.array(rotation @ Quaternion(rest[b.name])) for b in bones]
    joints = _export_joints(obj, bones, points[:len(bones)], points[len(bones):], animated, rest_world,
                            options.rotation_order)
    skeleton = native.Skeleton(joints.names, joints.parents, np.array(joints.offsets), joints.end_sites,
                               joints.channels)
    # Pose arrays per joint (end sites carry identity, ignored by the job).
    count = len(joints.names)
    joint_rot = np.tile([1.0, 0.0, 0.0, 0.0], (frames.size, count))
    joint_loc = np.zeros((frames.size, 3 * count))
    for i, j in enumerate(joints.of_bone):
        joint_rot[:, 4 * j:4 * j + 4] = rotations[:, 4 * i:4 * i + 4]
        joint_loc[:, 3 * j:3 * j + 3] = locations[:, 3 * i:3 * i + 3]
    values = native.pose_to_bvh(skeleton, joint_rot, joint_loc, np.array(joints.rest), conv_quat,
                                1.0 / options.scale)
    frame_time = scene.render.fps_base / scene.render.fps
    native.write_bvh(os.fspath(filepath), skeleton, native.Motion(values, frame_time))


def _positive(value) -> bool:
    try:
        value = float(value)
    except (TypeError, ValueError):
        return False
    return bool(np.isfinite(value) and value > 0)


def _check_export(obj, options: ExportOptions) -> None:
    if obj is None:
        raise ValueError("bvh.save: pick an armature object")
    if not isinstance(obj, bpy.types.Object) or obj.type != 'ARMATURE':
        raise ValueError(f"bvh.save: '{getattr(obj, 'name', obj)}' is not an armature object")
    if not len(obj.data.bones):
        raise ValueError(f"bvh.save: armature '{obj.name}' has no bones")
    if not _positive(options.scale):
        raise ValueError(f"bvh.save: scale must be a positive number, got {options.scale!r}")
    if options.rotation_order != 'NATIVE' and options.rotation_order not in ROTATION_MODES[2:]:
        raise ValueError(f"bvh.save: unknown rotation order {options.rotation_order!r}")


@dataclass
class _Joints:
    """The BVH hierarchy of an armature: a joint per bone (parents first) and an end site after each leaf."""
    names: list = field(default_factory=list)
    parents: list = field(default_factory=list)
    offsets: list = field(default_factory=list)
    end_sites: list = field(default_factory=list)
    channels: list = field(default_factory=list)
    rest: list = field(default_factory=list)      # each joint's rest orientation in the file's world
    of_bone: list = field(default_factory=list)   # each bone's joint

    def add(self, name, parent, offset, end_site, channels, rest) -> int:
        for column, value in zip((self.names, self.parents, self.offsets, self.end_sites, self.channels, self.rest),
                                 (name, parent, offset, end_site, channels, rest)):
            column.append(value)
        return len(self.names) - 1


def _export_joints(obj, bones, heads, tails, animated, rest_world, rotation_order) -> _Joints:
    """The joints of bones (depth first) with heads and tails in BVH space: a bone's position channels only
    where it moves (the root, or a loose bone whose location is animated)."""
    joints = _Joints()
    parents = pose_channels.parent_indices(bones)
    for i, bone in enumerate(bones):
        parent = parents[i]
        letters = _channel_letters(obj.pose.bones[bone.name], rotation_order)
        moves = parent < 0 or (animated[i] and not bone.use_connect)
        channels = ([f"{a}position" for a in "XYZ"] if moves else []) + [f"{a}rotation" for a in letters]
        joint = joints.add(bone.name, joints.of_bone[parent] if parent >= 0 else -1,
                           heads[i] - (heads[parent] if parent >= 0 else 0.0), False, channels, rest_world[i])
        joints.of_bone.append(joint)
        if not bone.children:
            joints.add(bone.name + "_end", joint, tails[i] - heads[i], True, [], np.array([1.0, 0.0, 0.0, 0.0]))
    return joints
