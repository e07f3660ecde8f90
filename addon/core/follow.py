"""Bones that follow other bones of the same rig (numpy, no bpy): a game rig's IK and prop bones, keyed to
stand where the body parts they stand for stand. Unreal's mannequin names them: ik_foot_l and ik_foot_r
(under ik_foot_root) follow the feet, ik_hand_gun (under ik_hand_root) the right hand, ik_hand_l and
ik_hand_r (under ik_hand_gun) the hands; an engine's IK reads them. A follower keeps its rest offset from
the bone it follows: its armature-space pose is the followed bone's pose times the followed bone's rest
inverse times its own rest, whatever its parents do."""
from __future__ import annotations

import re

import numpy as np

from . import bone_mapping, native_state
from .rig_data import RigData
from .root_motion import local_channels
from .rotation_channels import conjugate, multiply, rotate_each as rotate

# A follower's name (any namespace or prefix cut, any case) and the labelled body part it follows.
FOLLOWERS = (("ik_foot_l", "foot.L"), ("ik_foot_r", "foot.R"), ("ik_hand_gun", "hand.R"),
             ("ik_hand_l", "hand.L"), ("ik_hand_r", "hand.R"))
_NAMESPACE = re.compile(r"^.*:")


def followers(rig: RigData, body: bone_mapping.Body) -> dict[int, int]:
    """{follower bone: the bone it follows} by index, for the followers this rig has and whose body part is
    labelled; parents first."""
    wanted = dict(FOLLOWERS)
    out = {}
    for b, name in enumerate(rig.names):
        part = wanted.get(_NAMESPACE.sub("", name).lower())
        followed = body.limbs.get(part) if part else None
        if followed in rig:
            out[b] = rig.index(followed)
    return out


def follow(rig: RigData, pairs: dict[int, int], rotations, locations, posed) -> None:
    """Writes each follower's pose channels (rotations (frames, 4B), locations (frames, 3B), in place) so
    that it stands where pairs says, given the rig's armature-space pose posed = (orientations (frames, 4B),
    heads (frames, 3B)) of the pose channels as they are; followers parents first, the rig posed again
    after each (a follower under a follower: ik_hand_l under ik_hand_gun)."""
    orientations, heads = posed
    rest = rig.unit_rest
    block = lambda a, b, n: a[:, n * b:n * b + n]  # noqa: E731
    for bone in sorted(pairs):
        followed = pairs[bone]
        offset = multiply(conjugate(rest[followed]), rest[bone])  # the follower's rest in the followed bone's
        at = rotate(conjugate(rest[followed])[None], (rig.heads[bone] - rig.heads[followed])[None])[0]
        turn = block(orientations, followed, 4)
        wanted_rot = multiply(turn, np.broadcast_to(offset, turn.shape))
        wanted_head = block(heads, followed, 3) + rotate(turn, np.broadcast_to(at, (len(turn), 3)))
        parent = rig.parents[bone]
        parent_pose = (block(orientations, parent, 4), block(heads, parent, 3)) if parent >= 0 else (None, None)
        basis, location = local_channels(rest, rig.heads, bone, parent, *parent_pose, wanted_rot, wanted_head)
        rotations[:, 4 * bone:4 * bone + 4] = basis
        locations[:, 3 * bone:3 * bone + 3] = location
        if any(rig.is_below(other, bone) for other in pairs if other != bone):
            orientations, heads = native_state.native().armature_pose(rig.native, rotations, locations)
