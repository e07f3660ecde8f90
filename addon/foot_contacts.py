"""Foot contacts: detection, plant positions and blend weights (pure numpy, no Blender).

A contact is a foot point (ankle or ball) that is both low and slow for a
while (Kovar, Schreiner, Gleicher 2002). Everything here works on world
positions with Z up, in any unit: thresholds are relative to the leg length
(thigh + shin) and speeds are per second, so the same settings hold for a clip
in metres at 60 fps and one in centimetres at 30 fps.

Arrays: points (frames, P, 3), contacts (frames, P) bool. Intervals are
half-open frame index ranges [start, end).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class ContactSettings:
    """Thresholds relative to the leg length L, times in seconds.

    A point enters a contact where it is within `height_enter * L` of its own
    standing height and slower than `speed_enter * L` per second; it stays in
    while within `height_leave * L` and slower than `speed_leave * L` per
    second (the looser pair: hysteresis). Contacts shorter than `min_length`
    are dropped, gaps shorter than `min_gap` closed. `blend` is how long the
    IK targets take to ramp in and out around a contact.
    """
    height_enter: float = 0.06
    height_leave: float = 0.09
    speed_enter: float = 0.45
    speed_leave: float = 0.7
    min_length: float = 0.05      # s
    min_gap: float = 0.03         # s
    smoothing: float = 0.03       # s: box filter on the speed, so capture jitter does not flicker
    ground_percentile: float = 5.0  # a point's standing height: this low percentile of its heights
    max_ground: float = 0.3       # L: a point whose standing height is higher above the floor never lands
    blend: float = 0.1            # s

    def blend_frames(self, fps: float) -> int:
        return max(1, int(round(self.blend * fps)))

    def validate(self) -> None:
        for name in ("height_enter", "height_leave", "speed_enter", "speed_leave", "blend", "max_ground"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"ContactSettings.{name} must be positive, not {value}")
        for name in ("min_length", "min_gap", "smoothing"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise ValueError(f"ContactSettings.{name} must not be negative, not {value}")
        if self.height_leave < self.height_enter or self.speed_leave < self.speed_enter:
            raise ValueError("ContactSettings: the leave thresholds must be at least the enter ones")
        if not 0 <= self.ground_percentile <= 50:
            raise ValueError("ContactSettings.ground_percentile must be in [0, 50]")


def _check_points(points) -> np.ndarray:
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 3 or points.shape[2] != 3:
        raise ValueError(f"points must have shape (frames, P, 3), not {points.shape}")
    if not np.all(np.isfinite(points)):
        frame, point = np.argwhere(~np.isfinite(points).all(axis=2))[0]
        raise ValueError(f"point {point} is not finite at frame index {frame}")
    return points


def estimate_floor(points, percentile: float = 2.0) -> float:
    """The floor's height: the lowest point's low percentile (robust to a few stray low frames)."""
    points = _check_points(points)
    return float(np.min(np.percentile(points[..., 2], percentile, axis=0)))


def speeds(points, fps: float, smoothing: float = 0.0) -> np.ndarray:
    """(frames, P) speed per second (central differences), box-filtered over `smoothing` seconds."""
    points = _check_points(points)
    if points.shape[0] < 2:
        return np.zeros(points.shape[:2])
    velocity = np.gradient(points, 1.0 / fps, axis=0)
    speed = np.linalg.norm(velocity, axis=2)
    half = int(round(smoothing * fps / 2))
    if half > 0 and speed.shape[0] > 1:
        padded = np.pad(speed, ((half, half), (0, 0)), mode="edge")
        kernel = np.ones(2 * half + 1) / (2 * half + 1)
        speed = np.apply_along_axis(lambda s: np.convolve(s, kernel, mode="valid"), 0, padded)
    return speed


def _hysteresis(enter: np.ndarray, stay: np.ndarray) -> np.ndarray:
    """On from an `enter` frame until the first frame that is not `stay`; vectorised forward fill."""
    frames = enter.shape[0]
    decided = enter | ~stay  # frames whose state does not depend on the one before
    index = np.where(decided, np.arange(frames)[:, None], -1)
    last = np.maximum.accumulate(index, axis=0)
    state = np.take_along_axis(enter, np.maximum(last, 0), axis=0)
    return state & (last >= 0)


def intervals(contacts_1d) -> list[tuple[int, int]]:
    """Half-open [start, end) runs of True in a (frames,) bool array."""
    c = np.asarray(contacts_1d, dtype=bool).astype(np.int8)
    edges = np.diff(np.concatenate([[0], c, [0]]))
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist()))


def all_intervals(contacts) -> list[list[tuple[int, int]]]:
    """Per point, its contact intervals."""
    contacts = np.asarray(contacts, dtype=bool)
    return [intervals(contacts[:, p]) for p in range(contacts.shape[1])]


def _filter_runs(contacts: np.ndarray, min_frames: int, min_gap_frames: int) -> np.ndarray:
    out = contacts.copy()
    for p in range(out.shape[1]):
        if min_gap_frames > 0:
            runs = intervals(out[:, p])
            for (_, end), (start, _) in zip(runs[:-1], runs[1:]):
                if start - end <= min_gap_frames:
                    out[end:start, p] = True
        for start, end in intervals(out[:, p]):
            if end - start < min_frames:
                out[start:end, p] = False
    return out


def detect(points, fps: float, leg_length: float, floor: float | None = 0.0,
           settings: ContactSettings | None = None) -> np.ndarray:
    """Contacts (frames, P) bool of points (frames, P, 3), Z up, sampled at fps.

    floor: the floor's height; None estimates it (estimate_floor). Each point's
    standing height is its own low percentile, not the floor itself: an ankle
    stands a few centimetres above the floor when planted. A point whose
    standing height is more than `max_ground` leg lengths above the floor never
    lands (a foot held up through the clip).
    """
    settings = settings or ContactSettings()
    settings.validate()
    points = _check_points(points)
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be positive, not {fps}")
    if not (np.isfinite(leg_length) and leg_length > 0):
        raise ValueError(f"leg_length must be positive, not {leg_length}")
    frames, count = points.shape[:2]
    if frames == 0:
        return np.zeros((0, count), dtype=bool)
    if floor is None:
        floor = estimate_floor(points)
    height = points[..., 2]
    ground = np.percentile(height, settings.ground_percentile, axis=0)
    ground = np.maximum(ground, floor)  # nothing stands below the floor
    lands = ground - floor <= settings.max_ground * leg_length
    above = (height - ground) / leg_length
    speed = speeds(points, fps, settings.smoothing) / leg_length
    enter = (above <= settings.height_enter) & (speed <= settings.speed_enter) & lands
    stay = (above <= settings.height_leave) & (speed <= settings.speed_leave) & lands
    contacts = _hysteresis(enter, stay)
    min_frames = int(np.ceil(settings.min_length * fps - 1e-9))
    min_gap = int(np.floor(settings.min_gap * fps + 1e-9))
    return _filter_runs(contacts, min_frames, min_gap)


def plant_positions(points, contacts, rigid_pairs=()) -> list[list[np.ndarray]]:
    """Per point and contact interval (in the order of all_intervals) one plant position: the mean of the
    point over the contact (its height as it stood).

    rigid_pairs: (a, b) point pairs a fixed distance apart (an ankle and the
    ball of the same foot). Where a contact of b overlaps one of a, b's plant
    is moved along the line from a's plant to the distance the two keep in
    the clip, so that both can be held at once by a rigid foot.
    """
    points = _check_points(points)
    contacts = np.asarray(contacts, dtype=bool)
    if contacts.shape != points.shape[:2]:
        raise ValueError(f"contacts must have shape {points.shape[:2]}, not {contacts.shape}")
    runs = [np.array(r, dtype=np.int64).reshape(-1, 2) for r in all_intervals(contacts)]
    # Means over [start, end) from running sums: one pass per point, however many contacts.
    sums = np.concatenate([np.zeros((1,) + points.shape[1:]), np.cumsum(points, axis=0)])
    plants = [list((sums[r[:, 1], p] - sums[r[:, 0], p]) / (r[:, 1] - r[:, 0])[:, None])
              for p, r in enumerate(runs)]
    for a, b in rigid_pairs:
        if not (len(runs[a]) and len(runs[b])):
            continue
        distance = float(np.median(np.linalg.norm(points[:, b] - points[:, a], axis=1)))
        # Frames each b contact shares with each a contact; the a contact sharing the most (the first of equals).
        shared = (np.minimum(runs[b][:, None, 1], runs[a][None, :, 1])
                  - np.maximum(runs[b][:, None, 0], runs[a][None, :, 0]))
        for j, i in enumerate(np.argmax(shared, axis=1)):
            if shared[j, i] <= 0:
                continue
            offset = plants[b][j] - plants[a][i]
            norm = np.linalg.norm(offset)
            if norm > 0:
                plants[b][j] = plants[a][i] + offset * (distance / norm)
    return plants


def smoothstep(x) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _distance_to_contact(contacts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per frame and point, the distance in frames to the nearest contact frame, and that frame's index
    (frames, P); distance inf and index -1 where the point has no contact at all."""
    frames = contacts.shape[0]
    idx = np.arange(frames)[:, None]
    before = np.maximum.accumulate(np.where(contacts, idx, -1), axis=0)
    after = np.where(contacts, idx, frames)[::-1]
    after = np.minimum.accumulate(after, axis=0)[::-1]
    d_before = np.where(before >= 0, idx - before, np.inf)
    d_after = np.where(after < frames, after - idx, np.inf)
    nearest = np.where(d_before <= d_after, before, after)
    distance = np.minimum(d_before, d_after)
    nearest = np.where(np.isfinite(distance), nearest, -1)
    return distance, nearest


