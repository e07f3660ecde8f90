"""The demo's plot: MotionKit's interpolants compared on the same motion-capture keys.

No bpy here: demo.py hands over plain arrays (and what Blender itself
evaluates for the resampled curve), this draws them with matplotlib.
"""
from __future__ import annotations

import numpy as np

SCALAR_CURVES = (("linear", "Linear", {}), ("natural", "Natural spline", {}),
                 ("catmull-rom", "Catmull-Rom", {}), ("centripetal", "Centripetal Catmull-Rom", {}),
                 ("kochanek-bartels", "Kochanek-Bartels T=0.5", {"tension": 0.5}),
                 ("monotone", "Monotone cubic", {}))
ROTATION_CURVES = (("slerp", "Slerp"), ("squad", "Squad"), ("catmull-rom", "Sphere Catmull-Rom"),
                   ("kochanek-bartels", "Sphere Kochanek-Bartels T=0.5"),
                   ("euler-catmull-rom", "Euler-channel Catmull-Rom"),
                   ("axis-angle-catmull-rom", "Axis-angle Catmull-Rom"))


def _with_tcb(kwargs, count):
    return {name: np.full(count, value) for name, value in kwargs.items()}


def plot(native, path, scalar, rotation, resampled, stride=6):
    """scalar: (frames, values, label); rotation: (frames, quaternions (n, 4), label);
    resampled: dict with old/new/curve times (seconds) and values and a label."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(15, 9.5), dpi=110)
    frames, values, label = scalar
    keys_t, keys_v = np.ascontiguousarray(frames[::stride]), np.ascontiguousarray(values[::stride])
    dense = np.linspace(keys_t[0], keys_t[-1], 2000)
    ax = axes[0, 0]
    ax.plot(frames, values, ".", color="0.75", markersize=3, label="all 60 fps samples")
    for kind, name, kwargs in SCALAR_CURVES:
        curve = native.interpolate(keys_t, keys_v, dense, kind=kind, **_with_tcb(kwargs, keys_t.size))
        ax.plot(dense, curve, linewidth=1.2, label=name)
    ax.plot(keys_t, keys_v, "ko", markersize=4, label=f"keys (every {stride}th frame)")
    ax.set(title=f"Scalar interpolants through the same keys: {label}", xlabel="frame")
    ax.legend(fontsize=7, ncol=2)

    ax = axes[0, 1]
    runge_t = np.linspace(frames[0], frames[-1], 12).round()
    runge_v = np.interp(runge_t, frames, values)
    dense = np.linspace(runge_t[0], runge_t[-1], 2000)
    ax.plot(frames, values, ".", color="0.75", markersize=3, label="all samples")
    ax.plot(dense, native.interpolate(runge_t, runge_v, dense, kind="polynomial"), "C3",
            label="polynomial of degree 11")
    ax.plot(dense, native.interpolate(runge_t, runge_v, dense, kind="natural"), "C1", label="natural spline")
    ax.plot(runge_t, runge_v, "ko", markersize=4, label="12 keys")
    span = values.max() - values.min()
    ax.set_ylim(values.min() - 0.6 * span, values.max() + 0.6 * span)
    ax.set(title="One polynomial through 12 keys: Runge's phenomenon at the ends", xlabel="frame")
    ax.legend(fontsize=7)

    frames_r, quats, label_r = rotation
    keys_t, keys_q = np.ascontiguousarray(frames_r[::stride]), np.ascontiguousarray(quats[::stride])
    dense = np.linspace(keys_t[0], keys_t[-1], 3000)
    ax = axes[1, 0]
    dots = np.abs(np.einsum("ij,ij->i", quats[1:], quats[:-1]))
    speed = np.degrees(2 * np.arccos(np.clip(dots, 0, 1))) / np.diff(frames_r)
    ax.plot(0.5 * (frames_r[1:] + frames_r[:-1]), speed, ".", color="0.75", markersize=3,
            label="60 fps samples (finite differences)")
    for kind, name in ROTATION_CURVES:
        kwargs = {"tension": np.full(keys_t.size, 0.5)} if kind == "kochanek-bartels" else {}
        _, omega = native.interpolate_rotations(keys_t, keys_q, dense, kind=kind, angular_velocity=True, **kwargs)
        ax.plot(dense, np.degrees(np.linalg.norm(omega, axis=1)), linewidth=1.1, label=name)
    for t in keys_t:
        ax.axvline(t, color="0.9", linewidth=0.6, zorder=0)
    ax.set(title=f"Angular speed between rotation keys: {label_r} (keys every {stride}th frame)",
           xlabel="frame", ylabel="degrees per frame")
    ax.legend(fontsize=7, ncol=2)

    ax = axes[1, 1]
    r = resampled
    ax.plot(r["old_times"], r["old_values"], ".", color="0.6", markersize=4, label="60 fps keys")
    ax.plot(r["curve_times"], r["curve_values"], "C0", linewidth=1.2,
            label="after: Blender's fcurve.evaluate of the written curve")
    ax.plot(r["new_times"], r["new_values"], "C3o", markersize=5, label="24 fps keys (Bezier, exact handles)")
    ax.set(title=f"Resampled 60 \u2192 24 fps: {r['label']}", xlabel="seconds")
    ax.legend(fontsize=7)

    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
