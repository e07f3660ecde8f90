"""A bone's or object's rotation channels, in any of Blender's rotation modes, as quaternions and back.

No bpy here: the BVH exporter, the resampler and the plain-Python tests share it.
Blender's Euler mode 'XYZ' applies X first, then Y, then Z about fixed axes,
which is the intrinsic order "ZYX" of our native rotations (the letters
reversed); angles are stored per axis (x, y, z) whatever the mode.
"""
from __future__ import annotations

import numpy as np

EULER_MODES = ('XYZ', 'XZY', 'YXZ', 'YZX', 'ZXY', 'ZYX')
_AXIS = {"X": 0, "Y": 1, "Z": 2}


def channel_property(mode: str) -> tuple[str, int]:
    """The property that holds the rotation in this mode, and its channel count."""
    if mode == 'QUATERNION':
        return "rotation_quaternion", 4
    if mode == 'AXIS_ANGLE':
        return "rotation_axis_angle", 4
    if mode in EULER_MODES:
        return "rotation_euler", 3
    raise ValueError(f"unknown rotation mode {mode!r}")


def euler_order(mode: str) -> tuple[str, list[int]]:
    """A Blender Euler mode as our intrinsic order and, per angle of that order, its axis."""
    if mode not in EULER_MODES:
        raise ValueError(f"not an Euler rotation mode: {mode!r}")
    order = mode[::-1]
    return order, [_AXIS[letter] for letter in order]


def to_quaternions(native, mode: str, block, what: str = "rotation", frames=None) -> np.ndarray:
    """Channel values (n, 3 or 4) in mode to unit w x y z quaternions (n, 4).

    A zero or non-finite quaternion raises ValueError naming `what` and the
    frame (frames[row], or the row when frames is None).
    """
    block = np.asarray(block, dtype=np.float64)
    if mode == 'QUATERNION':
        q = block
    elif mode == 'AXIS_ANGLE':
        axis = block[:, 1:]
        norm = np.linalg.norm(axis, axis=1, keepdims=True)
        # Blender treats a zero axis as the Y axis.
        axis = np.divide(axis, norm, out=np.tile([0.0, 1.0, 0.0], (len(axis), 1)), where=norm > 0)
        half = 0.5 * block[:, 0:1]
        q = np.hstack([np.cos(half), np.sin(half) * axis])
    else:
        order, axes = euler_order(mode)
        q = native.euler_to_quaternion(np.ascontiguousarray(block[:, axes]), order)
    norm = np.sqrt(np.einsum("ij,ij->i", q, q))[:, None]
    bad = np.flatnonzero(~(norm[:, 0] > 1e-12))
    if bad.size:
        where = f"row {bad[0]}" if frames is None else f"frame {frames[bad[0]]:g}"
        raise ValueError(f"{what} is zero or not finite at {where}")
    return q / norm


def from_quaternions(native, mode: str, q, previous=None) -> np.ndarray:
    """Unit quaternions to channel values in mode, continuous from row to row: q (n, 4) gives (n, size),
    q (n, k, 4), k bones in one native call, gives (n, k, size).

    previous: the channel values just before the first row, (size,) or (k, size) (the first row is
    made closest to them), or None. Euler angles are continuous as Blender's
    to_euler(order, compat) makes them; quaternions keep one hemisphere;
    axis-angle keeps its axis from flipping.
    """
    q = np.asarray(q, dtype=np.float64)
    single = q.ndim == 2
    if single:
        q = q[:, None]
    n, k = q.shape[:2]
    if previous is not None:
        previous = np.asarray(previous, dtype=np.float64).reshape(k, -1)
    if mode in EULER_MODES:
        order, axes = euler_order(mode)
        start = np.zeros(3 * k) if previous is None else np.ascontiguousarray(previous[:, axes]).ravel()
        angles = np.empty((n, k, 3))
        if n and k:
            angles = native.quaternion_to_euler(np.ascontiguousarray(q.reshape(n, 4 * k)), order, True,
                                                start).reshape(n, k, 3)
        out = np.empty((n, k, 3))
        out[..., axes] = angles
        return out[:, 0] if single else out
    reference = None
    if previous is not None:
        reference = to_quaternions(native, mode, previous)
    q = sign_continuous(q, reference)
    if mode == 'AXIS_ANGLE':
        out = _axis_angles(q, previous)
    elif mode == 'QUATERNION':
        out = q
    else:
        raise ValueError(f"unknown rotation mode {mode!r}")
    return out[:, 0] if single else out


def _axis_angles(q, previous) -> np.ndarray:
    """Axis-angle channels (n, k, 4) of sign-continuous quaternions (n, k, 4)."""
    # q and -q give angle and 2*pi - angle about opposite axes: the sign
    # continuity keeps both the angle and the axis from jumping.
    n, k = q.shape[:2]
    vector = q[..., 1:]
    sin_half = np.linalg.norm(vector, axis=2)
    angle = 2.0 * np.arctan2(sin_half, q[..., 0])
    axis = np.divide(vector, sin_half[..., None], out=np.zeros_like(vector), where=sin_half[..., None] > 1e-12)
    # Where the angle vanishes the axis is free: keep the last defined one (the previous value's before any).
    defined = sin_half > 1e-12
    if not defined.all():
        first = previous[:, 1:] if previous is not None else np.tile([0.0, 1.0, 0.0], (k, 1))
        axis = np.concatenate([first[None], axis])
        rows = np.arange(n + 1)[:, None]
        last = np.maximum.accumulate(np.where(np.concatenate([np.ones((1, k), bool), defined]), rows, 0), axis=0)
        axis = np.take_along_axis(axis, last[..., None], axis=0)[1:]
    return np.concatenate([angle[..., None], axis], axis=2)


