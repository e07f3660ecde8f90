"""What resampling and key reduction do, without Blender: the choices, the new key times,
which F-curves travel together, and Bezier handles from Hermite slopes.

No bpy here, so all of it is tested in plain Python.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

# (identifier, label, description): the operator enums and the Python API share them.
SCALAR_INTERPOLANTS = (
    ("catmull-rom", "Catmull-Rom", "Through every key, tangents from the neighbours"),
    ("centripetal", "Centripetal Catmull-Rom", "Catmull-Rom with centripetal knots: no cusps or loops"),
    ("chordal", "Chordal Catmull-Rom", "Catmull-Rom with chord-length knots"),
    ("kochanek-bartels", "Kochanek-Bartels", "Catmull-Rom with tension, continuity and bias"),
    ("natural", "Natural spline", "C2 cubic spline, zero curvature at the ends"),
    ("clamped", "Clamped spline", "C2 cubic spline, zero slope at the ends"),
    ("not-a-knot", "Not-a-knot spline", "C2 cubic spline, scipy's default ends"),
    ("periodic", "Periodic spline", "C2 cubic spline for cycles (first and last keys equal)"),
    ("monotone", "Monotone cubic", "Never overshoots the keys (PCHIP)"),
    ("linear", "Linear", "Straight lines between keys"),
    ("stepped", "Stepped", "Hold each key until the next"),
    ("polynomial", "Polynomial", "One polynomial through all keys (for comparison: Runge's phenomenon)"),
)
ROTATION_INTERPOLANTS = (
    ("squad", "Squad", "Spherical quadrangle: smooth on the quaternion sphere"),
    ("kochanek-bartels", "Kochanek-Bartels", "Spherical Kochanek-Bartels with tension, continuity and bias"),
    ("catmull-rom", "Catmull-Rom", "Catmull-Rom on the quaternion sphere"),
    ("slerp", "Slerp", "Constant-speed arcs between keys"),
    ("euler-catmull-rom", "Euler Catmull-Rom", "Per Euler channel, for comparison: wobbles and flips"),
    ("axis-angle-catmull-rom", "Axis-angle Catmull-Rom", "Per rotation-vector component, for comparison"),
)
OUTPUTS = (
    ("EXACT", "Exact curve",
     "Keys on the new frames with Bezier handles, so that Blender draws the chosen curve itself"),
    ("DENSE", "Dense keys", "One linear key per new frame, sampled from the chosen curve"),
)
# Interpolants whose segments are exactly Bezier segments (or Blender's own
# constant or linear keys); the others are written as dense keys.
BLENDER_INTERPOLATION = {"stepped": 'CONSTANT', "linear": 'LINEAR'}
NOT_CUBIC = {"polynomial"}

_PATH = re.compile(r'^(?P<owner>.*?)\.?(?P<prop>[A-Za-z_][A-Za-z0-9_]*)$')
_ROTATIONS = {"rotation_quaternion": 'QUATERNION', "rotation_axis_angle": 'AXIS_ANGLE',
              "rotation_euler": None, "delta_rotation_quaternion": 'QUATERNION',
              "delta_rotation_euler": None}
_VECTORS = {"location", "scale", "delta_location", "delta_scale"}


def split_path(data_path: str) -> tuple[str, str]:
    """'pose.bones["a"].location' -> ('pose.bones["a"]', 'location'); 'location' -> ('', 'location')."""
    match = _PATH.match(data_path)
    if match is None or data_path.endswith("]"):
        return data_path, ""
    return match.group("owner"), match.group("prop")


@dataclass
class ChannelGroup:
    """F-curves that are resampled together: a rotation, a vector, or one scalar.

    kind: 'rotation', 'vector' or 'scalar'. mode: for rotations, the Blender
    rotation mode whose channels these are. curves: {array_index: curve}, where
    a curve is whatever the caller passed (an F-curve in Blender).
    """
    owner: str
    prop: str
    kind: str
    mode: str = ""
    curves: dict = field(default_factory=dict)

    @property
    def data_path(self) -> str:
        return f"{self.owner}.{self.prop}" if self.owner else self.prop

    @property
    def size(self) -> int:
        if self.kind == 'rotation':
            return 3 if self.mode not in ('QUATERNION', 'AXIS_ANGLE') else 4
        if self.kind == 'vector':
            return max(3, max(self.curves) + 1)
        return 1

    def label(self) -> str:
        return self.data_path if self.kind != 'scalar' else f"{self.data_path}[{next(iter(self.curves))}]"


def group_channels(curves, euler_mode_of=lambda owner: 'XYZ') -> list[ChannelGroup]:
    """Group (data_path, array_index, curve) triples into ChannelGroups, in first-seen order.

    euler_mode_of(owner) gives the Euler mode of the bone or object that owns a
    rotation_euler curve (its rotation_mode when that is an Euler mode, else 'XYZ').
    """
    groups: dict[tuple, ChannelGroup] = {}
    for data_path, index, curve in curves:
        owner, prop = split_path(data_path)
        if prop in _ROTATIONS:
            key = (owner, prop)
            if key not in groups:
                mode = _ROTATIONS[prop] or euler_mode_of(owner)
                groups[key] = ChannelGroup(owner, prop, 'rotation', mode)
        elif prop in _VECTORS:
            key = (owner, prop)
            groups.setdefault(key, ChannelGroup(owner, prop, 'vector'))
        else:
            key = (owner, prop, index)
            groups.setdefault(key, ChannelGroup(owner, prop, 'scalar'))
        groups[key].curves[index] = curve
    return list(groups.values())


@dataclass(frozen=True)
class Timing:
    """Where the new keys go: new_frame = anchor + (old_frame - anchor) * scale, keys every step."""
    scale: float
    anchor: float
    step: float
    scene_fps: float | None  # the scene's new frame rate, or None to leave it

    def map(self, frames):
        return self.anchor + (np.asarray(frames, dtype=np.float64) - self.anchor) * self.scale


def plan_timing(scene_fps: float, anchor: float, step: float | None = None, fps: float | None = None,
                change_scene_rate: bool = False) -> Timing:
    """The time mapping for a frame step, or for a new frame rate with or without the scene's.

    A new rate with the scene's rate changed keeps every key at the same time in
    seconds: frames are rescaled about `anchor` and keys go on every new frame.
    Without changing the scene, keys go every scene_fps / fps frames (60 -> 24
    gives a key every 2.5 frames, the 24 fps look at the scene's rate).
    """
    if (step is None) == (fps is None):
        raise ValueError("resample: give either a frame step or a frame rate")
    if not scene_fps > 0:
        raise ValueError(f"resample: the scene's frame rate {scene_fps} is not positive")
    if step is not None:
        if not (np.isfinite(step) and step > 0):
            raise ValueError(f"resample: the frame step must be positive, got {step}")
        return Timing(1.0, anchor, float(step), None)
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"resample: the frame rate must be positive, got {fps}")
    if change_scene_rate:
        return Timing(fps / scene_fps, anchor, 1.0, float(fps))
    return Timing(1.0, anchor, scene_fps / fps, None)


def samples_between(first: float, last: float, samples_per_frame: int) -> np.ndarray:
    """first, then every 1/samples_per_frame of a frame up to last: the samples a key reduction is checked
    on (uniform, so that a sample's index says its time)."""
    count = int(np.floor((last - first) * samples_per_frame + 1e-9)) + 1
    return first + np.arange(count, dtype=np.float64) / samples_per_frame


def key_grid(first: float, last: float, step: float) -> np.ndarray:
    """first, first + step, ... up to last, and last itself when it is a whole frame.

    The end key keeps the clip's last pose where it can sit on a frame; a
    fractional end (60 -> 24 fps maps frame 10,000 to 4,000.6) is left out
    rather than leaving a key between frames.
    """
    if not last >= first:
        raise ValueError(f"resample: the keys end ({last:g}) before they start ({first:g})")
    count = int(np.floor((last - first) / step + 1e-9)) + 1
    grid = first + step * np.arange(count, dtype=np.float64)
    if last - grid[-1] > 1e-6 * step and _whole(last):
        grid = np.append(grid, last)
    return grid


def segment_grid(grid: np.ndarray, first: float, last: float) -> np.ndarray:
    """The keys of one channel group whose own keys span [first, last]: the grid there, plus
    its ends where they are whole frames or where the grid has nothing inside."""
    eps = 1e-6
    inside = grid[(grid > first + eps) & (grid < last - eps)]

    def keep(end):
        return _whole(end) or not inside.size or bool(np.any(np.abs(grid - end) < eps))

    head = [first] if keep(first) else []
    tail = [last] if last > first + eps and keep(last) else []
    return np.concatenate([head, inside, tail]).astype(np.float64)


def _whole(frame: float) -> bool:
    return abs(frame - round(frame)) < 1e-6


def bezier_handles(frames, values, slopes_in, slopes_out):
    """Handles that make Blender's Bezier segments exactly the cubic Hermite segments.

    frames (n,), values/slopes (c, n). Each handle sits a third of its segment
    from the key, so a segment's time is linear in the Bezier parameter and its
    value is the Hermite cubic. The outer handles of the end keys mirror the
    neighbouring segment; constant extrapolation never evaluates them.
    Returns (left_frames, left_values, right_frames, right_values, aligned).
    """
    frames = np.asarray(frames, dtype=np.float64)
    values = np.atleast_2d(np.asarray(values, dtype=np.float64))
    slopes_in = np.atleast_2d(slopes_in)
    slopes_out = np.atleast_2d(slopes_out)
    if frames.size < 2:
        h_left = h_right = np.ones_like(frames)
    else:
        gaps = np.diff(frames)
        h_left = np.concatenate([gaps[:1], gaps])
        h_right = np.concatenate([gaps, gaps[-1:]])
    left_frames = frames - h_left / 3.0
    right_frames = frames + h_right / 3.0
    left_values = values - slopes_in * (h_left / 3.0)
    right_values = values + slopes_out * (h_right / 3.0)
    scale = np.maximum(1.0, np.maximum(np.abs(slopes_in), np.abs(slopes_out)))
    aligned = np.abs(slopes_in - slopes_out) <= 1e-9 * scale
    return left_frames, left_values, right_frames, right_values, aligned
