"""The retarget's body stage: where a forearm or a hand of the target goes into its own body (core.body),
the arm swung at the shoulder and the elbow the least that brings it back out to the clearance wanted, the
hand's direction kept, continuous over the clip (numpy and native posing, no bpy). docs/body.md.

Per frame that goes in, the turn of the upper arm about the shoulder and of the forearm about the elbow
(two rotation vectors) is solved by Gauss-Newton on the arm's skin points that are nearer the body than
wanted: each point moves by the turns' cross products with its lever arms, the body's distance along its
gradient; a small equal weight on both turns takes the least turn and shares it between the joints; each
run of consecutive frames is solved as one, neighbours' turns tied (SMOOTHNESS). The turns of the frames that
go in are then spread over the frames around them (a Gaussian-weighted mean of the nearby frames' turns,
eased in and out) and held to TURN_RATE, so that the arm leaves and meets the body without a pop; the frames
still in after that are solved again from there, and what that adds spread in turn (ROUNDS).
"""
from __future__ import annotations

import weakref
from dataclasses import dataclass, field

import numpy as np

from . import bone_mapping, native_state, rotation_channels
from .body import ARM_PARTS, MARGIN, Body, on_body

SAMPLES = 64          # skin points per arm, spread over its forearm and hand (farthest-point order)
# Body skin points (farthest-point order) a hand is brought toward where the field does not reach it: on a
# 1.8 m character's 1.8 square metres of skin, one about every 4 cm (the field takes it onto the skin).
SKIN_SAMPLES = 1024
ITERATIONS = 6        # Gauss-Newton steps per frame
# Below this of the turn (radians) both joints are alike to the solve: the least turn is the one it takes.
# A tenth of a radian's weight against a lever of half a metre: a centimetre of reach costs 0.01 rad.
TURN_WEIGHT = 0.05
# A hand this near its body (in the body's heights) touches it: the protocol's 2 cm on a 1.75 m character.
TOUCH = 0.02 / 1.75
ROUNDS = 4            # solve-and-spread rounds at most
MAX_STEP = 0.25      # radians a joint turns in one Gauss-Newton step at most
SPREAD = 0.1          # seconds: the Gaussian over which nearby frames' turns are averaged
EASE = 0.25           # seconds over which a turn eases in before and out after the frames that go in, at least
# ... and at least as many frames as keep the easing under this many degrees a frame: an animator sees a
# jump of a few degrees from one frame to the next as a pop (a smoothstep's steepest is 1.5 times its mean).
EASE_RATE = 1.5
# Within the frames that go in or touch, a joint's turn changes by at most this many degrees a second: 4 a
# frame at 24 fps, under a dance's own fastest arm (10-14 degrees a frame), so that what the stage adds
# never makes the arm move faster than the clip itself does (a place the hand is to reach that jumps with
# the source's nearest point would otherwise swing the arm with it).
TURN_RATE = 96.0
# Neighbouring frames' turns solved as one (_native.body_arm's smoothness): a turn's change from one frame
# to the next weighs as its distance in body heights over this many seconds, so that the frames of a run
# take the same way round the body (each alone, one goes over a shoulder, the next under it).
SMOOTHNESS = 0.0125
# A place on the body the hand reaches only by turning a joint farther than this (degrees) is not the
# corresponding place for this character (a long glove round a wide belly): the hand goes the nearest way.
MAX_TURN = 60.0
LIMIT_STEPS = 4000    # _limited's averaging steps at most: enough for a jump of two radians spread at the rate


@dataclass(frozen=True)
class Arm:
    """One arm's joints (upper arm, forearm, hand: bone indices) and its skin points: the bone each rides on
    (S,), its offset in that bone's rest frame (S, 3), and whether it is on the hand (S,)."""
    side: str
    upper_arm: int
    forearm: int
    hand: int
    bones: np.ndarray
    local: np.ndarray
    on_hand: np.ndarray


def arms(body: Body) -> list[Arm]:
    """The arms whose upper arm, forearm and hand are labelled and whose forearm or hand the mesh skins
    (found once a body: a retarget asks for them several times, a batch on every take)."""
    found = _ARMS.get(body)
    if found is None:
        found = _ARMS[body] = _find_arms(body)
    return found


_ARMS: "weakref.WeakKeyDictionary[Body, list[Arm]]" = weakref.WeakKeyDictionary()