def blend_weights(contacts, blend_frames: int) -> np.ndarray:
    """(frames, P) weights: 1 in contacts, a smoothstep ramp over blend_frames frames on either side, 0
    elsewhere; between two close contacts, the nearer one's ramp."""
    distance, _ = _distance_to_contact(np.asarray(contacts, dtype=bool))
    return _ramp(distance, blend_frames)


def _ramp(distance, blend_frames: int) -> np.ndarray:
    if blend_frames < 0:
        raise ValueError("blend_frames must not be negative")
    return smoothstep(1.0 - distance / (blend_frames + 1))


def plant_targets(points, contacts, blend_frames: int, rigid_pairs=()) -> tuple[np.ndarray, np.ndarray]:
    """Per frame the plant of the nearest contact (frames, P, 3) (the point itself where it has none)
    and the blend weights (frames, P)."""
    points = _check_points(points)
    contacts = np.asarray(contacts, dtype=bool)
    plants = plant_positions(points, contacts, rigid_pairs)
    distance, nearest = _distance_to_contact(contacts)
    targets = points.copy()
    for p, runs in enumerate(all_intervals(contacts)):
        if not runs:
            continue
        # Which interval each frame's nearest contact frame belongs to.
        starts = np.array([s for s, _ in runs])
        which = np.searchsorted(starts, nearest[:, p], side="right") - 1
        targets[:, p] = np.asarray(plants[p])[which]
    return targets, _ramp(distance, blend_frames)


