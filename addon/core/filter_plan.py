"""What filtering keyed motion does, without Blender: the filters and their settings, the frames a channel
is sampled on, and a channel group's values through the native filters (rotations on the quaternion
sphere, back in the group's own rotation mode with continuous angles).

No bpy here, so all of it is tested in plain Python.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import rotation_channels

# (identifier, label, description): the operator enums and the Python API share them.
FILTERS = (
    ("butterworth", "Butterworth", "Zero-phase low-pass: removes what moves faster than the cut-off"),
    ("gaussian", "Gaussian", "Weighted average of the neighbouring frames (sigma in frames)"),
    ("median", "Median", "Removes spikes: the middle value of a window of frames"),
    ("one_euro", "One-Euro", "Causal, for streamed or live data: steady when slow, responsive when fast"),
    ("euler", "Euler Discontinuity", "Euler angles made continuous, the rotations unchanged"),
)
KEYS = (
    ("EVERY_FRAME", "Every Frame", "A key on every frame of the range"),
    ("ORIGINAL", "Original Keys", "The keys where they were, with filtered values"),
)
CHANNELS = (
    ("ALL", "All", "Locations, rotations, scales and other channels"),
    ("ROTATION", "Rotations", "Rotation channels only"),
    ("LOCATION", "Locations", "Location channels only"),
)
MAYA_CUTOFF_HZ = 7.0  # Maya's Butterworth default


@dataclass(frozen=True)
class FilterSettings:
    """One filter and its parameters, as the native filters take them (keyword names match)."""
    kind: str = "butterworth"
    cutoff: float = MAYA_CUTOFF_HZ  # Hz (butterworth)
    order: int = 4  # butterworth
    sigma: float = 1.0  # frames (gaussian)
    size: int = 5  # frames, odd (median)
    min_cutoff: float = 1.0  # Hz (one_euro)
    beta: float = 0.0  # one_euro: how fast the cut-off rises with speed
    d_cutoff: float = 1.0  # Hz, one_euro's speed estimate

    def native_options(self) -> dict:
        return dict(cutoff=float(self.cutoff), order=int(self.order), sigma=float(self.sigma),
                    size=int(self.size), min_cutoff=float(self.min_cutoff), beta=float(self.beta),
                    d_cutoff=float(self.d_cutoff))

    def check(self, fps: float, where: str) -> None:
        """ValueError for settings no clip could take, naming where (the action) and the rate."""
        kinds = [f[0] for f in FILTERS]
        if self.kind not in kinds:
            raise ValueError(f"unknown filter {self.kind!r}; expected one of {kinds}")
        nyquist = 0.5 * fps
        if self.kind == "butterworth":
            if not 0.0 < self.cutoff < nyquist:
                raise ValueError(f"{where}: the cut-off {self.cutoff:g} Hz must lie between 0 and the Nyquist "
                                 f"frequency {nyquist:g} Hz of its {fps:g} fps keys")
            if not (isinstance(self.order, (int, np.integer)) and 1 <= self.order <= 8):
                raise ValueError(f"{where}: the Butterworth order must be an integer from 1 to 8, not {self.order}")
        elif self.kind == "gaussian" and not self.sigma > 0.0:
            raise ValueError(f"{where}: sigma must be positive, not {self.sigma:g}")
        elif self.kind == "median" and not (isinstance(self.size, (int, np.integer)) and self.size >= 3
                                            and self.size % 2 == 1):
            raise ValueError(f"{where}: the median window must be an odd number of frames from 3, not {self.size}")
        elif self.kind == "one_euro" and not (self.min_cutoff > 0.0 and self.beta >= 0.0 and self.d_cutoff > 0.0):
            raise ValueError(f"{where}: One-Euro needs min_cutoff > 0, beta >= 0 and d_cutoff > 0")


def grid_step(key_frames: np.ndarray) -> float:
    """Frames between the samples a curve is filtered on: the keys' own spacing when they are evenly spaced
    closer than a frame (a capture keyed at its own rate in a slower scene), else one frame. Taken as the
    mean spacing from first to last key, so that float32 key frames do not make the samples drift off them
    and lose the last key."""
    if key_frames.size >= 3:
        gaps = np.diff(key_frames.astype(np.float64))
        spacing = float(key_frames[-1] - key_frames[0]) / (key_frames.size - 1)
        if 0.0 < spacing < 1.0 - 1e-6 and np.all(np.abs(gaps - spacing) <= 1e-3 * spacing + 1e-4):
            return spacing
    return 1.0


def sample_frames(first: float, last: float, step: float) -> np.ndarray:
    """The frames a channel is filtered on: first, first + step, ... up to last (within a thousandth)."""
    count = int(np.floor((last - first) / step + 1e-3)) + 1
    return first + step * np.arange(count, dtype=np.float64)


def at_frames(samples: np.ndarray, filtered: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """The filtered values (n, size) on samples, taken at frames (original keys between samples: linear)."""
    return np.stack([np.interp(frames, samples, column) for column in filtered.T], axis=1)


def filter_groups(native, groups: list, settings: FilterSettings, fps: float, frames: np.ndarray) -> list:
    """Channel groups sampled on the same frames, filtered together: every rotation in one native call, on
    the quaternion sphere, and every other channel in another, so a clip costs two calls whatever its bone
    count. groups: [(kind, mode, values (n, size), what)], kind 'rotation' (in rotation mode `mode`),
    'vector' or 'scalar'. Returns each group's values filtered, rotations back in their mode, continuous
    from their first row; the Euler filter only makes Euler angles continuous. ValueError names the group
    and frame of a value that is not finite."""
    out = [np.asarray(values, dtype=np.float64) for _, _, values, _ in groups]
    for (_, _, _, what), values in zip(groups, out):
        if not np.isfinite(values).all():
            bad = np.argwhere(~np.isfinite(values))
            raise ValueError(f"{what}[{bad[0][1]}] is not finite at frame {frames[bad[0][0]]:g}")
    plain = [i for i, group in enumerate(groups) if group[0] != 'rotation']
    turned = [i for i, group in enumerate(groups) if group[0] == 'rotation'
              and (settings.kind != "euler" or group[1] in rotation_channels.EULER_MODES)]
    if plain and settings.kind != "euler":
        stacked = native.filter_channels(np.ascontiguousarray(np.hstack([out[i] for i in plain])), settings.kind,
                                         fps, **settings.native_options())
        # Transposed once, so that each channel's filtered values lie together for the caller's checks
        # and writes (a column of the native (n, channels) result is one value a cache line).
        rows = np.ascontiguousarray(stacked.T)
        ends = np.cumsum([out[i].shape[1] for i in plain])
        for i, end in zip(plain, ends):
            out[i] = rows[end - out[i].shape[1]:end].T
    if turned:
        q = _unit_quaternions(native, [groups[i] for i in turned], [out[i] for i in turned], frames)
        if settings.kind != "euler":
            q = native.filter_rotations(np.ascontiguousarray(q), settings.kind, fps, **settings.native_options())
        q = q.reshape(len(q), len(turned), 4)
        # One conversion per rotation mode, every bone in that mode together.
        for mode in {groups[i][1] for i in turned}:
            bones = [k for k, i in enumerate(turned) if groups[i][1] == mode]
            if mode == 'QUATERNION' and settings.kind != "euler":
                # filter_rotations returns each bone's signs continuous, its first frame's the input's:
                # what from_quaternions would make of them, so quaternion channels take them as they are
                # (transposed as the other channels above).
                chosen = q if len(bones) == q.shape[1] else q[:, bones]
                rows = np.ascontiguousarray(chosen.transpose(1, 2, 0))
                for j, k in enumerate(bones):
                    out[turned[k]] = rows[j].T
                continue
            back = rotation_channels.from_quaternions(native, mode, q[:, bones],
                                                      previous=np.stack([out[turned[k]][0] for k in bones]))
            for j, k in enumerate(bones):
                out[turned[k]] = back[:, j]
    return out


def _unit_quaternions(native, groups: list, blocks: list, frames: np.ndarray) -> np.ndarray:
    """The rotation groups' unit quaternions side by side, (n, 4 groups). Quaternion channels (a capture's
    usual case) are normalised together, in one pass instead of one a bone; any other mode, or a zero or
    non-finite quaternion (to have its error named), goes through rotation_channels.to_quaternions."""
    if all(group[1] == 'QUATERNION' for group in groups):
        q = np.hstack(blocks).reshape(len(frames), len(groups), 4)
        norm = np.sqrt(np.einsum("ijk,ijk->ij", q, q))
        if (norm > 1e-12).all():
            return (q / norm[..., None]).reshape(len(frames), 4 * len(groups))
    return np.hstack([rotation_channels.to_quaternions(native, mode, block, what, frames)
                      for (_, mode, _, what), block in zip(groups, blocks)])