def _find_arms(body: Body) -> list[Arm]:
    rig, labels, mesh = body.rig, body.rig.body, body.mesh
    out = []
    for side in bone_mapping.SIDES:
        names = [labels.limbs.get(f"{key}.{side}") for key in ("upper_arm", "forearm", "hand")]
        if any(n is None or n not in rig for n in names):
            continue
        upper, fore, hand = (rig.index(n) for n in names)
        # Decided per bone, not per vertex: a mesh has tens of thousands of vertices on a few bones.
        carried = [int(b) for b in np.unique(mesh.bone)
                   if b >= 0 and body.part[b] in ARM_PARTS and rig.is_below(int(b), upper)]
        riding = np.isin(mesh.bone, carried)
        if not riding.any():
            continue
        chosen = _spread(mesh.vertices[riding], SAMPLES)
        vertices = mesh.vertices[riding][chosen]
        bones = mesh.bone[riding][chosen]
        local = _riding(rig, vertices, bones)
        on_hand = np.array([rig.is_below(int(b), hand) for b in bones], dtype=bool)
        out.append(Arm(side, upper, fore, hand, bones, local, on_hand))
    return out


@dataclass(frozen=True)
class Skin:
    """The body's skin points a hand far from it is brought toward: the bone each rides on (K,) and its offset
    in that bone's rest frame (K, 3)."""
    bones: np.ndarray
    local: np.ndarray


def skin(body: Body) -> Skin:
    """SKIN_SAMPLES of the body's (trunk, head, thighs) vertices, spread farthest-point, found once a body."""
    found = _SKIN.get(body)
    if found is None:
        mesh = body.mesh
        on = np.flatnonzero(on_body(body.part, mesh))
        chosen = on[_spread(mesh.vertices[on], SKIN_SAMPLES)]
        found = _SKIN[body] = Skin(mesh.bone[chosen], _riding(body.rig, mesh.vertices[chosen], mesh.bone[chosen]))
    return found


def _riding(rig, vertices, bones) -> np.ndarray:
    """(N, 3) each vertex's offset in its bone's rest frame: what carries it rigidly with that bone."""
    return rotation_channels.rotate_each(rotation_channels.conjugate(rig.unit_rest[bones]), vertices - rig.heads[bones])


_SKIN: "weakref.WeakKeyDictionary[Body, Skin]" = weakref.WeakKeyDictionary()


def _spread(points, count: int) -> np.ndarray:
    """Indices of up to count points, each the farthest from those chosen before (the first: the farthest
    from their centre), so that the whole forearm and hand are covered, the same on every run."""
    if len(points) <= count:
        return np.arange(len(points))
    chosen = [int(np.argmax(np.linalg.norm(points - points.mean(axis=0), axis=1)))]
    nearest = np.linalg.norm(points - points[chosen[0]], axis=1)
    for _ in range(count - 1):
        chosen.append(int(np.argmax(nearest)))
        nearest = np.minimum(nearest, np.linalg.norm(points - points[chosen[-1]], axis=1))
    return np.array(chosen)


@dataclass
class Cleared:
    """What the stage did: per arm (side) the frames that went in or were to touch and did not (frames,),
    and the turns applied (frames, 6: the shoulder's and the elbow's rotation vectors, armature space)."""
    went_in: dict
    turns: dict


@dataclass
class Report:
    """What the body stage did, to say: "off" (asked so), "no mesh" (the target deforms none, or none that
    skins its trunk, head or thighs) or "on", the meshes read, and per arm (side) how many frames it changed:
    the arm brought out of the body, or the hand onto it where the source's touches its own."""
    state: str
    meshes: str = ""
    frames_in: dict = field(default_factory=dict)

    def message(self) -> str:
        if self.state == "off":
            return "Arms not kept out of the body (off)"
        if self.state == "no mesh":
            return (f"The target's meshes ({self.meshes}) skin no trunk, head or thighs" if self.meshes else
                    "The target deforms no mesh") + ": its arms were not kept out of its body"
        went = sum(self.frames_in.values())
        return (f"Arms kept out of the body of {self.meshes} and hands on it where the source's touch: " +
                (", ".join(f"{side} on {n} frames" for side, n in self.frames_in.items() if n) if went
                 else "nothing to change"))


def hand_distances(body: Body, orientations, heads) -> dict:
    """Per arm (side), (frames,) how far its hand is from the body on each frame of a pose (negative
    inside)."""
    return {arm.side: _measured(body, arm, orientations, heads).hand for arm in arms(body) if arm.on_hand.any()}


def touching(body: Body, orientations, heads) -> dict:
    """Per arm (side), (frames,) whether its hand touches the body on each frame of a pose: within TOUCH
    (of the body's height) of it, or in it."""
    return {side: d <= TOUCH * body.height for side, d in hand_distances(body, orientations, heads).items()}


