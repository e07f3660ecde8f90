"""The characters the tests make from Mixamo's (tests/common/made_characters.py), held to the clip's own forward
kinematics (san_protocol's numpy): every joint but the one moved or taken out stands where the clip put it."""
import os

import numpy as np
import pytest

import made_characters as made
import san_protocol as sp

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
GOBLIN = os.path.join(ROOT, "tests", "data", "mixamo_excerpts", "Goblin_m", "Jumping_mid.bvh")
# Written with six decimals (cm): each offset and angle rounds by up to 5e-7, some twenty joints from the root
# to a fingertip over a body 1.5 m tall carry it to about 1e-4 cm at most; bounded at 1e-3 cm.
WRITTEN = 1e-3


@pytest.fixture(scope="module")
def goblin():
    return sp.read_bvh(GOBLIN)


def _positions(bvh, names):
    return sp.clip_positions(bvh)[:, [bvh.index(n) for n in names]]


def test_a_split_joint_moved_leaves_every_other_joint_where_the_clip_puts_it(goblin):
    moved = made.with_joint_moved(goblin, "Spine1_split", [0.0, 0.0, 0.0])
    others = [n for n in goblin.names if n != "Spine1_split"]
    np.testing.assert_allclose(_positions(moved, others), _positions(goblin, others), atol=1e-9)
    assert np.linalg.norm(moved.offsets[moved.index("Spine1_split")]) == 0.0


def test_a_split_joint_taken_out_leaves_every_other_joint_where_the_clip_puts_it(goblin):
    fewer = made.without_joint(goblin, "LeftShoulder_split")
    others = [n for n in goblin.names if n != "LeftShoulder_split"]
    assert fewer.names == others and fewer.values.shape[1] == goblin.values.shape[1] - 3
    assert fewer.parents[fewer.index("LeftArm")] == fewer.index("LeftShoulder")
    np.testing.assert_allclose(_positions(fewer, others), _positions(goblin, others), atol=1e-9)


def test_a_turned_joint_is_refused(goblin):
    with pytest.raises(ValueError, match="Spine1 turns"):
        made.with_joint_moved(goblin, "Spine1", [0.0, 1.0, 0.0])


def test_a_written_character_reads_back_as_it_was(goblin, tmp_path):
    part = made.frames(made.without_joint(goblin, "Spine1_split"), 2, 5)
    path = str(tmp_path / "made.bvh")
    made.write_bvh(part, path)
    back = sp.read_bvh(path)
    assert back.names == part.names and back.parents == part.parents and back.channels == part.channels
    assert back.values.shape == (5, part.values.shape[1]) and back.frame_time == pytest.approx(part.frame_time)
    np.testing.assert_allclose(sp.clip_positions(back), sp.clip_positions(part), atol=WRITTEN)
    np.testing.assert_allclose(sp.clip_positions(back)[0], sp.clip_positions(goblin)[2][
        [goblin.index(n) for n in part.names]], atol=WRITTEN)
