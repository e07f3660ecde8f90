"""Where each rig's floor is, how long its legs are, and how the retargeted body comes to stand on the
target's floor (numpy and native posing, no bpy). The retarget's root-and-floor stage: every decision
about a floor is made here, on plain rig data (core.rig_data); core.floor holds the arithmetic.

Heights are along a unit `up` in a rig's armature space and in its units.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import bone_mapping, native_state, rotation_channels
from .floor import (clearance, clip_floor, clip_low, feet_lifts, hips_lift, leg_reaches, own_clip_floor, reach_drops,
                    rest_floor, sole_height)
from .rig_data import Pose, RigData
from .root_motion import Leg, leg_length as _one_leg


def legs(rig: RigData, body: bone_mapping.Body) -> list[Leg]:
    """The labelled legs (thigh and shin at least) as root_motion.Leg, by bone index."""
    out = []
    for s in bone_mapping.SIDES:
        thigh, shin, foot = (body.limbs.get(f"{k}.{s}") for k in ("thigh", "shin", "foot"))
        if thigh in rig and shin in rig:
            f = rig.index(foot) if foot in rig else -1
            below = () if f < 0 else tuple(i for i in range(len(rig)) if rig.is_below(i, f))
            out.append(Leg(rig.index(thigh), rig.index(shin), f, below))
    return out


def hip_height(pose: Pose, root: int, up: np.ndarray) -> float:
    """How high the root stands above the rig's lowest point, along up."""
    return float(pose.heads[root] @ up - (pose.points @ up).min())


def leg_length(rig: RigData, body, pose: Pose, up, hips: int, heads_over_clip=None, floor: float = 0.0) -> float:
    """The rig's leg length in its own armature units.

    thigh + shin + the ankle's height above the sole (the legs' mean), so
    that the same skeleton in any rest pose measures the same: what a leg
    reaches, and the contacts' and the floor's thresholds, scale with it (the
    root's path with standing_height); the hips' height above the lowest point
    only for a rig without labelled legs.
    heads_over_clip (frames, 3B): the rig's motion, for a zero pose's feet above the floor's height.
    """
    found = legs(rig, body)
    if not found:
        return hip_height(pose, hips, up)
    tails = pose.tails
    lengths = []
    for leg in found:
        lowest = None
        if heads_over_clip is not None and leg.foot >= 0:
            lowest = float(np.min(heads_over_clip[:, 3 * leg.foot:3 * leg.foot + 3] @ up)) - floor
            lowest = lowest if lowest > 0 else None
        lengths.append(_one_leg(leg, pose.heads, tails, lowest, up))
    return float(np.mean(lengths))



def standing_height(rig: RigData, body, pose: Pose, up, hips: int, legs_length: float, clearance: float) -> float:
    """How high the hips stand above the floor as the rig stands upright: the hips' head above the hip joints
    (the legs' mean), the legs' reach from hip joint to ankle, the ankle's height above the sole and the
    sole's clearance above the floor. The hip-to-ankle distance, not its height, so that legs spread at the
    hip (an A-pose) measure as when they hang, while a bent knee counts as it stands (Mixamo scales the root's
    path by the rest hips' heights: Goblin 1.21 of Aj's, SportyGranny 1.06, where their legs give 1.25 and
    0.97). legs_length: leg_length's (thigh + shin + ankle height); 0 where the rig has no labelled legs."""
    found = [leg for leg in legs(rig, body) if leg.foot >= 0]
    if not found or not legs_length > 0:
        return legs_length
    heads = pose.heads
    above = float(heads[hips] @ up - np.mean([heads[leg.thigh] @ up for leg in found]))
    reach = float(np.mean([np.linalg.norm(heads[leg.foot] - heads[leg.thigh]) for leg in found]))
    bones = float(np.mean([np.linalg.norm(heads[leg.shin] - heads[leg.thigh])
                           + np.linalg.norm(heads[leg.foot] - heads[leg.shin]) for leg in found]))
    # legs_length less thigh + shin: the ankle's height as leg_length measured it.
    height = above + reach + (legs_length - bones) + max(clearance, 0.0)
    return height if height > 0.5 * legs_length else legs_length