def clearances(body: Body, orientations, heads) -> dict:
    """Per arm (side), (frames,) how far its skin stays from the body on each frame of a pose (an armature
    pose: orientations (frames, 4B), heads (frames, 3B)), 0 where it goes in: a hand that sinks into its own
    body touches it, its depth is no clearance to copy."""
    return {arm.side: np.maximum(_measured(body, arm, orientations, heads).least, 0.0) for arm in arms(body)}


def _measured(body: Body, arm: Arm, orientations, heads):
    """_native.BodyArmResult of the arm as the pose has it, on every frame."""
    count = len(orientations)
    return _arm(body, arm, orientations, heads, np.zeros(count), np.zeros((count, 6)), np.zeros(count, dtype=bool),
                np.arange(count), 0)[1]


@dataclass(frozen=True)
class Place:
    """Where one arm's hand touches the body on each frame: bone (frames,) the body bone carrying the place
    (-1 where it touches nowhere), offset (frames, 3) the place less that bone's posed head, in the
    armature's space, and hand (frames, 3) the hand's point that touches it less the hand's posed head,
    turned back by the hand's turn from its rest (where that point is on the hand at rest) (NaN where bone is
    -1); reach: that hand's length (hand_reach), what the hand's offset is a share of."""
    bone: np.ndarray
    offset: np.ndarray
    hand: np.ndarray
    reach: float


def touch_places(body: Body, orientations, heads, touching: dict) -> dict:
    """Per arm (side), the Place its hand touches the body at on the frames of touching (per side, (frames,)
    bools, as touching() finds them): the skin point nearest the hand's nearest point, and the body bone
    whose part of the field carries it there."""
    count = len(orientations)
    out = {}
    for arm in arms(body):
        bone, offset, hand = np.full(count, -1), np.full((count, 3), np.nan), np.full((count, 3), np.nan)
        frames = np.flatnonzero(np.asarray(touching.get(arm.side, np.zeros(count)), dtype=bool))
        if len(frames) and arm.on_hand.any():
            o, h = orientations[frames], heads[frames]
            points = _posed(arm, o, h)[:, arm.on_hand]
            distance, slope = body.posed_with_gradient(points, o, h)
            rows, nearest = np.arange(len(frames)), np.argmin(distance, axis=1)
            d, g = distance[rows, nearest], slope[rows, nearest]
            size = np.linalg.norm(g, axis=1)
            fine = np.isfinite(d) & (size > 1e-12)
            on_skin = points[rows, nearest] - np.where(fine, d / np.maximum(size, 1e-12), 0.0)[:, None] * g
            carrier = np.where(fine, _carrier_at(body, on_skin, o, h), -1)
            found = carrier >= 0
            bone[frames[found]] = carrier[found]
            held = np.flatnonzero(found)
            offset[frames[held]] = on_skin[held] - h[held[:, None], 3 * carrier[held][:, None] + np.arange(3)]
            hand[frames[held]] = rotation_channels.rotate_each(
                rotation_channels.conjugate(_hand_turn(body, arm, o[held])),
                points[rows, nearest][held] - h[held, 3 * arm.hand:3 * arm.hand + 3])
        out[arm.side] = Place(bone, offset, hand, hand_reach(body, arm))
    return out


def hand_reach(body: Body, arm: Arm) -> float:
    """How far the arm's hand skin reaches from its wrist (the hand bone's head) at rest: its length."""
    rig, on = body.rig, arm.on_hand
    if not on.any():
        return 0.0
    rest = rotation_channels.rotate_each(rig.unit_rest[arm.bones[on]], arm.local[on]) + rig.heads[arm.bones[on]]
    return float(np.linalg.norm(rest - rig.heads[arm.hand], axis=1).max())


def _carrier_at(body: Body, points, orientations, heads) -> np.ndarray:
    """(N,) per point (N, 3; the pose's frame N) the carrier whose part of the field holds it: of those that
    own the cell it maps to, the one reading the least signed distance, as Body.posed's native read takes
    it, -1 for none."""
    rig, best, found = body.rig, np.full(len(points), np.inf), np.full(len(points), -1)
    for b in body.carriers:
        to_rest = rotation_channels.multiply(np.broadcast_to(rig.unit_rest[b], (len(points), 4)),
                                             rotation_channels.conjugate(orientations[:, 4 * b:4 * b + 4]))
        rest = rotation_channels.rotate_each(to_rest, points - heads[:, 3 * b:3 * b + 3]) + rig.heads[b]
        distance, owner = body.at_rest(rest)
        better = (owner == b) & (distance < best)
        best, found = np.where(better, distance, best), np.where(better, b, found)
    return found


