"""core.retarget_inputs: a retarget's inputs as plain data: the bone pairs checked against both rigs, the bones
written, and the source's clip posed natively as the tests' own forward kinematics (rig_fk) poses it."""
import characters
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import rig_fk
from core.retarget_inputs import SourceClip, bone_pairs, written_bones
from core.retarget_options import RetargetOptions
from plain_rigs import from_spec


@pytest.fixture(scope="module")
def rigs():
    return from_spec(characters.MIXAMO_T), from_spec(characters.RIGIFY_A)


def test_bone_pairs_are_the_map_s_each_bone_checked(rigs):
    source, target = rigs
    assert bone_pairs({source.names[0]: target.names[0]}, source, target) == [(source.names[0], target.names[0])]
    assert bone_pairs([(source.names[1], target.names[1]), ("", target.names[2])], source, target) == \
        [(source.names[1], target.names[1])]
    with pytest.raises(ValueError, match="'nope' is not a bone of the source"):
        bone_pairs({"nope": target.names[0]}, source, target)
    with pytest.raises(ValueError, match="not a bone of the target"):
        bone_pairs({source.names[0]: "nope"}, source, target)
    with pytest.raises(ValueError, match="mapped twice"):
        bone_pairs([(source.names[0], target.names[0]), (source.names[1], target.names[0])], source, target)
    with pytest.raises(ValueError, match="no common bones"):
        bone_pairs({}, source, target)
    with pytest.raises(ValueError, match="pairs"):
        bone_pairs([(source.names[0],)], source, target)


def test_no_map_is_the_automatic_one(rigs):
    source, target = rigs
    pairs = dict(bone_pairs(None, source, target))
    assert pairs[source.body.hips] == target.body.hips
    assert pairs[source.body.limbs["hand.L"]] == target.body.limbs["hand.L"]


def test_the_bones_written_are_the_parts_or_the_bones_chosen(rigs):
    _, target = rigs
    assert written_bones(target, RetargetOptions()) is None
    arm = written_bones(target, RetargetOptions(parts=("arm.L",)))
    assert target.index(target.body.limbs["forearm.L"]) in arm
    assert target.index(target.body.limbs["thigh.L"]) not in arm
    assert written_bones(target, RetargetOptions(bones=(target.names[3],))) == {3}
    with pytest.raises(ValueError, match="'nope' is not a bone of the target"):
        written_bones(target, RetargetOptions(bones=("nope",)))


def test_a_clip_is_posed_as_the_independent_forward_kinematics(rigs, core_native):
    source, _ = rigs
    frames = 6
    basis = np.roll(Rotation.random(frames * len(source), random_state=3).as_quat(), 1, axis=1).reshape(frames, -1)
    locations = np.zeros((frames, 3 * len(source)))
    locations[:, :3] = np.random.default_rng(4).normal(scale=0.1, size=(frames, 3))
    clip = SourceClip(source, "clip", np.arange(1.0, frames + 1), 30.0, basis, locations).posed()
    _, heads, _ = rig_fk.pose(list(source.parents), source.unit_rest, source.heads, source.lengths, basis,
                              locations[:, :3])
    # Doubles through the deepest chain (a fingertip, some twenty rotations): ulps of the 1.8 m body.
    assert np.abs(clip.heads.reshape(frames, -1, 3) - heads).max() < 1e-13
    assert clip.rotations.shape == (frames, 4 * len(source))