def foot_heights(rig: RigData, body, rotations, heads, up, column=None) -> np.ndarray:
    """(frames, legs) the lowest of each foot's ankle (its head) and ball (the toe's head, else the foot's tail)
    along up: the points a standing foot is put down by. column: bone index -> its column in rotations and
    heads (default: the same)."""
    column = column or (lambda b: b)
    out = []
    for leg, s in zip(legs(rig, body), bone_mapping.SIDES):
        foot = column(leg.foot)
        ankle = heads[:, 3 * foot:3 * foot + 3]
        toe = body.limbs.get(f"toe.{s}")
        # The toe's head is the ball wherever the rig has one (the foot's tail need not lie there).
        ball = heads[:, 3 * column(rig.index(toe)):3 * column(rig.index(toe)) + 3] if toe in rig else ankle + \
            rig.lengths[leg.foot] * rotation_channels.y_axes(rotations[:, 4 * foot:4 * foot + 4])
        out.append(np.minimum(ankle @ up, ball @ up))
    return np.stack(out, axis=1)


def floor_height(rig: RigData, body, up, given=None, heads_over_clip=None, own=False) -> tuple[float, float]:
    """(floor, clearance): the rig's floor along up in its armature space, given (a world Z height) if set,
    else the floor its importer recorded (RigData.floor), else its rest soles or the origin just below them
    (core.floor.rest_floor); a source clip (heads_over_clip) whose feet never come down to its rest soles
    walks on the floor core.floor.clip_floor finds; a target's own clip (own=True) as core.floor.own_clip_floor
    reads it. clearance: how high its rest soles (the lowest point of every bone of its feet, a heel bone's
    too) ride above that floor (core.floor.clearance)."""
    found = legs(rig, body)
    below = [b for leg in found for b in leg.below_ankle]
    soles = np.vstack([rig.heads[below], rig.tails[below]]) if below else None
    lengths = [np.linalg.norm(rig.heads[leg.shin] - rig.heads[leg.thigh])
               + np.linalg.norm(rig.tails[leg.shin] - rig.heads[leg.shin]) for leg in found]
    rest = sole_height(soles, up) if soles is not None else None
    floor = _floor_of(rig, found, up, given, heads_over_clip, rest, lengths, own)
    if own and rest is not None and floor != _floor_of(rig, found, up, given, None, rest, lengths, own):
        rest += _lifted(found, up, heads_over_clip, rig.heads)  # the soles where the clip stands them
    return floor, clearance(rest, floor, float(np.mean(lengths))) if rest is not None and lengths else 0.0


def joint_clearance(rig: RigData, body, up, floor: float, heads_over_clip=None, own=False) -> float:
    """How high the rig's foot joints that a standing foot is put down by (foot_heights': the ankle and the
    ball) ride above its floor when it stands: its rest's lowest of them, where that is no more than a sole's
    thickness above the floor (core.floor.clearance), else 0 (a capture's floor, on which the joints stand).
    Not the lowest foot point (floor_height's clearance): a heel bone lying on the floor (Blender's metarig,
    Rigify) or a toe's tip lies lower than any joint, and a foot held by its joints at that point's height
    sinks into the floor by the ball's height. heads_over_clip, own: a target's own clip, as floor_height
    reads it (the joints where that clip stands them)."""
    found = [leg for leg in legs(rig, body) if leg.foot >= 0]
    if not found:
        return 0.0
    pose = Pose.rest(rig)
    heads = pose.heads.reshape(1, -1)
    rest = float(foot_heights(rig, body, pose.rotations.reshape(1, -1), heads, up).min())
    if own and heads_over_clip is not None and floor != floor_height(rig, body, up)[0]:
        rest += _lifted(legs(rig, body), up, heads_over_clip, rig.heads)
    lengths = [np.linalg.norm(rig.heads[leg.shin] - rig.heads[leg.thigh])
               + np.linalg.norm(rig.tails[leg.shin] - rig.heads[leg.shin]) for leg in found]
    return clearance(rest, floor, float(np.mean(lengths)))


def own_lift(rig: RigData, body, up, heads_over_clip) -> float:
    """How far (along up, armature units) a target's own clip stands it above its rest, where its floor is
    read from that clip (floor_height's own=True, core.floor.own_clip_floor); 0 where it is not."""
    floor, _ = floor_height(rig, body, up, None, heads_over_clip, own=True)
    if floor == floor_height(rig, body, up)[0]:
        return 0.0
    return _lifted(legs(rig, body), up, heads_over_clip, rig.heads)


def _lifted(found, up, heads_over_clip, rest_heads) -> float:
    """How far a target's own clip stands its feet above where its rest has them, along up: its feet's
    lowest head as low as the clip brings it (core.floor.clip_low) against the rest's."""
    feet = [leg.foot for leg in found if leg.foot >= 0]
    return clip_low(_lowest_feet(feet, up, heads_over_clip)) - float(np.min(rest_heads[feet] @ up))


def _lowest_feet(feet, up, heads_over_clip) -> np.ndarray:
    """(frames,) the lowest of the feet bones' heads along up on each frame of a clip (frames, 3B)."""
    return np.min(np.stack([heads_over_clip[:, 3 * f:3 * f + 3] @ up for f in feet], axis=1), axis=1)


