"""What an animator looks for in a retargeted clip, as numbers a batch can sort by: how far the feet slide
while the source stands on them, how far they stand off the floor then, how far a mapped bone points from
where the source's points, and how much harder than the source's a bone's rotation jumps between frames.

Everything here is measured on arrays of the result (world space, metres) that the caller reads from the
target, however it reads them (posed from the written keys, or by Blender's evaluation in a test). No bpy.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

MM = 1000.0  # metres to millimetres


@dataclass
class FeetMotion:
    """The target's foot points (frames, points, 3) world, the same points in its rest pose (points, 3),
    where the rest pose stands on the floor, and on which frames the source stands on each (frames, points);
    feet: the points of each foot (an ankle and a ball), each point a foot of its own when None."""
    points: np.ndarray
    rest: np.ndarray
    stance: np.ndarray
    up: np.ndarray
    feet: tuple | None = None


@dataclass
class BoneMotion:
    """Mapped pairs' world directions (frames, pairs, 3), unit, the source's turned as the retarget placed
    it, and world rotations (frames, pairs, 4) w-first quaternions, for each side; the target's bone names."""
    source_directions: np.ndarray
    target_directions: np.ndarray
    source_rotations: np.ndarray
    target_rotations: np.ndarray
    names: list


@dataclass
class Quality:
    """One clip's figures; None where the clip has nothing to measure (no stance frames, no mapped bone)."""
    sliding_median_mm: float | None = None
    sliding_worst_mm: float | None = None
    floor_above_mm: float | None = None
    floor_below_mm: float | None = None
    direction_worst_deg: float | None = None
    direction_worst_bone: str = ""
    pop_worst_deg: float | None = None
    pop_bone: str = ""
    pop_frame: int | None = None

    def as_dict(self) -> dict:
        return asdict(self)


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) frame indices of each run of True."""
    padded = np.concatenate(([False], mask, [False])).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    return [(int(a), int(b) - 1) for a, b in zip(edges[::2], edges[1::2])]


def foot_sliding_mm(feet: FeetMotion) -> list[float]:
    """Per stance (a run of frames on which the source stands on a point): the farthest the target's point
    moves along the floor from where it was on the stance's first frame."""
    up = feet.up / np.linalg.norm(feet.up)
    along_floor = feet.points - np.einsum("fpk,k->fp", feet.points, up)[..., None] * up
    drifts = []
    for point in range(feet.points.shape[1]):
        for first, last in _runs(feet.stance[:, point]):
            moved = along_floor[first:last + 1, point] - along_floor[first, point]
            drifts.append(float(np.linalg.norm(moved, axis=1).max()) * MM)
    return drifts


def floor_offsets_mm(feet: FeetMotion) -> np.ndarray:
    """On each frame a foot stands on (any of its points in stance), how far the lowest of its standing
    points is above (+) or below (-) where that point is when the rig stands on the floor in its rest pose:
    a heel lifted while the ball stands is no hover, a whole foot in the air is."""
    up = feet.up / np.linalg.norm(feet.up)
    heights = np.einsum("fpk,k->fp", feet.points, up) - feet.rest @ up
    groups = feet.feet or tuple((p,) for p in range(heights.shape[1]))
    offsets = []
    for group in groups:
        standing = np.where(feet.stance[:, group], heights[:, group], np.inf).min(axis=1)
        offsets.append(standing[np.isfinite(standing)])
    return np.concatenate(offsets) * MM


def _angles_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angles between unit vectors along the last axis, robust near 0 and 180 degrees."""
    cross = np.linalg.norm(np.cross(a, b), axis=-1)
    return np.degrees(np.arctan2(cross, np.einsum("...k,...k->...", a, b)))


def _rotation_steps_deg(q: np.ndarray) -> np.ndarray:
    """(frames - 1, pairs) angle each rotation turns by from one frame to the next."""
    dots = np.abs(np.einsum("fpk,fpk->fp", q[1:], q[:-1]))
    return np.degrees(2.0 * np.arccos(np.clip(dots, 0.0, 1.0)))


def best_turn_about(up: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The turn about the unit axis up (w x y z) that best lays directions a (..., 3) onto b (..., 3): the
    retarget may face the target another way than the source, which is no error of any bone."""
    a_flat = a.reshape(-1, 3) - np.outer(a.reshape(-1, 3) @ up, up)
    b_flat = b.reshape(-1, 3) - np.outer(b.reshape(-1, 3) @ up, up)
    angle = np.arctan2(np.einsum("nk,nk->n", np.cross(a_flat, b_flat), np.broadcast_to(up, a_flat.shape)).sum(),
                       np.einsum("nk,nk->n", a_flat, b_flat).sum())
    return np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * up])


def measure(feet: FeetMotion | None, bones: BoneMotion | None) -> Quality:
    quality = Quality()
    if feet is not None and feet.stance.any():
        drifts = foot_sliding_mm(feet)
        offsets = floor_offsets_mm(feet)
        quality.sliding_median_mm = float(np.median(drifts))
        quality.sliding_worst_mm = float(max(drifts))
        quality.floor_above_mm = float(max(offsets.max(), 0.0))
        quality.floor_below_mm = float(max(-offsets.min(), 0.0))
    if bones is not None and bones.target_directions.shape[1]:
        errors = _angles_deg(bones.source_directions, bones.target_directions)
        worst = np.unravel_index(int(np.argmax(errors)), errors.shape)
        quality.direction_worst_deg = float(errors[worst])
        quality.direction_worst_bone = bones.names[worst[1]]
        if bones.target_rotations.shape[0] > 1:
            beyond = _rotation_steps_deg(bones.target_rotations) - _rotation_steps_deg(bones.source_rotations)
            frame, pair = np.unravel_index(int(np.argmax(beyond)), beyond.shape)
            quality.pop_worst_deg = float(max(beyond[frame, pair], 0.0))
            quality.pop_bone = bones.names[pair]
            quality.pop_frame = int(frame) + 1
    return quality