def sign_continuous(q, previous=None) -> np.ndarray:
    """Flip rows of q (n, 4), or of each column of q (n, k, 4), so that each has a non-negative dot product
    with the one before (the first with previous, (4,) or (k, 4), when given)."""
    q = np.array(q, dtype=np.float64)
    if not len(q):
        return q
    dots = np.einsum("i...j,i...j->i...", q[1:], q[:-1])
    first = np.zeros(q.shape[1:-1], dtype=bool) if previous is None else \
        np.einsum("...j,...j->...", q[0], np.asarray(previous, dtype=np.float64).reshape(q.shape[1:])) < 0.0
    flips = np.concatenate([first[None], dots < 0.0])
    sign = np.where(np.logical_xor.accumulate(flips, axis=0), -1.0, 1.0)
    return q * sign[..., None]


def multiply(a, b) -> np.ndarray:
    """Quaternion products a b, w x y z, broadcasting over leading axes."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    w1, x1, y1, z1 = np.moveaxis(a, -1, 0)
    w2, x2, y2, z2 = np.moveaxis(b, -1, 0)
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], axis=-1)


def conjugate(q) -> np.ndarray:
    return np.asarray(q, dtype=np.float64) * np.array([1.0, -1.0, -1.0, -1.0])


def rotate(q, points) -> np.ndarray:
    """Points (..., 3) turned by the unit quaternion q (4,)."""
    w, v = q[0], np.asarray(q[1:], dtype=np.float64)
    t = 2.0 * np.cross(v, points)
    return points + w * t + np.cross(v, t)


def about(axis: int, angles) -> np.ndarray:
    """Quaternions (..., 4) turning by angles (...) about the X, Y or Z axis (axis 0, 1 or 2)."""
    half = 0.5 * np.asarray(angles, dtype=np.float64)
    out = np.zeros(half.shape + (4,))
    out[..., 0], out[..., 1 + axis] = np.cos(half), np.sin(half)
    return out


def rotate_each(q, v) -> np.ndarray:
    """Vectors v (..., 3) turned by unit quaternions q (..., 4), one by one, broadcasting."""
    q, v = np.asarray(q, dtype=np.float64), np.asarray(v, dtype=np.float64)
    w, u = q[..., :1], q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def y_axes(q) -> np.ndarray:
    """The Y axes (..., 3) of unit quaternions (..., 4): where Blender bones point."""
    w, x, y, z = np.moveaxis(np.asarray(q, dtype=np.float64), -1, 0)
    return np.stack([2 * (x * y - w * z), 1 - 2 * (x * x + z * z), 2 * (y * z + w * x)], axis=-1)


def twist_angles(q, axis) -> np.ndarray:
    """The turn (...) of rotations q (..., 4) about a unit axis (3,): the twist of a swing-twist split,
    in (-pi, pi]."""
    q = np.asarray(q, dtype=np.float64)
    along = q[..., 1:] @ np.asarray(axis, dtype=np.float64)
    angle = 2.0 * np.arctan2(along, q[..., 0])
    return (angle + np.pi) % (2 * np.pi) - np.pi


def between(a, b) -> np.ndarray:
    """The shortest rotation (w x y z) that turns direction a (3,) onto direction b (3,)."""
    a = np.asarray(a, dtype=np.float64) / np.linalg.norm(a)
    b = np.asarray(b, dtype=np.float64) / np.linalg.norm(b)
    w = 1.0 + float(a @ b)
    if w < 1e-12:  # opposite: half a turn about any axis across a
        axis = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        return np.concatenate([[0.0], axis / np.linalg.norm(axis)])
    q = np.concatenate([[w], np.cross(a, b)])
    return q / np.linalg.norm(q)


def ik_swing_twist(q) -> np.ndarray:
    """The IK's joint-limit coordinates (swing x, twist, swing z) of basis rotations q (n, 4): the native
    IkSwingTwist (native/src/ik/limits.cpp) step for step, so that limits set from these coordinates are the
    bounds the solver clamps. q = swing * twist, twist about Y in [-pi, pi] (its w made non-negative), swing
    the rotation vector (x, 0, z); a half-turn swing has no twist: 0."""
    q = np.asarray(q, dtype=np.float64)
    tw, ty = q[:, 0].copy(), q[:, 2].copy()
    n = np.hypot(tw, ty)
    some = n > 1e-12
    tw = np.where(some, tw / np.where(some, n, 1.0), 1.0)
    ty = np.where(some, ty / np.where(some, n, 1.0), 0.0)
    flip = np.where(tw < 0, -1.0, 1.0)
    tw, ty = tw * flip, ty * flip
    zero = np.zeros_like(tw)
    swing = multiply(q, np.stack([tw, zero, -ty, zero], axis=1))
    # RotationVector (native/src/so3.hpp): w made non-negative, angle in [0, pi].
    swing *= np.where(swing[:, :1] < 0, -1.0, 1.0)
    w, v = swing[:, 0], swing[:, 1:]
    s = np.linalg.norm(v, axis=1)
    scale = np.where(s < 1e-9, 2.0 / np.maximum(w, 1e-300), 2.0 * np.arctan2(s, w) / np.where(s < 1e-9, 1.0, s))
    return np.stack([v[:, 0] * scale, 2.0 * np.arctan2(ty, tw), v[:, 2] * scale], axis=1)
