"""Key reduction bounded where the viewer sees it: the pose bones' keys of an armature, reduced so that
every joint, and points a set length along each bone's axes, stay within a distance of where the
original keys put them (native world_key_reduction.hpp; docs/cleanup.md).

distance and axis_length are in the scene's units: they are divided by the armature object's largest
scale factor (of its world matrix at the current frame), so that the bound, checked in armature space,
holds in world space too. Only the channels that pose the bones count: each bone's location (unless
the bone is connected, which ignores it), its scale, and the rotation of its own rotation mode. The
object's own transform, an unused rotation mode's curves and other properties are not poses of the
bones: reduce_keys fits them per channel with its tolerances.
"""
from __future__ import annotations

import numpy as np

from ..blender import animdata, channel_groups, pose_channels
from ..core import resample_plan, rotation_channels

# The native Euler orders, as numbered by the native rotation modes (2 + index).
_NATIVE_ORDERS = ('XYZ', 'XZY', 'YXZ', 'YZX', 'ZXY', 'ZYX')
_CHANNELS = 10  # per bone: rotation 4, location 3, scale 3
_GROUP_COLUMN = {0: 0, 1: 4, 2: 7}


def check_settings(distance, axis_length) -> None:
    """ValueError naming the setting when distance is not > 0 or axis_length not >= 0 (or either is not
    finite)."""
    for name, value, bound in (("distance", distance, "> 0"), ("axis_length", axis_length, ">= 0")):
        try:
            number = float(value)
        except (TypeError, ValueError):
            number = float("nan")
        ok = np.isfinite(number) and (number > 0 if bound == "> 0" else number >= 0)
        if not ok:
            raise ValueError(f"reduce_keys: {name} must be finite and {bound}, got {value!r}")


def _native_mode(mode: str) -> tuple[int, list[int]]:
    """A Blender rotation mode as the native code and, per native column, the channel it holds."""
    if mode == 'QUATERNION':
        return 0, [0, 1, 2, 3]
    if mode == 'AXIS_ANGLE':
        return 1, [0, 1, 2, 3]
    order, axes = rotation_channels.euler_order(mode)
    return 2 + _NATIVE_ORDERS.index(order), axes


def _check_inheritance(obj) -> None:
    for bone in obj.data.bones:
        if not (bone.use_inherit_rotation and bone.inherit_scale == 'FULL' and bone.use_local_location):
            raise ValueError(f"space='WORLD': bone '{bone.name}' of '{obj.name}' does not inherit its parent's "
                             "rotation and scale fully or has a global location; reduce it per channel")


def _world_scale(obj) -> float:
    scale = float(np.linalg.svd(np.array(obj.matrix_world, dtype=np.float64)[:3, :3], compute_uv=False)[0])
    if not (np.isfinite(scale) and scale > 0):
        raise ValueError(f"space='WORLD': '{obj.name}' has a zero or non-finite scale")
    return scale


def _pose_slot(obj, bone_paths, group) -> tuple[int, int] | None:
    """(bone, group 0 rotation / 1 location / 2 scale) when the channel group poses a bone, else None;
    bone_paths: {data path of a pose bone: (name, index)}."""
    if group.owner not in bone_paths:
        return None
    name, b = bone_paths[group.owner]
    pose_bone = obj.pose.bones[name]
    if group.prop == rotation_channels.channel_property(pose_bone.rotation_mode)[0]:
        return b, 0
    if group.prop == "location" and not pose_bone.bone.use_connect:
        return b, 1
    if group.prop == "scale":
        return b, 2
    return None


def _static_channels(obj, bones) -> tuple[np.ndarray, np.ndarray, list]:
    """Every bone's ten channels as they stand (1, 10 B), the native rotation modes (B,) and each bone's
    native column order."""
    row = np.zeros(_CHANNELS * len(bones))
    modes, columns = np.zeros(len(bones), dtype=np.int32), []
    for b, bone in enumerate(bones):
        pose_bone = obj.pose.bones[bone.name]
        modes[b], order = _native_mode(pose_bone.rotation_mode)
        prop, _ = rotation_channels.channel_property(pose_bone.rotation_mode)
        rotation = np.array(tuple(getattr(pose_bone, prop)), dtype=np.float64)
        start = _CHANNELS * b
        row[start:start + len(order)] = rotation[order]
        row[start + 4:start + 7] = tuple(pose_bone.location) if not bone.use_connect else (0.0, 0.0, 0.0)
        row[start + 7:start + 10] = tuple(pose_bone.scale)
        columns.append(order)
    return row[None], modes, columns


