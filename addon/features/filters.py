"""Filter keyed motion in Blender: motionkit.filter.

Each channel group (a location, a rotation, a scale, one scalar) is sampled once per frame of its keys'
rate over the range, filtered natively in one call (rotations as quaternions on the sphere, whatever the
bone's rotation mode: core/filter_plan.py), and written back in bulk: a key on every frame, or the
original keys with filtered values. Keys outside the range keep their frames and values. Everything is
computed and checked before the first F-curve changes, so an error leaves every action as it was.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..blender import animdata, channel_groups
from ..core import filter_plan, native_state
from ..core.filter_plan import FilterSettings
from .resampling import KeyWrite, bones_of, plan_group_writes, target_actions, write_planned

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
    work, clips = [], {}
    for obj, action in target_actions(targets, "filter"):
        fps = animdata.frame_rate(action)
        settings.check(fps, f"'{action.name}'")
        groups = [g for g in channel_groups.read(obj, action, bones_of(bones, obj)) if _CHOSEN[channels](g)]
        groups = [g for g in groups if not animdata.holds_every_key(next(iter(g.curves.values())))]
        if not groups:
            raise ValueError(f"'{obj.name}' has no keys to filter" + (" on the selected bones" if bones else ""))
        work.append((obj, action, groups))
        clips[obj.name, action.name] = _ClipFilter(native, settings, fps, frame_range, keys, groups)
    planned, before, after = plan_group_writes(
        work, lambda obj, action, group: clips[obj.name, action.name].write_of(obj, action, group), progress)
    write_planned(planned)
    return FilterReport(sum(len(w.channels) for *_, ws in planned for w in ws), before, after,
                        [action for _, action, _ in planned])


@dataclass
class _GroupFrames:
    """A channel group's keys and the frames it is filtered on."""
    group: object
    channels: list
    static: np.ndarray
    key_frames: np.ndarray  # every curve's, when they all share them (shared), else their union
    key_values: np.ndarray | None  # (curves, keys) as they are, when shared
    shared: bool
    first: float
    last: float
    step: float  # frames between samples
    samples: np.ndarray


class _ClipFilter:
    """Filters a whole clip the first time one of its groups is asked for: the groups that share sample
    frames go through the native filters together (filter_plan.filter_groups), two calls a clip."""

    def __init__(self, native, settings, fps, frame_range, keys, groups):
        self.native, self.settings, self.fps, self.frame_range, self.keys = native, settings, fps, frame_range, keys
        self.groups, self.writes = groups, None

    def write_of(self, obj, action, group) -> KeyWrite:
        if self.writes is None:
            self.writes = self._filter_clip(obj, action, self.groups)
        return self.writes[id(group)]

    def _filter_clip(self, obj, action, groups) -> dict:
        """Each group's KeyWrite by id. A sample is one Blender frame, or the keys' own spacing where a
        capture is keyed closer than that; the action's frame rate says how many Blender frames make a
        second, so the filters' Hz are seconds of the capture whatever the scene plays it at."""
        plans = [_group_frames(obj, group, self.frame_range) for group in groups]
        writes, grids = {}, {}
        for plan in plans:
            if plan.samples.size < 2:
                values = channel_groups.sample(obj, action, plan.channels, plan.static, plan.key_frames)
                writes[id(plan.group)] = KeyWrite(plan.channels, plan.key_frames, np.ascontiguousarray(values.T),
                                                  'BEZIER', None)
            else:
                grids.setdefault((plan.samples[0], plan.samples.size, plan.step), []).append(plan)
        for (*_, step), same_grid in grids.items():
            self.settings.check(self.fps / step, f"'{action.name}'")
            samples = same_grid[0].samples
            # One float64 copy of every channel (the float32 keys widened as they are gathered), a channel
            # a row as the keys are read: each group's block a transposed view, its values together.
            values = np.concatenate([plan.key_values if _keys_are_samples(plan) else
                                     channel_groups.sample(obj, action, plan.channels, plan.static, samples).T
                                     for plan in same_grid], axis=0, dtype=np.float64)
            ends = np.cumsum([len(p.channels) for p in same_grid])
            blocks = [(p.group.kind, p.group.mode, values[end - len(p.channels):end].T, p.group.data_path)
                      for p, end in zip(same_grid, ends)]
            try:
                filtered = filter_plan.filter_groups(self.native, blocks, self.settings, self.fps / step, samples)
            except (ValueError, self.native.MotionKitError) as ex:
                raise ValueError(f"{obj.name}: {ex}") from None
            for plan, values_of_group in zip(same_grid, filtered):
                writes[id(plan.group)] = _group_write(obj, action, plan, values_of_group, self.keys)
        return writes


