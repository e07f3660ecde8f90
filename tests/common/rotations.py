"""Comparing rotations in tests by the angle between them, in radians.

|q1 . q2| close to 1 says little: 1 - cos(theta / 2) is about theta^2 / 8, so
a tolerance of 1e-5 on it (numpy's default rtol) lets through half a degree.
The angle itself is what an "exact" test should bound."""
import numpy as np


def quaternion_angles(a, b) -> np.ndarray:
    """The angles (radians) of the rotations between quaternions a and b (..., 4), any order of
    components as long as both share it; q and -q are the same rotation. Accurate near 0 (no arccos)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    b = b * np.where(np.sum(a * b, axis=-1, keepdims=True) < 0, -1.0, 1.0)
    return 4.0 * np.arctan2(np.linalg.norm(a - b, axis=-1), np.linalg.norm(a + b, axis=-1))


def matrix_angles(a, b) -> np.ndarray:
    """The angles (radians) of R_a^T R_b between the rotations of matrices a and b (..., 3+, 3+; a 4x4's
    upper 3x3 is taken): the whole rotation, a turn about a bone's own axis (its roll) included. Each
    matrix's columns are first made unit (a scaled bone's scale is no turn). atan2 of the skew part against
    the trace: accurate near 0, where arccos of the trace loses half the digits."""
    ra = np.asarray(a, dtype=np.float64)[..., :3, :3]
    rb = np.asarray(b, dtype=np.float64)[..., :3, :3]
    ra = ra / np.linalg.norm(ra, axis=-2, keepdims=True)
    rb = rb / np.linalg.norm(rb, axis=-2, keepdims=True)
    r = np.swapaxes(ra, -1, -2) @ rb
    skew = np.stack([r[..., 2, 1] - r[..., 1, 2], r[..., 0, 2] - r[..., 2, 0], r[..., 1, 0] - r[..., 0, 1]], axis=-1)
    return np.arctan2(np.linalg.norm(skew, axis=-1) / 2, (np.trace(r, axis1=-2, axis2=-1) - 1) / 2)