def _posed(arm: Arm, orientations, heads) -> np.ndarray:
    """(frames, S, 3): the arm's skin points where the pose has its bones."""
    g = np.stack([orientations[:, 4 * b:4 * b + 4] for b in arm.bones], axis=1)
    h = np.stack([heads[:, 3 * b:3 * b + 3] for b in arm.bones], axis=1)
    return rotation_channels.rotate_each(g, arm.local) + h


def _goals(body: Body, arm: Arm, place: Place, orientations, heads, fps: float) -> tuple:
    """(goals, contacts), each (frames, 3), for a Place (on this rig's bones): where the hand is to go on
    each frame (the bone's posed head plus the offset, taken to the nearest point half a cell off the skin;
    NaN where the place is off the field or there is none) and the hand's point that goes there (the hand's
    posed head plus the place's hand offset); (None, None) where there is none on any frame."""
    on = np.flatnonzero(place.bone >= 0)
    if not len(on):
        return None, None
    count, base, wrist = len(orientations), 3 * int(body.carriers[0]), 3 * arm.hand
    wanted = np.full((count, 3), np.nan)
    wanted[on] = heads[on[:, None], 3 * place.bone[on][:, None] + np.arange(3)] + place.offset[on]
    # Averaged over the frames around (relative to the body's first carrier), as the source's own contact
    # is: its hand's nearest point jumps from frame to frame (a finger, the wrist; the hip, the chest), and
    # the arm taken to each would jump with it.
    wanted = _averaged(wanted - heads[:, base:base + 3], fps) + heads[:, base:base + 3]
    goals, contacts = np.full((count, 3), np.nan), np.zeros((count, 3))
    goals[on] = _off_skin(body, wanted[on], orientations[on], heads[on])
    # On the hand as it is turned on each frame (the hand keeps the target's orientation, which need not be the
    # source's), the same share of its length, and there the hand's own skin point nearest: hands are not alike
    # in shape either (a cartoon glove's fingertip, shrunk to a slim hand's length, is off its fingers).
    size = hand_reach(body, arm) / place.reach if place.reach > 0.0 else 1.0
    mapped = heads[on, 3 * arm.hand:3 * arm.hand + 3] + rotation_channels.rotate_each(
        _hand_turn(body, arm, orientations[on]), size * place.hand[on])
    skin = _posed(arm, orientations[on], heads[on])[:, arm.on_hand]
    nearest = np.argmin(np.linalg.norm(skin - mapped[:, None, :], axis=2), axis=1)
    touching = np.full((count, 3), np.nan)
    touching[on] = skin[np.arange(len(on)), nearest] - heads[on, wrist:wrist + 3]
    contacts[on] = _averaged(touching, fps)[on] + heads[on, wrist:wrist + 3]
    return goals, contacts


def _hand_turn(body: Body, arm: Arm, orientations) -> np.ndarray:
    """(frames, 4) the hand's turn from its rest on each frame of a pose (armature space)."""
    rest = np.broadcast_to(body.rig.unit_rest[arm.hand], (len(orientations), 4))
    return rotation_channels.multiply(orientations[:, 4 * arm.hand:4 * arm.hand + 4], rotation_channels.conjugate(rest))


def _off_skin(body: Body, points, orientations, heads) -> np.ndarray:
    """(N, 3) the points (N, 3; on the pose's frames N) each taken along the field's gradient to half a cell
    off the skin (NaN where the field does not reach one)."""
    distance, slope = body.posed_with_gradient(points[:, None, :], orientations, heads)
    d, g = distance[:, 0], slope[:, 0]
    size = np.linalg.norm(g, axis=1)
    fine = np.isfinite(d) & (size > 1e-12)
    out = np.full((len(points), 3), np.nan)
    out[fine] = points[fine] - ((d[fine] - 0.5 * body.spacing) / size[fine])[:, None] * g[fine]
    return out


