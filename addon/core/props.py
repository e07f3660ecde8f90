"""A prop bone follows the source's prop in a space of the user's choosing (numpy, no bpy): a mapped bone
that is no body part (a weapon under a hand, a prop under the root) moves from its own rest as the
source's moves from its rest relative to a reference: the hand it hangs from ("hand"), the hips ("root")
or the armature itself ("world"), the reference's motion being the target's own and the move scaled as
the motion is. "bone" leaves it to the retarget, which turns it as any mapped bone (its direction). A prop
bone connected to its parent can only turn (Blender ignores a connected bone's location)."""
from __future__ import annotations

import numpy as np

from . import retarget_parts
from .rig_data import RigData
from .root_motion import local_channels
from .rotation_channels import conjugate, multiply, rotate_each as rotate

SPACES = (
    ("bone", "Bone", "Turned as any mapped bone: pointing where the source's points"),
    ("hand", "Hand", "Moving in its hand as the source's moves in the source's hand"),
    ("root", "Root", "Moving about the hips as the source's moves about the source's, scaled"),
    ("world", "World", "Moving in the armature's space as the source's does, scaled"),
)


# A bone "moves" in a clip when its channels turn it more than this from their first frame (radians), or
# move it more than this part of the rig's size: far above float32 keys' rounding (1e-7), far below a
# prop's handling (degrees, centimetres).
MOVES_TURN = 1e-4
MOVES_SHIFT = 1e-5


def candidates(rig: RigData, roots=()) -> list[int]:
    """The bones (indices) that no label names and that hang from no labelled body part but a hand (a rifle
    under a hand, a prop under the root), roots (the hips, a floor root) aside."""
    body = rig.body
    labelled = set(body.limbs.values()) | set(body.twists) | set(body.metacarpals.values()) | {
        n for names in body.fingers.values() for n in names} | {body.hips, body.root}
    parts = retarget_parts.part_of_bones(rig.names, rig.parents, body)
    return [b for b, part in enumerate(parts) if rig.names[b] not in labelled
            and (part == "other" or part.startswith("hand.")) and b not in roots]


def moving(rig: RigData, bones, basis, locations) -> list[int]:
    """Those of bones whose channels (basis (n, 4B), locations (n, 3B)) move over the clip (MOVES_*)."""
    out = []
    for b in bones:
        q = basis[:, 4 * b:4 * b + 4]
        turn = 2.0 * np.arcsin(np.clip(np.linalg.norm(multiply(conjugate(q[:1]), q)[:, 1:], axis=1), 0.0, 1.0))
        shift = np.ptp(locations[:, 3 * b:3 * b + 3], axis=0).max(initial=0.0)
        if turn.max(initial=0.0) > MOVES_TURN or shift > MOVES_SHIFT * rig.size:
            out.append(b)
    return out


def _from_rest(rot, heads, rest_rot, rest_head):
    """A bone's move from its rest, (q, t): a rest point p goes to q p + t. rot (n, 4), heads (n, 3)."""
    q = multiply(rot, np.broadcast_to(conjugate(rest_rot), rot.shape))
    return q, heads - rotate(q, np.broadcast_to(rest_head, heads.shape))


def wanted(source: RigData, target: RigData, pairs, source_pose, target_pose, space, scale):
    """{target prop: (orientations (n, 4), heads (n, 3))} armature space, for pairs {target prop: (source
    prop, source reference or -1, target reference or -1)}; poses (orientations (n, 4B), heads (n, 3B));
    space: the turn from the source's armature to the target's; scale: the motion's."""
    block = lambda pose, b: (pose[0][:, 4 * b:4 * b + 4], pose[1][:, 3 * b:3 * b + 3])  # noqa: E731
    out = {}
    for prop, (source_prop, source_ref, target_ref) in pairs.items():
        q_s, t_s = _from_rest(*block(source_pose, source_prop), source.unit_rest[source_prop],
                              source.heads[source_prop])
        n = len(q_s)
        if source_ref >= 0:
            q_r, t_r = _from_rest(*block(source_pose, source_ref), source.unit_rest[source_ref],
                                  source.heads[source_ref])
            q_s, t_s = multiply(conjugate(q_r), q_s), rotate(conjugate(q_r), t_s - t_r)
        turn = np.broadcast_to(space, (n, 4))
        q_rel = multiply(multiply(turn, q_s), conjugate(turn))
        t_rel = scale * rotate(turn, t_s)
        if target_ref >= 0:
            q_t, t_t = _from_rest(*block(target_pose, target_ref), target.unit_rest[target_ref],
                                  target.heads[target_ref])
            q_rel, t_rel = multiply(q_t, q_rel), t_t + rotate(q_t, t_rel)
        out[prop] = (multiply(q_rel, np.broadcast_to(target.unit_rest[prop], (n, 4))),
                     rotate(q_rel, np.broadcast_to(target.heads[prop], (n, 3))) + t_rel)
    return out


def place(target: RigData, poses: dict, rotations, locations, target_pose) -> None:
    """The props' pose channels (rotations (n, 4B), locations (n, 3B), in place) that put each where poses
    says, under its parent as target_pose (armature space) has it; parents first."""
    orientations, heads = target_pose[0].copy(), target_pose[1].copy()
    for prop in sorted(poses):
        parent = target.parents[prop]
        parent_pose = (orientations[:, 4 * parent:4 * parent + 4], heads[:, 3 * parent:3 * parent + 3]) \
            if parent >= 0 else (None, None)
        basis, location = local_channels(target.unit_rest, target.heads, prop, parent, *parent_pose, *poses[prop])
        rotations[:, 4 * prop:4 * prop + 4] = basis
        locations[:, 3 * prop:3 * prop + 3] = location
        # A prop under a prop (a magazine in a rifle) is placed under its parent as now placed.
        orientations[:, 4 * prop:4 * prop + 4], heads[:, 3 * prop:3 * prop + 3] = poses[prop]
