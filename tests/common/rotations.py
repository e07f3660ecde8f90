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
