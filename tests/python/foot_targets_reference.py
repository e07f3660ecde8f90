"""The footskate cleanup's targets in numpy: the reference the native foot_targets job (which the add-on
uses, native/src/foot_targets.cpp) is compared with, step by step as the add-on once computed them."""
import numpy as np

from core.foot_contacts import _check_points, all_intervals


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
    return [list(plants) for plants in _plants(points, all_intervals(contacts), rigid_pairs)]


def _plants(points, intervals_, rigid_pairs) -> list[np.ndarray]:
    """plant_positions as one (contacts, 3) array per point, from the contacts' intervals."""
    runs = [np.array(r, dtype=np.int64).reshape(-1, 2) for r in intervals_]
    # Means over [start, end) from running sums: one pass per point, however many contacts.
    sums = np.concatenate([np.zeros((1,) + points.shape[1:]), np.cumsum(points, axis=0)])
    plants = [(sums[r[:, 1], p] - sums[r[:, 0], p]) / (r[:, 1] - r[:, 0])[:, None] for p, r in enumerate(runs)]
    for a, b in rigid_pairs:
        if not (len(runs[a]) and len(runs[b])):
            continue
        distance = float(np.median(np.linalg.norm(points[:, b] - points[:, a], axis=1)))
        # Frames each b contact shares with each a contact; the a contact sharing the most (the first of equals).
        shared = (np.minimum(runs[b][:, None, 1], runs[a][None, :, 1])
                  - np.maximum(runs[b][:, None, 0], runs[a][None, :, 0]))
        best = np.argmax(shared, axis=1)
        offset = plants[b] - plants[a][best]
        norm = np.linalg.norm(offset, axis=1)
        moved = (shared[np.arange(len(best)), best] > 0) & (norm > 0)
        plants[b][moved] = plants[a][best[moved]] + offset[moved] * (distance / norm[moved])[:, None]
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
    if contacts.shape != points.shape[:2]:
        raise ValueError(f"contacts must have shape {points.shape[:2]}, not {contacts.shape}")
    intervals_ = all_intervals(contacts)
    plants = _plants(points, intervals_, rigid_pairs)
    distance, nearest = _distance_to_contact(contacts)
    targets = points.copy()
    for p, runs in enumerate(intervals_):
        if not runs:
            continue
        # Which interval each frame's nearest contact frame belongs to.
        starts = np.array([s for s, _ in runs])
        which = np.searchsorted(starts, nearest[:, p], side="right") - 1
        targets[:, p] = plants[p][which]
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