def _nearest_goals(body: Body, arm: Arm, orientations, heads, frames, fps: float) -> tuple:
    """(goals, contacts) as _goals gives them, on frames (indices): the body's skin point (skin()) nearest
    the hand's skin, half a cell off, and the hand's point nearest it, each averaged over the frames around
    (Gaussian, SPREAD: the goal relative to the body's first carrier, the hand's point to the wrist). The
    field's gradient takes a hand near the body the nearest way, but it reaches only MARGIN beyond the skin:
    a longer arm's hand, farther, is pulled by nothing. Averaged, since from afar the nearest pair of points
    jumps from frame to frame (a finger, then the wrist; the belly, then a thigh), and the arm would with it."""
    count = len(orientations)
    found, touching = np.full((count, 3), np.nan), np.full((count, 3), np.nan)
    on_skin = skin(body)
    base, wrist = 3 * int(body.carriers[0]), 3 * arm.hand
    for start in range(0, len(frames), 64):  # (64, hand, skin) distances at a time: a few megabytes
        chunk = frames[start:start + 64]
        o, h = orientations[chunk], heads[chunk]
        hand, body_points = _posed(arm, o, h)[:, arm.on_hand], _posed(on_skin, o, h)
        # Squared, through a product: the (64, hand, skin, 3) differences would cost ten times as much.
        gaps = (np.einsum("fhk,fhk->fh", hand, hand)[:, :, None] + np.einsum("fsk,fsk->fs", body_points, body_points)[:, None, :]
                - 2.0 * hand @ body_points.transpose(0, 2, 1))
        flat = np.argmin(gaps.reshape(len(chunk), -1), axis=1)
        rows, which, where = np.arange(len(chunk)), flat // gaps.shape[2], flat % gaps.shape[2]
        found[chunk] = body_points[rows, where] - h[:, base:base + 3]
        touching[chunk] = hand[rows, which] - h[:, wrist:wrist + 3]
    goals, contacts = np.full((count, 3), np.nan), np.zeros((count, 3))
    found, touching = _averaged(found, fps), _averaged(touching, fps)
    goals[frames] = _off_skin(body, found[frames] + heads[frames, base:base + 3], orientations[frames], heads[frames])
    contacts[frames] = touching[frames] + heads[frames, wrist:wrist + 3]
    return goals, contacts


def _averaged(values, fps: float) -> np.ndarray:
    """(frames, 3) values averaged over the frames around each (Gaussian, SPREAD) where they are finite, NaN
    where they are not."""
    present = np.all(np.isfinite(values), axis=1)
    out = _gaussian(np.where(present[:, None], values, 0.0), present.astype(float), fps)
    out[~present] = np.nan
    return out


def _gaussian(values, weights, fps: float) -> np.ndarray:
    """(frames, C) the weighted mean of values (frames, C) over the frames around each (a Gaussian of SPREAD,
    cut at four deviations), weights (frames,) each frame's; 0 where no weight is in reach."""
    sigma = max(SPREAD * fps, 1e-9)
    reach = int(np.ceil(4.0 * sigma))
    kernel = np.exp(-0.5 * (np.arange(-reach, reach + 1) / sigma) ** 2)
    centred = lambda v: np.convolve(v, kernel)[reach:reach + len(values)]  # noqa: E731
    total = centred(weights)
    summed = np.stack([centred(weights * values[:, k]) for k in range(values.shape[1])], axis=1)
    return summed / np.maximum(total, 1e-300)[:, None]


