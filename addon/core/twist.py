"""Twist bones: each leaf twist bone beside a limb takes its share of the limb's twist (numpy, no bpy).
The retarget's fingers-and-twist stage: docs/retargeting.md, Twist bones."""
from __future__ import annotations

import numpy as np

from . import bone_mapping, rotation_channels
from .rig_data import RigData

# Each twist bone's limb and the bone below the joint whose twist it takes.
_TWIST_BELOW = {"upper_arm": "forearm", "forearm": "hand", "thigh": "shin", "shin": "foot"}


def _along(rig: RigData, bone: int, limb: int) -> float:
    """Where a bone's head lies along a limb, 0 at its head and 1 at its tail."""
    axis = rig.tails[limb] - rig.heads[limb]
    return float(np.clip(np.dot(rig.heads[bone] - rig.heads[limb], axis) / max(float(axis @ axis), 1e-30), 0.0, 1.0))


def share_twist(rig: RigData, body: bone_mapping.Body, rotations, mapped) -> None:
    """Gives each leaf twist bone beside a limb (Body.twists) its share of the limb's twist about the limb's
    axis, by where it lies along the limb: on an upper limb (upper arm, thigh), whose twist turns at the
    joint above it, the bone counters the limb's own twist fully at the joint and not at all at the far end;
    on a lower limb (forearm, shin), whose twist runs along it to the hand or foot, it takes none of the
    hand's or foot's twist at the near end and all of it at the far end. Writes the twist bones' basis
    rotations (frames, 4B) in place; mapped twist bones (indices) keep what the map gave them."""
    for name, limb_key in body.twists.items():
        limb_name, (part, side) = body.limbs.get(limb_key), limb_key.split(".")
        if name not in rig or limb_name not in rig or rig.index(name) in mapped:
            continue
        twist, limb = rig.index(name), rig.index(limb_name)
        along = _along(rig, twist, limb)
        if part in ("upper_arm", "thigh"):
            angle = -(1.0 - along) * rotation_channels.twist_angles(rotations[:, 4 * limb:4 * limb + 4], [0, 1, 0])
        else:
            below = body.limbs.get(f"{_TWIST_BELOW[part]}.{side}")
            if below not in rig:
                continue
            b = rig.index(below)
            angle = along * rotation_channels.twist_angles(rotations[:, 4 * b:4 * b + 4], [0, 1, 0])
        # The limb's axis (its Y) in the twist bone's own rest frame.
        local_axis = rotation_channels.rotate(
            rotation_channels.multiply(rotation_channels.conjugate(rig.rest[twist]), rig.rest[limb]),
            np.array([0.0, 1.0, 0.0]))
        rotations[:, 4 * twist:4 * twist + 4] = np.concatenate(
            [np.cos(angle / 2)[:, None], np.sin(angle / 2)[:, None] * local_axis], axis=1)
