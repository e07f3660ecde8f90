"""core/props: which bones are props (no labelled body part, under a hand or nothing labelled) and which of
them move in a clip, on the Mixamo-named sample with a gun under its right hand and a quiver on its back."""
import dataclasses

import numpy as np
from scipy.spatial.transform import Rotation

import characters
from core import props
from plain_rigs import from_spec


def _rig():
    spec = characters.MIXAMO_T
    at = {b.canonical: b for b in spec.bones}
    hand = at["hand.R"]
    extra = (characters.BoneSpec("Gun", "prop", hand.name, hand.tail, (hand.tail[0], hand.tail[1] - 0.3,
                                                                           hand.tail[2]), 0.0),
             characters.BoneSpec("Quiver", "prop", at["spine.2"].name, (0.0, 0.1, 1.3), (0.0, 0.1, 1.6), 0.0))
    return from_spec(dataclasses.replace(spec, bones=spec.bones + extra))


def _still(rig, frames=20):
    basis = np.tile([1.0, 0.0, 0.0, 0.0], (frames, len(rig)))
    return basis, np.zeros((frames, 3 * len(rig)))


def test_a_prop_hangs_from_a_hand_or_from_no_labelled_part():
    rig = _rig()
    found = [rig.names[b] for b in props.candidates(rig, roots=(rig.index(rig.body.hips),))]
    # The quiver hangs from the spine, a labelled part that is no hand: it rides with the body, no prop.
    assert found == ["Gun"]


def test_a_bone_moves_when_its_channels_move_beyond_rounding():
    rig = _rig()
    gun = rig.index("Gun")
    basis, locations = _still(rig)
    # float32 keys' rounding (6e-8) on the turn and the shift: still.
    basis[:, 4 * gun:4 * gun + 4] = np.roll(Rotation.from_rotvec(
        np.outer(np.linspace(0, 6e-8, len(basis)), [1.0, 0.0, 0.0])).as_quat(), 1, axis=1)
    locations[:, 3 * gun] = np.linspace(0.0, 6e-8, len(basis))
    assert props.moving(rig, [gun], basis, locations) == []
    turned = basis.copy()
    turned[:, 4 * gun:4 * gun + 4] = np.roll(Rotation.from_rotvec(
        np.outer(np.linspace(0, 2 * props.MOVES_TURN, len(basis)), [0.0, 0.0, 1.0])).as_quat(), 1, axis=1)
    assert props.moving(rig, [gun], turned, locations) == [gun]
    slid = locations.copy()
    slid[:, 3 * gun + 1] = np.linspace(0.0, 2 * props.MOVES_SHIFT * rig.size, len(basis))
    assert props.moving(rig, [gun], basis, slid) == [gun]