def clear(body: Body, rotations, locations, fps: float, clearance: dict | None = None, strength: float = 1.0,
          sides=bone_mapping.SIDES, touches: dict | None = None, places: dict | None = None) -> Cleared:
    """Brings every arm of sides that goes into the body back out, changing the upper arms', forearms' and
    hands' rotation channels in rotations (frames, 4B; locations (frames, 3B) place the root) in place.
    clearance: per side, (frames,) the distance (armature units) the arm is to keep where it goes in (the
    source's own, scaled), default none; strength: the share of each turn applied (1: out, 0: as it was).
    Half a cell of the field is kept beyond it: the field's own precision (docs/body.md). touches: per side,
    (frames,) where the hand is to touch the body (the source's own touches): there a hand farther than a
    cell from the body is brought onto it, the rest of the arm kept out: at the corresponding place where
    places (per side, a Place on this rig's bones: the source's touch_places, mapped) has one on the
    frame that the hand reaches with the arm kept out (_reachable; the hand's point nearest it onto the
    skin there, half a cell off), else the nearest way."""
    rig = body.rig
    native = native_state.native()
    orientations, heads = native.armature_pose(rig.native, np.ascontiguousarray(rotations),
                                               np.ascontiguousarray(locations))
    went_in, turns = {}, {}
    for arm in (a for a in arms(body) if a.side in sides):
        kept = (clearance or {}).get(arm.side)
        # No farther than the field reaches (a source's arm far from its body keeps what can be measured).
        reach = MARGIN * body.height - 2.0 * body.spacing
        wanted = 0.5 * body.spacing + (np.zeros(len(rotations)) if kept is None else
                                       np.clip(np.asarray(kept, dtype=np.float64), 0.0, reach))
        touch = np.zeros(len(rotations), dtype=bool) if (touches or {}).get(arm.side) is None else \
            np.asarray(touches[arm.side], dtype=bool) & arm.on_hand.any()
        count = len(rotations)
        goals, contacts, tried = _touch_goals(body, arm, (places or {}).get(arm.side), orientations, heads, wanted,
                                              touch, fps)
        spread = np.zeros((count, 6))
        needed = _needed(body, arm, orientations, heads, spread, touch, np.arange(count), (goals, contacts))
        went_in[arm.side], turns[arm.side] = needed, np.zeros((count, 6))
        if not needed.any():
            continue
        frames = np.flatnonzero(needed)
        # Each round solves the frames still in from where the last left them, and spreads what it adds
        # (smooth in turn): a frame's neighbours that needed less pull its average down, the next round
        # makes that up. The first takes the turns the goals' trial found (_reachable) where it has them.
        seeded = np.all(np.isfinite(tried), axis=1)
        for round_ in range(ROUNDS):
            start = np.where(seeded[:, None], tried, spread) if round_ == 0 else spread
            solved = _solve(body, arm, orientations, heads, wanted, start, touch, frames, fps, (goals, contacts))
            spread = _limited(spread + _spread_turns(frames, solved - spread[frames], count, fps), fps)
            if round_ == ROUNDS - 1:
                break
            # Only a frame that went in or that the turns reach can be in now: the others are as they were.
            reached = np.flatnonzero(needed | np.any(spread != 0.0, axis=1))
            frames = reached[_needed(body, arm, orientations, heads, spread, touch, reached, (goals, contacts))]
            if not len(frames):
                break
        # A frame whose solve found no finite turn (never seen) is left as it was, never made not finite.
        spread[~np.all(np.isfinite(spread), axis=1)] = 0.0
        turns[arm.side] = strength * spread
        _apply(rotations, orientations, arm, turns[arm.side])
    return Cleared(went_in, turns)


def _reachable(body: Body, arm: Arm, orientations, heads, wanted, touch, goals, most: float = np.inf) -> tuple:
    """(goals[0] (frames, 3) kept on the touching frames where the arm's solve brings the hand onto its goal
    (within a cell) with the rest of the arm out of the body (within half a cell, the field's precision),
    NaN on the others; that solve's turns (frames, 6) on the frames kept, NaN on the others). Where a goal is
    not kept the hand touches the nearest way. The clearance comes first: a place the target's hand cannot
    reach from outside its body (a far side of a bigger head, past the belly) would drag the arm through the
    body to it, or leave the hand short of the body, off it. most: the largest turn (radians) of either joint
    a goal is kept with."""
    on = np.flatnonzero(touch & np.all(np.isfinite(goals[0]), axis=1))
    kept, tried = goals[0].copy(), np.full((len(orientations), 6), np.nan)
    if not len(on):
        return kept, tried
    solved, measured = _arm(body, arm, orientations, heads, wanted, np.zeros((len(orientations), 6)), touch, on,
                            ROUNDS * ITERATIONS, goals)
    reached = (measured.least >= -0.5 * body.spacing) & (measured.gap <= body.spacing)
    reached &= np.all(np.linalg.norm(solved[on].reshape(-1, 2, 3), axis=2) <= most, axis=1)
    kept[on[~reached]] = np.nan
    tried[on[reached]] = solved[on[reached]]
    return kept, tried


def _touch_goals(body: Body, arm: Arm, place, orientations, heads, wanted, touch, fps: float) -> tuple:
    """(goals, contacts, tried) for the touching frames: the source's place (_goals) where the arm reaches it
    from outside (_reachable), else the nearest skin's (_nearest_goals) where it reaches that; goals NaN
    where neither (the field's nearest way then), (None, None, ...) where no frame touches; tried: the turns
    _reachable's solves found on the frames with a goal, NaN elsewhere."""
    count = len(orientations)
    goals, contacts, tried = None, None, np.full((count, 6), np.nan)
    if place is not None:
        goals, contacts = _goals(body, arm, place, orientations, heads, fps)
        if goals is not None:
            goals, tried = _reachable(body, arm, orientations, heads, wanted, touch, (goals, contacts),
                                      np.radians(MAX_TURN))
    none = touch & (np.ones(count, dtype=bool) if goals is None else ~np.all(np.isfinite(goals), axis=1))
    if not none.any():
        return (*_joined(body, arm, goals, contacts, touch, orientations, heads, fps), tried)
    near, touching = _nearest_goals(body, arm, orientations, heads, np.flatnonzero(none), fps)
    near, near_tried = _reachable(body, arm, orientations, heads, wanted, none, (near, touching))
    if goals is not None:
        taken = np.all(np.isfinite(near), axis=1)
        near, touching = np.where(taken[:, None], near, goals), np.where(taken[:, None], touching, contacts)
        near_tried = np.where(taken[:, None], near_tried, tried)
    return (*_joined(body, arm, near, touching, touch, orientations, heads, fps), near_tried)