def _floor_of(rig: RigData, found, up, given, heads_over_clip, soles, lengths, own) -> float:
    if given is not None:
        return rig.world_height_to_armature(given)
    if rig.floor is not None:  # as its importer knew it
        return rig.floor
    if soles is None:
        return 0.0  # no feet: the armature's origin, as a capture's floor
    rest = rest_floor(soles, float(np.mean(lengths))) if lengths else soles
    feet = [leg.foot for leg in found if leg.foot >= 0]
    if heads_over_clip is None or not feet:
        return rest
    lowest = _lowest_feet(feet, up, heads_over_clip)
    rest_lowest = float(np.min(rig.heads[feet] @ up))
    return (own_clip_floor if own else clip_floor)(rest, lowest, float(np.mean(lengths)), rest_lowest)


def pose_legs(rig: RigData, body, rotations, locations, hips: int):
    """The armature pose of the legs, the hips and the bones above them only (the rest place no foot):
    (rotations, heads) of those bones and their column by bone index."""
    leg_bones = [b for leg, s in zip(legs(rig, body), bone_mapping.SIDES)
                 for b in (leg.thigh, leg.shin, leg.foot) + ((rig.index(body.limbs[f"toe.{s}"]),)
                                                             if body.limbs.get(f"toe.{s}") in rig else ())]
    sub = sorted(set(leg_bones + [hips]).union(*(rig.ancestors(b) for b in leg_bones + [hips])))
    where = {b: i for i, b in enumerate(sub)}
    columns4 = (4 * np.array(sub)[:, None] + np.arange(4)).ravel()
    columns3 = (3 * np.array(sub)[:, None] + np.arange(3)).ravel()
    posed = native_state.native().armature_pose(rig.native_rig(sub), np.ascontiguousarray(rotations[:, columns4]),
                                                np.ascontiguousarray(locations[:, columns3]))
    return posed[0], posed[1], where.__getitem__


@dataclass
class Ground:
    """A rig standing on its floor: its labels, Blender's up in its armature space, the height its lowest
    foot joint stands at when it stands (its floor plus its clearance), and its leg length (leg_length's)."""
    rig: RigData
    body: bone_mapping.Body
    up: np.ndarray
    standing: float
    leg: float


def stand_on_floor(source: Ground, source_pose, target: Ground, rotations, locations, hips: int, stances,
                   height_scale: float, fps: float) -> np.ndarray:
    """Lifts the target's hips (its location channel, in place) where a standing leg cannot reach down to the
    height the source's foot stands at, scaled (height_scale), and returns how far each foot is still to
    rise (frames, legs) for the legs' solve, core.floor.feet_lifts. source_pose: the source clip's
    (orientations (frames, 4B), heads (frames, 3B)); rotations, locations: the target's pose channels;
    stances: (frames, 4) the source's contacts (foot_contacts.POINTS order)."""
    leg = target.leg
    wanted = target.standing + height_scale * (
        foot_heights(source.rig, source.body, *source_pose, source.up) - source.standing)
    tgt, up = target.rig, target.up
    posed_rotations, posed_heads, column = pose_legs(tgt, target.body, rotations, locations, hips)
    heights = foot_heights(tgt, target.body, posed_rotations, posed_heads, up, column)
    stance = stances[:, 0::2] | stances[:, 1::2]  # per leg: its ankle or its ball stands
    joint = lambda b: posed_heads[:, 3 * column(b):3 * column(b) + 3]  # noqa: E731
    found = legs(tgt, target.body)
    ends = [(joint(leg_.thigh), joint(leg_.shin), joint(leg_.foot) if leg_.foot >= 0 else None) for leg_ in found]
    if all(ankle is not None for _, _, ankle in ends):
        # As straight as the solve's knee allows (its rest bend, or the clip's straightest), a little short.
        reach = leg_reaches([np.linalg.norm(k[0] - h[0]) + np.linalg.norm(a[0] - k[0]) for h, k, a in ends],
                            [np.linalg.norm(tgt.heads[leg_.foot] - tgt.heads[leg_.thigh]) for leg_ in found],
                            [np.linalg.norm(a - h, axis=1).max() for h, _, a in ends])
        drops = reach_drops(np.stack([h for h, _, _ in ends], axis=1), np.stack([a for _, _, a in ends], axis=1),
                            wanted - heights, up, reach)
        on_feet = on_its_feet(source, source_pose)
        floats = np.where(on_feet[:, None], wanted - heights, 0.0)
        lift = hips_lift(drops, stance, slope=0.5 * leg / fps, floats=floats)
    else:
        lift = np.zeros(len(heights))
    orient = posed_rotations[:, 4 * column(hips):4 * column(hips) + 4]
    locations[:, 3 * hips:3 * hips + 3] += _location_step(orient, rotations[:, 4 * hips:4 * hips + 4],
                                                            lift[:, None] * up)
    return feet_lifts(wanted, heights + lift[:, None], stance, target.standing, blend_frames=0.1 * fps,
                      slope=0.5 * leg / fps)


