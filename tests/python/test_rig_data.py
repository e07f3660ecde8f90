"""core/rig_data: a rig at rest as plain data, its hierarchy, placement and native rig, against numpy,
scipy and the independent forward kinematics of tests/common/rig_fk.py."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import characters
import rig_fk
from core.rig_data import Pose, RigData
from plain_rigs import from_spec, placed


def _chain():
    """Four bones: a root, two in a chain under it, and a side branch."""
    heads = np.array([[0, 0, 0], [0, 0, 1], [0, 0, 2], [0.5, 0, 1]], dtype=float)
    tails = np.array([[0, 0, 1], [0, 0, 2], [0, 0, 3], [1, 0, 1]], dtype=float)
    return RigData("chain", ("a", "b", "c", "d"), (-1, 0, 1, 0), np.tile([1.0, 0, 0, 0], (4, 1)), heads, tails,
                   np.ones(4), (False, True, True, False))


def test_hierarchy():
    rig = _chain()
    assert rig.ancestors(2) == [1, 0] and rig.ancestors(0) == []
    assert rig.is_below(2, 0) and rig.is_below(2, 2) and not rig.is_below(3, 1)
    assert rig.top(2) == 0 and rig.depths == [0, 1, 2, 1]
    assert rig.index("d") == 3 and "d" in rig and "e" not in rig and len(rig) == 4
    # The box around heads and tails: 1 x 0 x 3.
    assert rig.size == pytest.approx(np.sqrt(10.0), abs=1e-15)


def test_bad_rigs_say_what_is_wrong():
    rig = _chain()
    with pytest.raises(ValueError, match="parents first"):
        RigData("x", ("a", "b"), (1, -1), rig.rest[:2], rig.heads[:2], rig.tails[:2], np.ones(2), (False, False))
    with pytest.raises(ValueError, match=r"rig 'x': heads must be \(2, 3\)"):
        RigData("x", ("a", "b"), (-1, 0), rig.rest[:2], rig.heads[:1], rig.tails[:2], np.ones(2), (False, False))
    scaled = from_spec(characters.MIXAMO_T, np.diag([1.0, 2.0, 1.0, 1.0]))
    with pytest.raises(ValueError, match="non-uniform scale"):
        scaled.scale


@pytest.mark.parametrize("seed", range(3))
def test_placement_up_and_heights(seed):
    """up is world Z seen from the armature: the object's rotation undone (scipy); heights go through the
    object's matrix both ways."""
    turn = Rotation.random(random_state=seed)
    rig = from_spec(characters.MIXAMO_T, placed(turn, 0.01, (0.3, -0.2, 0.5)))
    assert np.allclose(rig.up, turn.inv().apply([0.0, 0.0, 1.0]), atol=1e-14)
    assert rig.scale == pytest.approx(0.01, rel=1e-14)
    assert rig.armature_height_to_world(rig.world_height_to_armature(1.25)) == pytest.approx(1.25, abs=1e-14)
    assert rig.world_height_to_armature(0.5) == pytest.approx(0.0, abs=1e-14)


def test_mapping_rig_stands_upright():
    """An FBX-like placement (armature Y up, the object turned 90 degrees about X) reads upright."""
    plain = from_spec(characters.MIXAMO_T)
    turn = Rotation.from_euler("x", 90, degrees=True)
    lying = from_spec(characters.MIXAMO_T, placed(turn, 0.01))
    lying.heads[:], lying.tails[:] = turn.inv().apply(plain.heads) * 100, turn.inv().apply(plain.tails) * 100
    upright = lying.mapping_rig(upright=True)
    assert np.allclose(upright.heads, plain.heads * 100, atol=1e-9)
    assert lying.body.hips == plain.body.hips and lying.body.limbs == plain.body.limbs


def test_native_rig_of_some_bones_poses_as_the_independent_fk(core_native):
    native = core_native
    """The native rig of a subset (an arm under the chest, its parents outside the subset cut) poses as
    rig_fk, the tests' own forward kinematics, over random rotations."""
    rig = from_spec(characters.RIGIFY_A)
    arm = [rig.index(n) for n in rig.names if n.endswith(".L") and ("arm" in n or "hand" in n)]
    basis = np.roll(Rotation.random(5 * len(arm), random_state=7).as_quat(), 1, axis=1).reshape(5, -1)
    rotations, heads = native.armature_pose(rig.native_rig(arm), np.ascontiguousarray(basis),
                                            np.zeros((5, 3 * len(arm))))
    where = {b: i for i, b in enumerate(arm)}
    parents = [where.get(rig.parents[b], -1) for b in arm]
    _, fk_heads, _ = rig_fk.pose(parents, rig.unit_rest[arm], rig.heads[arm], rig.lengths[arm], basis)
    # Doubles through a chain of three rotations: a few ulps of the arm's 0.6 m.
    assert np.abs(heads.reshape(5, -1, 3) - fk_heads).max() < 1e-14


def test_rest_pose_points():
    rig = from_spec(characters.UNREAL_A)
    rest = Pose.rest(rig)
    # A bone's tail lies along its rest Y axis at its length (the edit bone's definition).
    assert np.abs(rest.tails - rig.tails).max() < 1e-14
    assert rest.points.shape == (2 * len(rig), 3)
