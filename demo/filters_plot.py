"""out/filters.png: a noisy capture's rotation before and after MotionKit's Butterworth filter on the sphere.

No bpy here: demo.py hands over one bone's quaternions (w x y z, a row per frame) as captured, with noise
added, and filtered; this draws one of its Euler angles and its angular speed with matplotlib.
"""
from __future__ import annotations

import numpy as np


def multiply(a, b):
    """Row-wise quaternion products a b (w x y z)."""
    w1, v1, w2, v2 = a[:, :1], a[:, 1:], b[:, :1], b[:, 1:]
    return np.hstack([w1 * w2 - np.sum(v1 * v2, axis=1, keepdims=True),
                      w1 * v2 + w2 * v1 + np.cross(v1, v2)])


def noise(rng, count: int, degrees: float):
    """count unit quaternions of random rotations, their angles' RMS about degrees."""
    vectors = rng.normal(0.0, np.radians(degrees) / np.sqrt(3.0), (count, 3))
    angles = np.linalg.norm(vectors, axis=1, keepdims=True)
    return np.hstack([np.cos(angles / 2), np.sin(angles / 2) * vectors / np.maximum(angles, 1e-12)])


def angles_between(a, b):
    """Degrees between rotations (w x y z rows), from the relative rotation's vector part, which keeps the
    small angles that arccos of a dot product near 1 rounds away."""
    conjugate = a * np.array([1.0, -1.0, -1.0, -1.0])
    relative = multiply(conjugate, b)
    return np.degrees(2.0 * np.arctan2(np.linalg.norm(relative[:, 1:], axis=1), np.abs(relative[:, 0])))


def angular_speed(q, fps: float):
    """Degrees a second between consecutive frames."""
    return angles_between(q[:-1], q[1:]) * fps


def euler_x(q):
    """The X angle (degrees) of an XYZ Euler decomposition: a knee's bend."""
    w, x, y, z = q.T
    return np.degrees(np.arctan2(2.0 * (w * x - y * z), 1.0 - 2.0 * (x * x + y * y)))


def rms(values) -> float:
    return float(np.sqrt(np.mean(np.square(values))))


def plot(path, frames, fps, captured, noisy, filtered, title):
    """frames (F,); captured, noisy, filtered (F, 4): one bone's local rotation, w x y z."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(10, 6.5), sharex=True, constrained_layout=True)
    lines = ((noisy, f"captured + noise (error {rms(angles_between(noisy, captured)):.2f}° RMS)",
              dict(color="#d95f02", lw=0.9, alpha=0.85)),
             (captured, "captured", dict(color="black", lw=1.0, ls="--")),
             (filtered, f"filtered on the sphere (error {rms(angles_between(filtered, captured)):.2f}° RMS)",
              dict(color="#1b9e77", lw=2.0)))
    for q, label, style in lines:
        top.plot(frames, euler_x(q), label=label, **style)
        bottom.plot(frames[1:], angular_speed(q, fps), label=label, **style)
    top.set_ylabel("rotation: X Euler angle (°)")
    bottom.set_ylabel("angular speed (°/s)")
    bottom.set_xlabel(f"frame ({fps:.4g} fps)")
    top.set_title(title)
    low, high = top.get_ylim()
    top.set_ylim(low, high + 0.22 * (high - low))  # room for the legend above the curves
    top.legend(loc="upper center", ncol=3, fontsize=9, frameon=False)
    fig.savefig(path, dpi=110)
    plt.close(fig)