def _location_step(orient, basis, world) -> np.ndarray:
    """(frames, 3) the location channel's change that moves a bone's head by world (frames, 3): the location
    moves the head in the bone's posed frame less its own rotation. orient: the bone's posed orientations,
    basis: its rotation channel (frames, 4 each)."""
    frame = rotation_channels.multiply(orient, rotation_channels.conjugate(
        basis / np.linalg.norm(basis, axis=1, keepdims=True)))
    return rotation_channels.rotate_each(rotation_channels.conjugate(frame), world)


def first_frame_lift(rig: RigData, up, floor: float, rotations, locations, hips: int) -> np.ndarray:
    """floor_fit="first_frame": the whole clip moved along up once, so that on its first frame the lowest of
    the rig's bones' heads and tails touches floor; the motion's own heights are kept, no frame fitted apart.
    Returns the hips' location channels' change (frames, 3) that does it: the same world move on every frame,
    through each frame's posed frame above the hips. rotations, locations: (frames, 4B), (frames, 3B)."""
    native = native_state.native()
    first = native.armature_pose(rig.native, np.ascontiguousarray(rotations[:1]),
                                 np.ascontiguousarray(locations[:1]))
    pose = Pose(first[0].reshape(-1, 4), first[1].reshape(-1, 3), rig.lengths)
    lowest = min(float(np.min(pose.heads @ up)), float(np.min(pose.tails @ up)))
    line = sorted({hips, *rig.ancestors(hips)})
    columns4 = (4 * np.array(line)[:, None] + np.arange(4)).ravel()
    columns3 = (3 * np.array(line)[:, None] + np.arange(3)).ravel()
    orient = native.armature_pose(rig.native_rig(line), np.ascontiguousarray(rotations[:, columns4]),
                                  np.ascontiguousarray(locations[:, columns3]))[0]
    at = 4 * line.index(hips)
    world = np.tile((floor - lowest) * np.asarray(up, dtype=np.float64), (len(rotations), 1))
    return _location_step(orient[:, at:at + 4], rotations[:, 4 * hips:4 * hips + 4], world)


# Feet the hips' lift leaves off the floor by no more than this (in the target's legs) are left where the legs
# put them: the legs' solve, which changes the legs' bones' directions, is asked for only beyond it, so that a
# retarget between alike legs keeps every bone's direction exactly. A twentieth of a percent: half a millimetre
# on a metre's leg, far under what an animator sees of a foot off its floor.
LEFT_OFF = 5e-4


def feet_left_off(lifts, leg: float) -> bool:
    """Whether any foot is still to rise (stand_on_floor's lifts, world units) by more than LEFT_OFF of leg
    (the target's leg length, world units)."""
    return bool(np.abs(np.asarray(lifts, dtype=np.float64)).max(initial=0.0) > LEFT_OFF * leg)


# A body point this close above where the source's feet stand (in its leg lengths) rests on the floor: lying and
# on all fours in the SAN Getting Up, the lowest of them measured -0.12 to 0.06 (Kaya's hand dips through the
# floor); crouched on its feet, 0.14 (a hand near the floor) and 0.2 or more (the knees).
RESTING = 0.12
_ABOVE_FEET = ("upper_arm", "forearm", "hand", "thigh", "shin")


def on_its_feet(ground: Ground, pose) -> np.ndarray:
    """(frames,) the frames on which the rig stands on its feet alone: none of its hips, spine, neck, head,
    shoulders, elbows, wrists, hip joints or knees (heads of the labelled bones) rests on its floor (within
    RESTING of its legs of where it stands). pose: (orientations (frames, 4B), heads (frames, 3B))."""
    body, rig = ground.body, ground.rig
    names = [body.hips, *body.spine, *body.neck, body.head] + [
        body.limbs.get(f"{key}.{side}") for key in _ABOVE_FEET for side in bone_mapping.SIDES]
    bones = [rig.index(n) for n in names if n in rig]
    heads = pose[1]
    if not bones:
        return np.ones(len(heads), dtype=bool)
    heights = np.stack([heads[:, 3 * b:3 * b + 3] @ ground.up for b in bones], axis=1)
    return (heights - ground.standing).min(axis=1) > RESTING * ground.leg
