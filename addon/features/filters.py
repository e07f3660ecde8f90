"""Filter keyed motion in Blender: motionkit.filter.

Each channel group (a location, a rotation, a scale, one scalar) is sampled once per frame of its keys'
rate over the range, filtered natively in one call (rotations as quaternions on the sphere, whatever the
bone's rotation mode: core/filter_plan.py), and written back in bulk: a key on every frame, or the
original keys with filtered values. Keys outside the range keep their frames and values. Everything is
computed and checked before the first F-curve changes, so an error leaves every action as it was.
"""
from __future__ import annotations

from dataclasses import dataclass

import bpy
import numpy as np

from ..blender import animdata
from ..core import filter_plan, native_state
from ..core.filter_plan import FilterSettings
from .resampling import KeyWrite, bones_of, channel_groups, channels_of_group, plan_group_writes, sample_channels, \
    target_actions, write_planned

# Which channel groups each `channels` choice takes: scale is a vector too, but not a location.
_CHOSEN = {"ALL": lambda group: True, "ROTATION": lambda group: group.kind == 'rotation',
           "LOCATION": lambda group: group.prop in ("location", "delta_location")}


@dataclass
class FilterReport:
    """What motionkit.filter did: curves changed, keys before and after, the actions."""
    curves: int
    keys_before: int
    keys_after: int
    actions: list


def filter(targets, kind: str = "butterworth", *, cutoff: float = filter_plan.MAYA_CUTOFF_HZ, order: int = 4,
           sigma: float = 1.0, size: int = 5, min_cutoff: float = 1.0, beta: float = 0.0, d_cutoff: float = 1.0,
           bones=None, frame_range=None, keys: str = "EVERY_FRAME", channels: str = "ALL",
           progress=None) -> FilterReport:
    """Filter the keys of the targets' actions.

    targets: an object, an action an object plays, or a list of them. kind: 'butterworth' (zero-phase
    low-pass, cutoff in Hz and order), 'gaussian' (sigma in frames), 'median' (size: an odd window of
    frames), 'one_euro' (causal: min_cutoff and d_cutoff in Hz, beta) or 'euler' (Euler angles made
    continuous). Frequencies are in Hz of the action's own frame rate (its capture's, else the scene's).
    bones: pose bone names, or {object name: names} (default: every curve). frame_range: (first, last)
    frames filtered (default: the keys' whole range). keys: 'EVERY_FRAME' or 'ORIGINAL'. channels: 'ALL',
    'ROTATION' or 'LOCATION'. Returns a FilterReport; a ValueError leaves every action as it was.
    """
    native = native_state.native()
    settings = FilterSettings(kind, cutoff, order, sigma, size, min_cutoff, beta, d_cutoff)
    if keys not in [k[0] for k in filter_plan.KEYS]:
        raise ValueError(f"unknown keys {keys!r}; expected one of {[k[0] for k in filter_plan.KEYS]}")
    if channels not in _CHOSEN:
        raise ValueError(f"unknown channels {channels!r}; expected one of {list(_CHOSEN)}")
    work, rates = [], {}
    for obj, action in target_actions(targets):
        fps = animdata.frame_rate(action)
        settings.check(fps, f"'{action.name}'")
        groups = [g for g in channel_groups(obj, action, bones_of(bones, obj)) if _CHOSEN[channels](g)]
        groups = [g for g in groups if not animdata.holds_every_key(next(iter(g.curves.values())))]
        if not groups:
            raise ValueError(f"'{obj.name}' has no keys to filter" + (" on the selected bones" if bones else ""))
        work.append((obj, action, groups))
        rates[obj.name] = fps
    planned, before, after = plan_group_writes(
        work, lambda obj, action, group: _filter_group(native, obj, action, group, settings, rates[obj.name],
                                                       frame_range, keys), progress)
    write_planned(planned)
    return FilterReport(sum(len(w.channels) for *_, ws in planned for w in ws), before, after,
                        [action for _, action, _ in planned])


def _filter_group(native, obj, action, group, settings, fps, frame_range, keys) -> KeyWrite:
    """The group's new keys: filtered inside the range, as they were outside it."""
    channels, static = channels_of_group(obj, group)
    key_frames = np.unique(np.concatenate([animdata.read_keys(fc)[0] for fc in group.curves.values()]))
    first, last = float(key_frames[0]), float(key_frames[-1])
    if frame_range is not None:
        first, last = max(first, float(frame_range[0])), min(last, float(frame_range[1]))
    step = (bpy.context.scene.render.fps / bpy.context.scene.render.fps_base) / fps
    samples = filter_plan.sample_frames(first, last, step)
    inside = (key_frames >= first - 1e-6) & (key_frames <= last + 1e-6)
    if samples.size < 2:
        frames = key_frames
        values = sample_channels(obj, action, channels, static, frames)
        return KeyWrite(channels, frames, np.ascontiguousarray(values.T), 'BEZIER', None)
    values = sample_channels(obj, action, channels, static, samples)
    try:
        filtered = filter_plan.filter_values(native, group.kind, group.mode, values, settings, fps,
                                             group.data_path)
    except native.MotionKitError as ex:
        raise ValueError(f"{obj.name}: {group.label()}: {ex}") from None
    new_frames = samples if keys == "EVERY_FRAME" else key_frames[inside]
    new_values = filtered if keys == "EVERY_FRAME" else filter_plan.at_frames(samples, filtered, new_frames)
    kept = key_frames[~inside]
    frames = np.concatenate([kept[kept < first], new_frames, kept[kept > last]])
    kept_values = sample_channels(obj, action, channels, static, kept) if kept.size else np.empty((0, len(channels)))
    values = np.concatenate([kept_values[kept < first], new_values, kept_values[kept > last]])
    return KeyWrite(channels, frames, np.ascontiguousarray(values.T), 'BEZIER', None)