def foot_targets(points, targets, weights, feet=((0, 1), (2, 3))) -> np.ndarray:
    """IK targets (frames, P, 3) that blend each point to its plant by its weight and carry a point that
    is not (fully) planted along with its foot's other point:
    target_p = point_p + w_p (plant_p - point_p) + (1 - w_p) w_q (plant_q - point_q).
    Then each foot's two targets are put the distance apart that its two points keep on that frame, the
    correction shared in proportion to 1 - w (a planted point does not move), so that a rigid foot can
    meet both: otherwise, while one point ramps out and the other holds, the targets would ask the foot
    to stretch and the solver would miss both. With every weight 0 the targets are the points themselves."""
    points = np.asarray(points, dtype=np.float64)
    weights = np.asarray(weights, dtype=np.float64)
    offsets = weights[..., None] * (np.asarray(targets) - points)
    out = points + offsets
    for a, b in feet:
        out[:, a] += (1.0 - weights[:, a, None]) * offsets[:, b]
        out[:, b] += (1.0 - weights[:, b, None]) * offsets[:, a]
        distance = np.linalg.norm(points[:, b] - points[:, a], axis=1)
        span = out[:, b] - out[:, a]
        length = np.linalg.norm(span, axis=1)
        unit = np.divide(span, length[:, None], out=np.zeros_like(span), where=length[:, None] > 0)
        free_a, free_b = 1.0 - weights[:, a], 1.0 - weights[:, b]
        total = free_a + free_b
        share_a = np.divide(free_a, total, out=np.full_like(total, 0.5), where=total > 0)
        excess = (length - distance)[:, None] * unit  # b is this much too far from a
        out[:, a] += share_a[:, None] * excess
        out[:, b] -= (1.0 - share_a)[:, None] * excess
    return out
