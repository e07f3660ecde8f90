"""An action's F-curves as channel groups (a location, a rotation in its own mode, a scalar property), each
group's channels with the values its owner holds where no curve is, and those channels read or sampled in
bulk: what resampling, key reduction and the filters read."""
from __future__ import annotations

import numpy as np

from . import animdata, pose_channels
from ..core import resample_plan, rotation_channels
from ..core.resample_plan import ChannelGroup


def read(obj, action, bones) -> list[ChannelGroup]:
    """obj's keyed, unmuted curves in action grouped per property; bones: names or None (every owner)."""
    owners = None if bones is None else {pose_channels.bone_path(b) for b in bones}

    def euler_mode_of(owner):
        holder = obj.path_resolve(owner) if owner else obj
        mode = getattr(holder, "rotation_mode", 'XYZ')
        return mode if mode in rotation_channels.EULER_MODES else 'XYZ'

    triples = []
    for fcurve in animdata.fcurves(action, obj):
        owner, _ = resample_plan.split_path(fcurve.data_path)
        if owners is not None and owner not in owners:
            continue
        if len(fcurve.keyframe_points) and not fcurve.mute:
            triples.append((fcurve.data_path, fcurve.array_index, fcurve))
    return resample_plan.group_channels(triples, euler_mode_of)


def channels(obj, group: ChannelGroup) -> tuple[list, np.ndarray]:
    """Every channel of the group (present or not) and each one's static value."""
    holder = obj.path_resolve(group.owner) if group.owner else obj
    static = np.atleast_1d(np.asarray(getattr(holder, group.prop) if group.prop else
                                      obj.path_resolve(group.data_path), dtype=np.float64))
    if group.kind == 'scalar':
        index = next(iter(group.curves))
        fcurve = group.curves[index]
        return [animdata.Channel(fcurve.data_path, index, _group_name(fcurve))], static[index:index + 1]
    name = _group_name(next(iter(group.curves.values())))
    return [animdata.Channel(group.data_path, k, name) for k in range(group.size)], static[:group.size]


def _group_name(fcurve) -> str:
    return fcurve.group.name if fcurve.group is not None else ""


def keys(obj, action, group: ChannelGroup) -> tuple[list, np.ndarray, np.ndarray]:
    """The group's channels, its key times (union over its curves) and every channel there, (n, size)."""
    reads = {index: animdata.read_keys(fcurve) for index, fcurve in group.curves.items()}
    frames = [f for f, _ in reads.values()]
    group_channels, static = channels(obj, group)
    same = all(f.shape == frames[0].shape and np.array_equal(f, frames[0]) for f in frames)
    times = frames[0].astype(np.float64) if same else np.unique(np.concatenate(frames)).astype(np.float64)
    values = np.tile(static, (times.size, 1))
    if same:
        for row, channel in enumerate(group_channels):
            if channel.index in reads:
                values[:, row] = reads[channel.index][1]
    else:
        values = sample(obj, action, group_channels, static, times)
    return group_channels, times, values


def sample(obj, action, channels, static, times) -> np.ndarray:
    """The channels as Blender evaluates them at times, (n, size); a channel without a curve holds static."""
    return np.ascontiguousarray(animdata.sample(action, obj, channels, times, static)[0].T)