def _joined(body: Body, arm: Arm, goals, contacts, touch, orientations, heads, fps: float) -> tuple:
    """(goals, contacts) on every touching frame: where a frame has none, joined by lines from the touching
    frames around that have one, then all averaged over the frames around (Gaussian, SPREAD), each relative to
    what carries it (the goal to the body's first carrier, the hand's point to the wrist), the goal taken back
    half a cell off the skin. Frame by frame, the goal would switch between the source's place, the nearest
    skin and none (the field's nearest way), and the arm would jump with it."""
    known = None if goals is None else touch & np.all(np.isfinite(goals), axis=1)
    if known is None or not known.any():
        return goals, contacts
    on, have = np.flatnonzero(touch), np.flatnonzero(known)
    base, wrist = 3 * int(body.carriers[0]), 3 * arm.hand
    out = []
    for values, carrier in ((goals, base), (contacts, wrist)):
        relative = values[have] - heads[have, carrier:carrier + 3]
        line = np.full_like(values, np.nan)
        line[on] = np.stack([np.interp(on, have, relative[:, k]) for k in range(3)], axis=1)
        out.append(_averaged(line, fps) + heads[:, carrier:carrier + 3])
    joined, held = np.full_like(goals, np.nan), np.zeros_like(contacts)
    joined[on] = _off_skin(body, out[0][on], orientations[on], heads[on])
    held[on] = out[1][on]
    return joined, held


def _quaternions(rotvecs) -> np.ndarray:
    angle = np.linalg.norm(rotvecs, axis=1, keepdims=True)
    axis = np.divide(rotvecs, angle, out=np.zeros_like(rotvecs), where=angle > 1e-15)
    return np.hstack([np.cos(0.5 * angle), np.sin(0.5 * angle) * axis])


def _needed(body: Body, arm: Arm, orientations, heads, turns, touch, frames, goals=(None, None)) -> np.ndarray:
    """(len(frames),) whether on each of frames the arm, turned so, still goes into the body, or where it
    is to touch, its hand is farther than a cell from the body (or from its goal, where it has one)."""
    _, measured = _arm(body, arm, orientations, heads, np.zeros(len(turns)), turns, touch, frames, 0, goals)
    far = measured.hand > body.spacing
    if goals[0] is not None:
        far = np.where(np.all(np.isfinite(goals[0][frames]), axis=1), measured.gap > body.spacing, far)
    return (measured.least < 0.0) | (touch[frames] & far)


def _solve(body: Body, arm: Arm, orientations, heads, wanted, turns, touch, frames, fps: float,
           goals=(None, None)) -> np.ndarray:
    """(len(frames), 6) the turns from turns (every frame's, (frames, 6)) on that bring every skin point to
    wanted (frames,) from the body and, on frames to touch, the hand's point nearest its goal onto it, or
    where there is none the hand's point nearest the body to half a cell from it (from either side)."""
    return _arm(body, arm, orientations, heads, wanted, turns, touch, frames, ITERATIONS, goals,
                SMOOTHNESS * fps * body.height)[0][frames]


def _arm(body: Body, arm: Arm, orientations, heads, wanted, turns, touch, frames, iterations, goals=(None, None),
         smoothness: float = 0.0):
    """(every frame's turns, solved from turns on at frames; _native.BodyArmResult at frames): the arm's
    Gauss-Newton, natively (_native.body_arm: the least turn on the points short of wanted, the hand's
    direction kept; goals: (_goals' goals, contacts) or (None, None))."""
    solved = np.array(turns, dtype=np.float64, order="C")
    measured = native_state.native().body_arm(
        **body.field_arguments(), orientations=np.ascontiguousarray(orientations, dtype=np.float64),
        heads=np.ascontiguousarray(heads, dtype=np.float64), arm=[arm.upper_arm, arm.forearm, arm.hand],
        point_bones=[int(b) for b in arm.bones], point_local=np.ascontiguousarray(arm.local, dtype=np.float64),
        on_hand=arm.on_hand.astype(int).tolist(), frames=[int(f) for f in frames],
        wanted=np.ascontiguousarray(wanted, dtype=np.float64), touch=np.asarray(touch, dtype=int).tolist(),
        turns=solved, goals=None if goals[0] is None else np.ascontiguousarray(goals[0], dtype=np.float64),
        contacts=None if goals[1] is None else np.ascontiguousarray(goals[1], dtype=np.float64),
        touch_distance=0.5 * body.spacing, iterations=iterations, turn_weight=TURN_WEIGHT, max_step=MAX_STEP,
        smoothness=smoothness)
    return solved, measured


