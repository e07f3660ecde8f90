"""Each rig's floor, and the body's height over it so that retargeted feet stand on it (numpy, no bpy).

A rig's floor is its own: where its rest pose's soles stand (the lowest
point of its feet along its up), never armature Z = 0, so an armature whose
origin sits at the hips, or an FBX import scaled 0.01 and turned 90 degrees,
has the same floor as one whose origin is on the ground. A capture whose rest
pose does not stand on its floor (a BVH file whose root OFFSET is zero hangs
its rest pose below the ground the clip walks on) takes the floor the clip's
feet come down to instead; a target whose own action walks on its origin's
level while its rest hangs below it, that level.

Heights are along a unit `up` in the rig's armature space and in its units.
"""
from __future__ import annotations

import numpy as np


# A rest pose whose feet lie farther than this (in leg lengths) from where the clip's feet come down does not
# stand on the clip's floor: a standing clip's feet come down to within a few hundredths of a leg of the rest's
# (a crouch lifts the heels, a tiptoe the ankles, by a tenth at most), a rest hanging from its origin lies a
# whole leg below.
_HANGING_REST = 0.25
# The clip's floor: the lowest foot point's low percentile over the clip (a few stray frames aside).
_FLOOR_PERCENTILE = 2.0


def sole_height(points, up) -> float:
    """The floor of a pose: the lowest of its foot points (n, 3) along up."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if not len(points):
        raise ValueError("no foot points to find the floor from")
    return float(np.min(points @ up))


# A foot's lowest joint stands a little above the sole it carries (a ball joint inside the foot: Kaya's, of
# the Mixamo test set, 2.4 % of her leg above the ground her clips walk on), in leg lengths.
_JOINT_ABOVE_SOLE = 0.04


def rest_floor(soles: float, leg_length: float) -> float:
    """The floor a rest pose stands on, from its lowest foot point's height (soles): the armature origin's
    level where the soles stand just above it (joints ride above the sole), else the soles themselves (an
    origin at the hips, or anywhere else)."""
    return 0.0 if 0.0 <= soles <= _JOINT_ABOVE_SOLE * leg_length else soles


def clearance(soles: float, floor: float, leg_length: float) -> float:
    """How high a rig's lowest foot joint rides above its floor when it stands, from its rest: the rest soles'
    height above the floor where that is no more than a sole's thickness (4 % of the leg), else 0 (a floor
    given by hand, or a capture's, on which the joints themselves stand)."""
    above = soles - floor
    return above if 0.0 <= above <= _JOINT_ABOVE_SOLE * leg_length else 0.0


def clip_floor(rest_floor: float, lowest, leg_length: float, rest_lowest: float) -> float:
    """The floor a source clip walks on: its rest pose's when the clip's feet come down to where the rest pose
    has them; otherwise (a rest pose hanging below the ground, or a zero pose) the armature origin's level
    when the feet come down to that (a capture's floor), else the lowest the feet reach.

    lowest: (frames,) the lowest foot joint's height on each frame; rest_lowest: the same joints' lowest at
    rest. Joints are held against joints, never against the soles: an ankle rides above the sole by a share
    of the leg that differs from body to body (a child's by over a quarter of its leg, an adult's by a tenth).
    """
    lowest = np.asarray(lowest, dtype=np.float64)
    if not len(lowest):
        return rest_floor
    reached = clip_low(lowest)
    near = _HANGING_REST * leg_length
    if abs(reached - rest_lowest) <= near:
        return rest_floor
    return 0.0 if abs(reached) <= near else reached


def clip_low(lowest) -> float:
    """How low a clip's feet come (lowest: (frames,) the lowest foot point on each frame): a low percentile,
    a few stray frames aside."""
    return float(np.percentile(np.asarray(lowest, dtype=np.float64), _FLOOR_PERCENTILE))


def own_clip_floor(rest_floor: float, lowest, leg_length: float, rest_lowest: float) -> float:
    """The floor a target stands on, from its rest floor and a clip of its own (the action it plays): the
    armature origin's level where its rest hangs off that level and the clip's feet come down to it
    (clip_floor's capture case: girl1 of ../shared/data/pairs, her rest's hips at her origin and her clips
    walking on it), else its rest floor. Only that case: a target's action may be any clip (a jump, a
    climb), so the lowest its feet reach sets no floor on its own."""
    return 0.0 if clip_floor(rest_floor, lowest, leg_length, rest_lowest) == 0.0 else rest_floor


def _through_stance(values, stance) -> np.ndarray:
    """values (frames,) on the stance frames, run linearly between them (held before and after)."""
    frames = len(values)
    if not frames or not stance.any():
        return np.zeros(frames)
    return np.interp(np.arange(frames), np.flatnonzero(stance), values[stance])


def _below_with_bounded_slope(values, slope: float) -> np.ndarray:
    """The highest curve at or below values (frames,) that changes by at most slope from frame to frame."""
    t = slope * np.arange(len(values))
    forward = np.minimum.accumulate(values - t) + t
    backward = np.minimum.accumulate((values + t)[::-1])[::-1] - t
    return np.minimum(forward, backward)


