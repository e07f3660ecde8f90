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


def sample_frames(first: float, last: float, step: float) -> np.ndarray:
    """The frames a channel is filtered on: first, first + step, ... up to last (within a thousandth)."""
    count = int(np.floor((last - first) / step + 1e-3)) + 1
    return first + step * np.arange(count, dtype=np.float64)


def at_frames(samples: np.ndarray, filtered: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """The filtered values (n, size) on samples, taken at frames (original keys between samples: linear)."""
    return np.stack([np.interp(frames, samples, column) for column in filtered.T], axis=1)


def filter_values(native, kind: str, mode: str, values: np.ndarray, settings: FilterSettings, fps: float,
                  what: str) -> np.ndarray:
    """One channel group's values (n, size) filtered. kind: 'rotation' (in rotation mode `mode`), 'vector'
    or 'scalar'. Rotations are filtered as unit quaternions on the sphere and come back in mode, continuous
    from the first row; the Euler filter only makes Euler angles continuous and leaves the rest as it is."""
    values = np.ascontiguousarray(values, dtype=np.float64)
    if kind != 'rotation':
        if settings.kind == "euler":
            return values
        return native.filter_channels(values, settings.kind, fps, **settings.native_options())
    if settings.kind == "euler" and mode not in rotation_channels.EULER_MODES:
        return values
    q = rotation_channels.to_quaternions(native, mode, values, what)
    if settings.kind != "euler":
        q = native.filter_rotations(np.ascontiguousarray(q), settings.kind, fps, **settings.native_options())
    return rotation_channels.from_quaternions(native, mode, q, previous=values[0])
