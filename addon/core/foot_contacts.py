"""Foot contacts: detection (pure numpy) and the cleanup's targets (the native core); no Blender.

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
    are dropped, gaps shorter than `min_gap` closed. A contact whose point
    wanders farther than `max_drift * L` across the floor from where it
    stands on average is no plant but a slide or a pivot (a catwalk's turn on
    the ball of the foot): dropped, the foot left to follow the motion.
    Where a foot's two points stand together and one wanders more than
    `max_pivot * L` while the other moves less than half as far, the foot
    turns about the still one (a kick's standing foot pivoting on its ball):
    the wandering point's contact is dropped, so the foot turns as the motion
    turns it about a held point. A contact through which the foot turns
    across the floor by more than `max_turn` degrees (a kick's standing foot
    swivelling) is no plant either: holding its points would hold the foot
    turned away from the motion's. `blend` is how long the IK targets take to
    ramp in and out around a contact.
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
    max_drift: float = 0.06       # L: captures' planted feet wander up to 0.049 (walk_and_turn_left's turn)
    max_pivot: float = 0.03       # L: a point wandering about its still partner turns the foot (captures: less)
    max_turn: float = 25.0        # degrees: captures' planted feet turn up to 19.8 (walk_and_turn_left's turn)
    blend: float = 0.1            # s

    def blend_frames(self, fps: float) -> int:
        return max(1, int(round(self.blend * fps)))

    def validate(self) -> None:
        for name in ("height_enter", "height_leave", "speed_enter", "speed_leave", "blend", "max_ground",
                     "max_drift", "max_pivot", "max_turn"):
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
    lands (a foot held up through the clip). Which of them a cleanup holds
    still: plantable().
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


def plantable(points, contacts, leg_length: float, settings: ContactSettings | None = None, feet=()) -> np.ndarray:
    """The contacts (frames, P) of points (frames, P, 3) a cleanup holds still: all but slides and pivots
    (ContactSettings: max_drift, max_pivot, max_turn), which stand on the floor all the same (their feet are
    put on it) but move as the motion moves them. feet: pairs of point indices of one foot (ankle, ball)."""
    settings = settings or ContactSettings()
    points, contacts = _check_points(points), np.asarray(contacts, dtype=bool)
    contacts = _drop_slides(points, contacts, settings.max_drift * leg_length)
    contacts = _drop_pivots(points, contacts, feet, settings.max_pivot * leg_length)
    return _drop_turns(points, contacts, feet, np.radians(settings.max_turn))


def _drop_turns(points: np.ndarray, contacts: np.ndarray, feet, turn: float) -> np.ndarray:
    """contacts without those through which their foot's line across the floor (its first point to its
    second) turns farther than turn (radians) from its mean direction."""
    out = contacts.copy()
    for a, b in feet:
        line = points[:, b, :2] - points[:, a, :2]
        for p in (a, b):
            for start, end in intervals(contacts[:, p]):
                unit = line[start:end] / np.maximum(np.linalg.norm(line[start:end], axis=1, keepdims=True), 1e-300)
                mean = unit.mean(axis=0)
                mean /= max(np.linalg.norm(mean), 1e-300)
                if np.arccos(np.clip(unit @ mean, -1.0, 1.0)).max() > turn:
                    out[start:end, p] = False
    return out


def _wander(points: np.ndarray) -> float:
    """How far points (frames, 3) stray across the floor (x, y) from their mean."""
    across = points[:, :2]
    return float(np.linalg.norm(across - across.mean(axis=0), axis=1).max()) if len(points) else 0.0


def _drop_pivots(points: np.ndarray, contacts: np.ndarray, feet, pivot: float) -> np.ndarray:
    """contacts without those of a foot point that wanders farther than pivot about its partner while the
    partner stands with it and moves less than half as far (the foot turning about the partner)."""
    out = contacts.copy()
    for pair in feet:
        for p, q in (pair, pair[::-1]):
            for start, end in intervals(contacts[:, p]):
                both = np.flatnonzero(contacts[start:end, q]) + start
                if not len(both):
                    continue
                moved, still = _wander(points[both, p]), _wander(points[both, q])
                if moved > pivot and still < 0.5 * moved:
                    out[start:end, p] = False
    return out


def _drop_slides(points: np.ndarray, contacts: np.ndarray, drift: float) -> np.ndarray:
    """contacts without those whose point wanders farther than drift across the floor (x, y) from its mean
    over the contact."""
    out = contacts.copy()
    for p in range(out.shape[1]):
        for start, end in intervals(out[:, p]):
            if _wander(points[start:end, p]) > drift:
                out[start:end, p] = False
    return out


def plant_targets(native, points, contacts, blend_frames: int, rigid_pairs=()) -> tuple[np.ndarray, np.ndarray]:
    """The cleanup's IK targets (frames, P, 3) and blend weights (frames, P), by the native core
    (native/include/motionkit/foot_targets.hpp): per contact one plant, the point's mean over it; each
    point blended to its nearest contact's plant by a smoothstep ramp over blend_frames frames either
    side; rigid_pairs (a, b), points a fixed distance apart (an ankle and the ball of the same foot):
    b's plant kept that distance from an overlapping contact of a's, a point not (fully) planted carried
    along with its foot's other one, and the two targets kept the distance apart that the points keep on
    each frame, so that a rigid foot can meet both. With no contact the targets are the points."""
    points = _check_points(points)
    contacts = np.ascontiguousarray(contacts, dtype=bool)
    if contacts.shape != points.shape[:2]:
        raise ValueError(f"contacts must have shape {points.shape[:2]}, not {contacts.shape}")
    frames, count = contacts.shape
    targets, weights = native.foot_targets(np.ascontiguousarray(points.reshape(frames, 3 * count)), contacts,
                                           int(blend_frames), [tuple(pair) for pair in rigid_pairs])
    return targets.reshape(frames, count, 3), weights