def _spread_turns(frames, solved, count: int, fps: float) -> np.ndarray:
    """(count, 6): the solved frames' turns, joined by lines between them (and held before the first and after
    the last), averaged over the frames around each (Gaussian, SPREAD), eased from nothing EASE (or as
    EASE_RATE asks of the largest turn) before the first and after the last of a run of frames that go in.
    The lines, never the nearer run's turn: between two runs that would switch from one to the other
    halfway, a pop as large as their difference."""
    every = np.arange(count)
    line = np.stack([np.interp(every, frames, solved[:, k]) for k in range(6)], axis=1)
    mean = _gaussian(line, np.ones(count), fps)
    gaps = _gaps(frames, count)
    peak = np.degrees(max(np.linalg.norm(solved[:, :3], axis=1).max(), np.linalg.norm(solved[:, 3:], axis=1).max()))
    ease_frames = max(EASE * fps, 1.5 * peak / EASE_RATE, 1e-9)
    ease = np.clip(1.0 - gaps / ease_frames, 0.0, 1.0)
    ease = ease * ease * (3.0 - 2.0 * ease)  # smoothstep: no kink where it starts or ends
    return mean * ease[:, None]


def _limited(turns, fps: float) -> np.ndarray:
    """(frames, 6) the turns, where from one frame to the next a joint's changes by more than TURN_RATE allows,
    averaged with its neighbours there until none does (a local diffusion: the turn spread over as many frames
    as the rate asks, the frames away from it left to the bit)."""
    budget, count = np.radians(TURN_RATE) / max(fps, 1e-9), len(turns)
    out = np.array(turns, dtype=np.float64)
    if count < 3:
        return out
    # A jump of J radians needs about J / budget frames, a diffusion about their square of steps.
    for _ in range(LIMIT_STEPS):
        change = np.square(out[1:] - out[:-1])
        fast = np.maximum(change[:, :3].sum(axis=1), change[:, 3:].sum(axis=1)) > budget * budget
        if not fast.any():
            break
        near = np.zeros(count, dtype=bool)  # both frames of a fast change and one either side
        near[:-1] |= fast
        near[1:] |= fast
        near[1:-1] |= near[:-2] | near[2:]
        near[[0, -1]] = False
        out[1:-1][near[1:-1]] = ((out[:-2] + out[1:-1] + out[2:]) / 3.0)[near[1:-1]]
    return out


def _gaps(frames, count: int) -> np.ndarray:
    """(count,) each frame's distance in frames to the nearest of frames (sorted indices)."""
    every = np.arange(count)
    after = np.searchsorted(frames, every)
    before = np.maximum(after - 1, 0)
    later = np.minimum(after, len(frames) - 1)
    left = np.where(after > 0, every - frames[before], np.inf)
    right = np.where(after < len(frames), frames[later] - every, np.inf)
    return np.minimum(left, right)


def _apply(rotations, orientations, arm: Arm, turns) -> None:
    """The turns written into the rotation channels: the upper arm turned by the shoulder's, the forearm by
    the elbow's, the hand back to its orientation (each basis' change from its orientation's,
    basis' = basis G^-1 R G)."""
    turned = np.flatnonzero(np.any(turns != 0.0, axis=1))  # the frames left alone stay to the bit
    qs, qe = _quaternions(turns[turned, :3]), _quaternions(turns[turned, 3:])
    both = rotation_channels.multiply(qs, qe)
    for bone, world in ((arm.upper_arm, qs), (arm.forearm, qe),
                        (arm.hand, rotation_channels.conjugate(both))):
        g = orientations[turned, 4 * bone:4 * bone + 4]
        change = rotation_channels.multiply(rotation_channels.conjugate(g), rotation_channels.multiply(world, g))
        basis = rotations[turned, 4 * bone:4 * bone + 4]
        rotations[turned, 4 * bone:4 * bone + 4] = rotation_channels.multiply(basis, change)
