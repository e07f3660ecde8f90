"""The reference pose: per chain, whether the target keeps its own posture or takes the source's direction
(numpy, no bpy).

Two rigs' rest poses differ in two ways. Where they stand in different poses
(one in a T, the other in an A; a capture with its legs spread), a limb of the
target is turned onto the source's direction before the source's motion is
laid on it: MATCH. Where they stand in the same pose but their bodies differ
(a hunched spine, a forward lean, knees bent by design, a long neck), the
target keeps its own posture and moves from it as the source moves from its
own: KEEP. That is what Mixamo does between its own characters (their upper
bodies' local rotations come out identical), and what Unreal's retarget pose
and HumanIK do once both rigs stand in a T.

The decision is per chain (CHAINS). The trunk (hips, spine, neck, head) is
the character's posture and is kept, unless its line (hips to head) lies
farther than TRUNK_POSE_ANGLE from the source's (a rig lying or bent double at
rest). A limb is matched where its overall line (from its upper bone's head to
its end joint) lies farther than LIMB_POSE_ANGLE from the source's, and kept
otherwise. Fingers are matched (a hand's rest spread and curl are poses). A
bone of a kept chain that its parents carry to point more than 45 degrees from
the source's is turned all the same (a capture's foot pointing down its shin;
the native retarget decides that, where the carrying is known). A
zero pose (every joint straight on from its parent's, as some captures' rests
stand) is no body's posture, and a rig whose trunk lies farther than
TRUNK_POSE_ANGLE from the source's stands in another pose altogether (lying,
or a zero pose along the floor): against either, every chain is matched. The user can
set any chain either way.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import bone_mapping
from .chain_modes import CHAINS, check_modes

# T against A arms lie 30-50 degrees apart and a capture's spread legs 20-45; the limbs of characters that all
# stand in a T differ by under 10 (a slightly lowered arm, a wide stance). Halfway between.
LIMB_POSE_ANGLE = 15.0
# Characters' spines lean 10-28 degrees forward or back bone by bone; hips to head, less.
TRUNK_POSE_ANGLE = 45.0

_LIMB_ENDS = {"arm": ("upper_arm", "hand", "forearm"), "leg": ("thigh", "foot", "shin")}
_POSE_ANGLE = {"trunk": TRUNK_POSE_ANGLE, "arm": LIMB_POSE_ANGLE, "leg": LIMB_POSE_ANGLE}


@dataclass(frozen=True)
class ChainPose:
    """How one chain of the target stands in the reference pose."""
    chain: str             # one of CHAINS
    mode: str              # "KEEP" (the target's own posture) or "MATCH" (turned onto the source's direction)
    by_user: bool          # the user's choice, not the automatic one
    angle: float           # degrees between the two rigs' lines of a limb in their match poses; nan elsewhere


@dataclass(frozen=True)
class Limbs:
    """One rig's match pose as this stage reads it: its body labels and its joints (heads) by bone name, in
    the target's armature space (the source's carried there)."""
    body: bone_mapping.Body
    heads: dict
    zero_pose: bool = False  # every joint straight on from its parent's: no body's posture


def _line(limbs: Limbs, kind: str, side: str) -> np.ndarray | None:
    """A chain's overall line (unit): a limb's from its upper bone's head to its end joint, the trunk's from
    the hips' head to the head's; None where unlabelled."""
    body, heads = limbs.body, limbs.heads
    if kind == "trunk":
        start, end = heads.get(body.hips), heads.get(body.head or (body.neck or body.spine or [None])[-1])
    else:
        upper, end_key, middle = _LIMB_ENDS[kind]
        start = heads.get(body.limbs.get(f"{upper}.{side}"))
        end = heads.get(body.limbs.get(f"{end_key}.{side}"))
        if end is None:  # no hand or foot: the middle bone's head still shows where the limb starts off
            end = heads.get(body.limbs.get(f"{middle}.{side}"))
    if start is None or end is None:
        return None
    line = np.asarray(end, dtype=np.float64) - np.asarray(start, dtype=np.float64)
    length = np.linalg.norm(line)
    return line / length if length > 1e-12 else None


def _angle(a, b) -> float:
    return float(np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b)), np.dot(a, b))))


def decide(source: Limbs, target: Limbs, user_modes=None) -> list[ChainPose]:
    """Every chain's mode, the user's where given (user_modes: {chain: mode})."""
    user_modes = check_modes(user_modes)
    trunk = _line(source, "trunk", ""), _line(target, "trunk", "")
    elsewhere = source.zero_pose or target.zero_pose or (
        trunk[0] is not None and trunk[1] is not None and _angle(*trunk) > TRUNK_POSE_ANGLE)
    out = []
    for chain in CHAINS:
        kind, _, side = chain.partition(".")
        angle, auto = float("nan"), "KEEP" if kind == "trunk" else "MATCH"
        if kind in _POSE_ANGLE:
            lines = _line(source, kind, side), _line(target, kind, side)
            if lines[0] is not None and lines[1] is not None:
                angle = _angle(*lines)
                auto = "MATCH" if angle > _POSE_ANGLE[kind] else "KEEP"
        if elsewhere:
            auto = "MATCH"
        mode = user_modes.get(chain, auto)
        out.append(ChainPose(chain, mode, chain in user_modes, angle))
    return out


def chain_of_labels(body: bone_mapping.Body) -> dict:
    """{bone name: chain} for the labelled bones of a body."""
    out = {name: "trunk" for name in [body.hips, *body.spine, *body.neck, body.head] if name}
    for key, name in body.limbs.items():
        slot, _, side = key.partition(".")
        out[name] = ("arm." if slot in bone_mapping.ARM_KEYS else "leg.") + side
    for key, names in body.fingers.items():
        for name in names:
            out[name] = "fingers." + key.partition(".")[2]
    for key, name in body.metacarpals.items():
        out[name] = "fingers." + key.partition(".")[2]
    return out


def kept_bones(names, parents, body: bone_mapping.Body, chains: list[ChainPose], by_user=None) -> list[int]:
    """The target bones (indices, ascending) on a kept chain: each bone is on the chain of its nearest
    labelled ancestor or itself (a twist bone on its limb's, an unlabelled bone between the hips and the
    chest on the trunk's, anything under a hand not labelled on that hand's fingers'). by_user: only those
    on chains the user set (True) or Auto decided (False); None: both."""
    labels = chain_of_labels(body)
    hands = {body.limbs.get(f"hand.{s}"): f"fingers.{s}" for s in bone_mapping.SIDES}
    modes = {c.chain: c.mode for c in chains if by_user is None or c.by_user == by_user}
    kept = []
    for b, name in enumerate(names):
        chain, up = labels.get(name), parents[b]
        while chain is None and up >= 0:
            chain = hands.get(names[up]) or labels.get(names[up])
            up = parents[up]
        if chain is not None and modes.get(chain) == "KEEP":
            kept.append(b)
    return kept
