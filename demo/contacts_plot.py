"""out/contacts.png: one foot's height and horizontal speed, before and after foot planting.

The retargeted character's left ankle (its foot bone's head) over the clip,
from the plain retarget and from the one with planted feet, with the contacts
detected on the source shaded: during a contact the planted foot's speed is
zero and its height constant, where the plain retarget's foot slides.
"""
from __future__ import annotations

import numpy as np


def _shade(ax, frames, on):
    edges = np.flatnonzero(np.diff(np.concatenate([[0], on.astype(int), [0]])))
    for start, end in zip(edges[::2], edges[1::2]):
        ax.axvspan(frames[start] - 0.5, frames[end - 1] + 0.5, color="#9ecae1", alpha=0.45, lw=0)


def plot(path, frames, fps, contacts, plain, planted, title):
    """frames (F,); contacts (F,) bool; plain and planted (F, 3) world positions of the same foot point."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(10, 6), sharex=True, constrained_layout=True)
    for ax in (top, bottom):
        _shade(ax, frames, contacts)
    for points, label, style in ((plain, "plain retarget", dict(color="#d95f02", lw=1.2)),
                                 (planted, "feet planted", dict(color="#1b9e77", lw=2.0))):
        top.plot(frames, 100 * points[:, 2], label=label, **style)
        speed = np.linalg.norm(np.diff(points[:, :2], axis=0), axis=1) * fps
        bottom.plot(frames[1:], 100 * speed, label=label, **style)
    top.set_ylabel("ankle height (cm)")
    bottom.set_ylabel("horizontal speed (cm/s)")
    bottom.set_xlabel("frame")
    top.set_title(title + "  (shaded: contacts detected on the source)")
    top.legend(loc="upper right")
    fig.savefig(path, dpi=110)
    plt.close(fig)
