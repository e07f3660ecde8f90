"""The target's bones that follow the body once it is retargeted (features.retargeting.plan's later stages):
IK and prop bones no map drives keyed to stand where the hands and feet they stand for stand (core.follow),
mapped props moved as the source's move in the space the user picks (core.props), two hands on one prop
(core.two_hands), and the source's moving props the target has no bone for, said. rigs, clip, fit, plan_:
the retarget's _Rigs, its core.retarget_inputs.SourceClip, _Fit and Plan; written: the target bones it writes (indices; None: all)."""
from __future__ import annotations

import numpy as np

from . import retarget_keys
from ..core import bone_mapping, channel_carry, follow, native_state, props, two_hands
from ..core.rig_data import RigData


def follow_bones(rigs, plan_, written) -> None:
    """The target's IK and prop bones that no map drives (core.follow: Unreal's ik_foot_l, ik_hand_gun...)
    keyed to stand where the hands and feet they stand for stand, once the feet's solve is done."""
    pairs = {f: b for f, b in follow.followers(rigs.tgt, rigs.tgt.body).items()
             if rigs.bone_map[f] < 0 and (written is None or b in written)}
    if not pairs:
        return
    plan_.resolve()
    rotations, locations = plan_.pose
    posed = native_state.native().armature_pose(rigs.tgt.native, rotations, locations)
    follow.follow(rigs.tgt, pairs, rotations, locations, posed)
    retarget_keys.rekey(rigs, plan_, set(pairs), located=list(pairs))


def move_props(rigs, clip, fit, plan_, written, space: str) -> None:
    """Mapped props (core.props) moved as the source's move in space: their hands, the hips or the world."""
    pairs = {}
    for prop in prop_bones(rigs):
        if written is not None and prop not in written:
            continue
        source = int(rigs.bone_map[prop])
        refs = (-1, -1) if space == "world" else rigs.roots
        if space == "hand":
            hands = (_labelled_hand(rigs.src, source), _labelled_hand(rigs.tgt, prop))
            refs = hands if min(hands) >= 0 else rigs.roots
        pairs[prop] = (source, *refs)
    if not pairs:
        return
    plan_.resolve()
    rotations, locations = plan_.pose
    posed = native_state.native().armature_pose(rigs.tgt.native, rotations, locations)
    scale = fit.unit_scale if space == "world" else fit.scale
    poses = props.wanted(rigs.src, rigs.tgt, pairs, (clip.rotations, clip.heads), posed, fit.space, scale)
    props.place(rigs.tgt, poses, rotations, locations, posed)
    retarget_keys.rekey(rigs, plan_, set(pairs), located=list(pairs))


def prop_bones(rigs) -> list[int]:
    """The target's mapped props (core.props.candidates), by index."""
    return [b for b in props.candidates(rigs.tgt, rigs.roots) if rigs.bone_map[b] >= 0]


def props_left_out(rigs, clip) -> list:
    """The source's props that move in the clip and that no pair takes: said, as the channels are."""
    paired = set(int(a) for a in rigs.bone_map if a >= 0)
    roots = [b for b in (rigs.roots[0], rigs.floor_bones[0]) if b is not None]
    bones = [b for b in props.candidates(rigs.src, roots) if b not in paired]
    reason = "a prop that moves; the target has no bone mapped to it (add one and map it)"
    return [channel_carry.LeftOut("bone", rigs.src.names[b], reason)
            for b in props.moving(rigs.src, bones, clip.basis, clip.locations)]


def _labelled_hand(rig: RigData, bone: int) -> int:
    """The labelled hand bone hangs from (its index), or -1."""
    hands = {rig.body.limbs.get(f"hand.{s}") for s in bone_mapping.SIDES}
    return next((a for a in rig.ancestors(bone) if rig.names[a] in hands), -1)


def _grips(rigs, written) -> list:
    """The two-handed holds the target can take (core.two_hands.Grip): a mapped bone under one hand that no
    label names (a rifle), and the other arm on both rigs."""
    tgt, src = rigs.tgt, rigs.src
    out = []
    for prop in prop_bones(rigs):
        hand = _labelled_hand(tgt, prop)
        if hand < 0:
            continue
        other = "L" if tgt.names[hand] == tgt.body.limbs.get("hand.R") else "R"
        names = [tgt.body.limbs.get(f"{k}.{other}") for k in ("upper_arm", "forearm", "hand")]
        sources = [src.body.limbs.get(f"{k}.{other}") for k in ("hand", "forearm")]
        if not all(n in tgt for n in names) or not all(n in src for n in sources):
            continue
        upper, forearm, hand = (tgt.index(n) for n in names)
        if written is not None and not {upper, forearm} <= written:
            continue
        out.append(two_hands.Grip(int(rigs.bone_map[prop]), src.index(sources[0]), src.index(sources[1]), prop,
                                  upper, forearm, hand))
    return out


def two_hands_hold(rigs, clip, fit, plan_, written) -> None:
    """A prop held in both hands: the target's other hand put where the source's holds it (core.two_hands),
    one prop at a time (core.two_hands.one_hold), each arm from the pose the other arm's hold leaves; only
    the frames where the source's hand holds are posed and solved."""
    arms = {}
    for grip in _grips(rigs, written):
        weight = two_hands.weights(rigs.src, grip, (clip.rotations, clip.heads))
        if weight.any():
            arms.setdefault((grip.upper, grip.forearm, grip.hand), []).append((grip, weight))
    if not arms:
        return
    plan_.resolve()
    rotations, locations = plan_.pose
    for held in arms.values():
        weight, which = two_hands.one_hold(np.stack([w for _, w in held]))
        rows = np.flatnonzero(weight > 0.0)
        part = rotations[rows]  # a row index copies, C-contiguous, as the native call takes it
        posed = native_state.native().armature_pose(rigs.tgt.native, part, locations[rows])
        wrists = np.empty((rows.size, 3))
        for i, (grip, _) in enumerate(held):
            mine = which[rows] == i
            if not mine.any():
                continue
            source = (clip.rotations[rows[mine]], clip.heads[rows[mine]])
            wrists[mine] = two_hands.wanted_wrists(rigs.src, rigs.tgt, grip, source, (posed[0][mine], posed[1][mine]),
                                                   fit.space, fit.scale)
        arm = held[0][0]
        two_hands.reach(rigs.tgt, arm, part, posed, wrists, weight[rows], fit.up)
        rotations[rows] = part
    retarget_keys.rekey(rigs, plan_, {b for upper, forearm, _ in arms for b in (upper, forearm)})
