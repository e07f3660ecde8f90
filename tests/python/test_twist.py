"""core/twist: a twist bone's share of its limb's twist, on a plain-data arm, against scipy."""
import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import characters
from core import twist
from plain_rigs import from_spec


def _with_twist_bones():
    """Unreal's sample with a twist bone a quarter down each left forearm and upper arm (leaves)."""
    spec = characters.UNREAL_A
    bones = list(spec.bones)
    for limb, name in (("forearm.L", "lowerarm_twist_01_l"), ("upper_arm.L", "upperarm_twist_01_l")):
        bone = next(b for b in bones if b.canonical == limb)
        head = np.array(bone.head) + 0.25 * (np.array(bone.tail) - np.array(bone.head))
        tail = head + 0.1 * (np.array(bone.tail) - np.array(bone.head))
        bones.append(characters.BoneSpec(name, f"twist.{limb}", bone.name, tuple(head), tuple(tail), bone.roll))
    return from_spec(dataclasses.replace(spec, bones=tuple(bones)))


def _about(axis, angles):
    return np.roll(Rotation.from_rotvec(np.outer(angles, axis)).as_quat(), 1, axis=1)


@pytest.mark.parametrize("angle", [0.3, -1.1])
def test_forearm_twist_bone_takes_its_share_of_the_hands_twist(angle):
    rig = _with_twist_bones()
    body = rig.body
    assert body.twists == {"lowerarm_twist_01_l": "forearm.L", "upperarm_twist_01_l": "upper_arm.L"}
    rotations = np.tile([1.0, 0.0, 0.0, 0.0], (2, len(rig)))
    hand, upper = rig.index(body.limbs["hand.L"]), rig.index(body.limbs["upper_arm.L"])
    rotations[:, 4 * hand:4 * hand + 4] = _about([0.0, 1.0, 0.0], [angle, 2 * angle])
    rotations[:, 4 * upper:4 * upper + 4] = _about([0.0, 1.0, 0.0], [angle, -angle])
    twist.share_twist(rig, body, rotations, mapped=set())
    for name, share, turns in (("lowerarm_twist_01_l", 0.25, [angle, 2 * angle]),
                               ("upperarm_twist_01_l", -0.75, [angle, -angle])):
        b = rig.index(name)
        # The twist bone lies along its limb with the same roll: the limb's Y is its own Y.
        expected = _about([0.0, 1.0, 0.0], share * np.array(turns))
        got = rotations[:, 4 * b:4 * b + 4]
        assert np.abs(np.abs(np.sum(got * expected, axis=1)) - 1.0).max() < 1e-12, name


def test_a_mapped_twist_bone_keeps_what_the_map_gave_it():
    rig = _with_twist_bones()
    rotations = np.tile([1.0, 0.0, 0.0, 0.0], (1, len(rig)))
    hand = rig.index(rig.body.limbs["hand.L"])
    rotations[:, 4 * hand:4 * hand + 4] = _about([0.0, 1.0, 0.0], [0.5])
    before = rotations.copy()
    twist.share_twist(rig, rig.body, rotations, mapped={rig.index("lowerarm_twist_01_l"),
                                                        rig.index("upperarm_twist_01_l")})
    assert np.array_equal(rotations, before)