def _group_frames(obj, group, frame_range) -> _GroupFrames:
    channels, static = channel_groups.channels(obj, group)
    reads = [animdata.read_keys(fcurve) for fcurve in group.curves.values()]
    for fcurve, (frames, values) in zip(group.curves.values(), reads):
        if np.isfinite(values).all() and np.isfinite(frames).all():
            continue  # the usual case, without the index arrays that name a bad key
        bad = np.flatnonzero(~np.isfinite(values) | ~np.isfinite(frames))
        if bad.size:
            raise ValueError(f"'{obj.name}': the key of {fcurve.data_path}[{fcurve.array_index}] at frame "
                             f"{frames[bad[0]]:g} is {values[bad[0]]:g}, not a finite number")
    shared = all(f.shape == reads[0][0].shape and np.array_equal(f, reads[0][0]) for f, _ in reads)
    key_frames = (reads[0][0] if shared else np.unique(np.concatenate([f for f, _ in reads]))).astype(np.float64)
    first, last = float(key_frames[0]), float(key_frames[-1])
    step = filter_plan.grid_step(key_frames)
    if frame_range is not None:
        first, last = max(first, float(frame_range[0])), min(last, float(frame_range[1]))
        chosen = key_frames[(key_frames >= first - 1e-6) & (key_frames <= last + 1e-6)]
        if step < 1.0 and chosen.size:  # a dense capture's samples stay on its keys
            first, last = float(chosen[0]), float(chosen[-1])
    order = list(group.curves)
    key_values = (np.stack([reads[order.index(c.index)][1] for c in channels if c.index in group.curves])
                  if shared else None)
    return _GroupFrames(group, channels, static, key_frames, key_values, shared, first, last,
                        step, filter_plan.sample_frames(first, last, step))


def _keys_are_samples(plan: _GroupFrames) -> bool:
    """Whether every channel has a curve keyed exactly on the samples and nowhere else, without modifiers:
    its keys are then its samples, read already, and Blender need not evaluate the curves (a capture's
    usual case)."""
    frames = plan.key_frames
    return (plan.shared and len(plan.key_values) == len(plan.channels) and _on_frames(frames, plan.samples)
            and not any(len(fcurve.modifiers) for fcurve in plan.group.curves.values()))


def _on_frames(frames: np.ndarray, samples: np.ndarray) -> bool:
    """Whether the key frames are the sample frames, one for one, to 1e-4 frame: np.allclose(rtol=0,
    atol=1e-4) without its overhead, which 455 curves of 10,000 keys notice."""
    return frames.size == samples.size and bool(np.all(np.abs(frames - samples) <= 1e-4))


def _group_write(obj, action, plan: _GroupFrames, filtered, keys) -> KeyWrite:
    """The group's new keys: filtered inside the range, as they were outside it. Where the keys stay where
    they are (the original keys, or a key already on every sample frame), only their values change, in
    place: their interpolation and handle types stay, and nothing is deleted and rebuilt."""
    frames, samples = plan.key_frames, plan.samples
    inside = (frames >= plan.first - 1e-6) & (frames <= plan.last + 1e-6)
    every = bool(inside.all())
    on_samples = _on_frames(frames if every else frames[inside], samples)
    if plan.shared and (keys == "ORIGINAL" or on_samples):
        present = [row for row, channel in enumerate(plan.channels) if channel.index in plan.group.curves]
        ours = filtered if len(present) == filtered.shape[1] else filtered[:, present]
        if every and on_samples:  # every key is a sample: its filtered value is its new value, no copy
            values = ours.T
        else:
            values = plan.key_values.astype(np.float64)
            values[:, inside] = ours.T if on_samples else filter_plan.at_frames(samples, ours, frames[inside]).T
        return KeyWrite([plan.channels[row] for row in present], frames, values, 'BEZIER', None, in_place=True)
    new_frames = samples if keys == "EVERY_FRAME" else frames[inside]
    new_values = filtered if keys == "EVERY_FRAME" else filter_plan.at_frames(samples, filtered, new_frames)
    kept = frames[~inside]
    all_frames = np.concatenate([kept[kept < plan.first], new_frames, kept[kept > plan.last]])
    kept_values = (channel_groups.sample(obj, action, plan.channels, plan.static, kept) if kept.size
                   else np.empty((0, len(plan.channels))))
    values = np.concatenate([kept_values[kept < plan.first], new_values, kept_values[kept > plan.last]])
    return KeyWrite(plan.channels, all_frames, np.ascontiguousarray(values.T), 'BEZIER', None)