def plan(native, obj, action, groups, distance, axis_length, samples_per_frame) -> dict:
    """New keys for those of groups that pose obj's bones: {(owner, prop): (channels, frames, values (size,
    k), slopes_in (size, k), slopes_out (size, k))}, every bone's pose bounded as the module says."""
    if obj.type != 'ARMATURE':
        raise ValueError(f"space='WORLD' bounds an armature's joints; '{obj.name}' is not an armature")
    _check_inheritance(obj)
    scale = _world_scale(obj)
    rig, bones = pose_channels.native_rig(obj.data)
    bone_paths = {pose_channels.bone_path(bone.name): (bone.name, b) for b, bone in enumerate(bones)}
    # Every curve that poses a bone counts, selected or not.
    posing = [(group, _pose_slot(obj, bone_paths, group)) for group in channel_groups.read(obj, action, None)]
    posing = [(group, slot) for group, slot in posing if slot is not None]
    selected = {(group.owner, group.prop) for group in groups}
    if not any((group.owner, group.prop) in selected for group, _ in posing):
        return {}
    ends = {group.label(): _key_range(group) for group, _ in posing}
    first, last = min(e[0] for e in ends.values()), max(e[1] for e in ends.values())
    times = resample_plan.samples_between(first, last, samples_per_frame)
    static, modes, columns = _static_channels(obj, bones)
    values = np.repeat(static, times.size, axis=0)
    ranges = np.full((3 * len(bones), 2), -1, dtype=np.int32)
    _sample_posing(obj, action, posing, times, values, columns)
    for group, (b, g) in posing:
        if (group.owner, group.prop) not in selected:
            continue
        start, stop = ends[group.label()]
        begin = int(np.floor((start - first) * samples_per_frame + 1e-6))
        end = int(np.ceil((stop - first) * samples_per_frame - 1e-6))
        ranges[3 * b + g] = (max(begin, 0), min(end, times.size - 1))
    keys, slopes_in, slopes_out, _ = native.reduce_keys_world(
        rig, times, values, modes, ranges, distance / scale, axis_length / scale, samples_per_frame)
    return {(group.owner, group.prop): _group_keys(obj, group, b, g, times, values, keys, (slopes_in, slopes_out),
                                                   columns[b])
            for group, (b, g) in posing if ranges[3 * b + g, 0] >= 0}


def _key_range(group) -> tuple[float, float]:
    """The first and last key frame over the group's curves (keys are kept in time order)."""
    points = [fc.keyframe_points for fc in group.curves.values()]
    return min(p[0].co[0] for p in points), max(p[-1].co[0] for p in points)


def _group_columns(b, g, order) -> np.ndarray:
    """The native columns of bone b's group g, in the order of the group's Blender channels."""
    start = _CHANNELS * b + _GROUP_COLUMN[g]
    if g != 0:
        return start + np.arange(3)
    return start + np.argsort(order)


def _sample_posing(obj, action, posing, times, values, columns) -> None:
    """The posing groups' channels as Blender evaluates them at times, into values (m, 10 B), in one call."""
    wanted, statics, targets = [], [], []
    for group, (b, g) in posing:
        channels, static = channel_groups.channels(obj, group)
        wanted += [(channel.data_path, channel.index) for channel in channels]
        statics.append(static)
        targets.append(_group_columns(b, g, columns[b])[:len(channels)])
    sampled, _ = animdata.sample(action, obj, wanted, times, np.concatenate(statics))
    values[:, np.concatenate(targets)] = sampled.T


def _group_keys(obj, group, b, g, times, values, keys, slopes, order) -> tuple:
    rows = np.flatnonzero(keys[:, 3 * b + g])
    channels, _ = channel_groups.channels(obj, group)
    cols = _group_columns(b, g, order)[:len(channels)]
    taken = [np.ascontiguousarray(array[np.ix_(rows, cols)].T) for array in (values, *slopes)]
    return (channels, times[rows], *taken)