def reach_drops(hip_joints, ankles, rise, up, reach) -> np.ndarray:
    """How far the hips must come down (frames, legs), <= 0, so that each ankle moved by rise along up comes
    within reach of its hip joint: the legs bend or stretch to put a foot where it should stand, and the
    hips move only where a leg would have to stretch beyond straight.

    hip_joints, ankles: (frames, legs, 3) where they are; rise: (frames, legs) how far each foot should
    move along up (negative: down); up: unit (3,); reach: (legs,) each leg's longest hip-to-ankle reach.
    """
    hip_joints, ankles = np.asarray(hip_joints, dtype=np.float64), np.asarray(ankles, dtype=np.float64)
    v = ankles + np.asarray(rise, dtype=np.float64)[..., None] * up - hip_joints
    along = v @ up
    across = np.linalg.norm(v - along[..., None] * up, axis=-1)
    reach = np.asarray(reach, dtype=np.float64)
    return np.minimum(0.0, along + np.sqrt(np.maximum(reach ** 2 - across ** 2, 0.0)))


# A leg reaches a thousandth of its length short of what its knee allows: the feet's solve stays
# well-conditioned.
_REACH_MARGIN = 1e-3


def leg_reaches(straight, rest, farthest) -> np.ndarray:
    """(legs,) how far each leg reaches from its hip joint to its ankle in the feet's solve, a thousandth of
    its length short (the reach reach_drops takes): its knee straightens as far as its rest pose has it (a
    knee bent by design: Blender's metarig's, 10 degrees) or the clip itself does, never beyond straight,
    as the solve's knee limits allow (features.contacts). straight: (legs,) thigh + shin, joint to joint;
    rest: (legs,) hip joint to ankle at rest; farthest: (legs,) the most hip joint to ankle over the clip."""
    straight = np.asarray(straight, dtype=np.float64)
    return np.minimum(straight, np.maximum(rest, farthest)) - _REACH_MARGIN * straight


def hips_lift(drops, stance, slope: float, floats=None) -> np.ndarray:
    """How far to move the hips along up on each frame (frames,), <= 0: on stance frames the most any
    standing leg needs (reach_drops), eased in beforehand and out afterwards at most slope a frame, never
    short of what a frame needs; 0 wherever no standing leg needs it (a jump keeps the source's height,
    scaled). floats (frames, legs), where given: how far each foot is from where it should stand (wanted
    less its height; 0 on frames the body does not stand on its feet alone): where every standing foot
    floats, the hips also come down until the nearest one stands, so that the legs keep the source's bend
    (a bent-kneed character's crouch settles lower, as Mixamo's own retargets do) rather than stretch."""
    drops, stance = np.asarray(drops, dtype=np.float64), np.asarray(stance, dtype=bool)
    if not len(drops):
        return np.zeros(0)
    needed = np.where(stance, drops, 0.0).min(axis=1)
    if floats is not None:
        floating = np.where(stance, np.minimum(np.asarray(floats, dtype=np.float64), 0.0), -np.inf).max(axis=1)
        needed = np.minimum(needed, np.where(np.isfinite(floating), floating, 0.0))
    return _below_with_bounded_slope(needed, slope)


def _near_stance(stance, blend_frames: float, values=None, slope: float = np.inf) -> np.ndarray:
    """(frames,) 1 on stance frames, easing to 0 (smoothstep) either side over blend_frames frames, or, where
    values (frames,) is large at the stance's edge, over 1.5 |value| / slope frames: what is eased out then
    changes by at most slope a frame (a smoothstep's steepest is 1.5 times its mean), so that a foot's large
    lift neither pops on nor off."""
    frames = len(stance)
    on = np.flatnonzero(stance)
    if not len(on):
        return np.zeros(frames)
    length = np.full(len(on), max(blend_frames, 1e-9))
    if values is not None and np.isfinite(slope) and slope > 0:
        length = np.maximum(length, 1.5 * np.abs(np.asarray(values, dtype=np.float64)[on]) / slope)
    index = np.arange(frames)
    after = np.clip(np.searchsorted(on, index), 0, len(on) - 1)
    before = np.clip(after - 1, 0, len(on) - 1)

    def eased(k):
        x = np.clip(1.0 - np.abs(on[k] - index) / length[k], 0.0, 1.0)
        return x * x * (3.0 - 2.0 * x)

    return np.maximum(eased(after), eased(before))


def feet_lifts(wanted, heights, stance, floor: float, blend_frames: float, slope: float = np.inf) -> np.ndarray:
    """(frames, feet) how far each foot is still to rise once the hips are lifted (heights include that):
    on its stance frames what it lacks (two feet standing at once where the rigs' legs differ), eased in
    and out over blend_frames either side, longer where that is more than slope a frame (_near_stance), so
    that nothing pops; and on any frame at least enough that it
    sinks no deeper below the floor than it should (wanted: the source's own depth below its floor,
    scaled; a capture's toes may dip a little), so the retarget never pushes a foot into the ground."""
    wanted, heights = np.asarray(wanted, dtype=np.float64), np.asarray(heights, dtype=np.float64)
    stance = np.asarray(stance, dtype=bool)
    if not len(heights):
        return np.zeros_like(heights)
    through = [_through_stance(wanted[:, k] - heights[:, k], stance[:, k]) for k in range(heights.shape[1])]
    lacking = np.stack([through[k] * _near_stance(stance[:, k], blend_frames, through[k], slope)
                        for k in range(heights.shape[1])], axis=1)
    return np.maximum(lacking, np.minimum(wanted, floor) - heights)
