"""core/facing: which way a rig faces and the quarter turn that lays a source on a target, on the sample
characters as plain data, against scipy's rotations and hand-derived directions."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import characters
from core import facing
from core.rig_data import Pose
from plain_rigs import from_spec, placed

UP = np.array([0.0, 0.0, 1.0])


def _turned(spec, degrees):
    """The character's bones turned about Z in its own space (it faces another way), placed as is."""
    rig = from_spec(spec)
    turn = Rotation.from_euler("z", degrees, degrees=True)
    rig.heads[:], rig.tails[:] = turn.apply(rig.heads), turn.apply(rig.tails)
    rig.rest[:] = np.roll((turn * Rotation.from_quat(np.roll(rig.rest, -1, axis=1))).as_quat(), 1, axis=1)
    return rig


def test_forward_is_where_a_blender_character_faces():
    # Left hip at +X, right at -X, Z up: Blender's characters face -Y.
    assert np.allclose(facing.forward(np.array([0.1, 0, 1]), np.array([-0.1, 0, 1]), UP), [0, -0.2, 0])


@pytest.mark.parametrize("degrees", [0, 10, 80, 100, 179, -100])
def test_turn_to_rounds_to_a_quarter_turn(degrees):
    direction = Rotation.from_euler("z", degrees, degrees=True).apply([1.0, 0.0, 0.0])
    q = facing.turn_to(direction, np.array([1.0, 0.0, 0.0]), UP)
    quarter = -90 * np.round(degrees / 90)
    assert np.allclose(np.abs(q @ np.roll(Rotation.from_euler("z", quarter, degrees=True).as_quat(), 1)), 1.0)


def test_a_zero_pose_faces_nowhere_and_a_t_pose_does():
    rig = from_spec(characters.MIXAMO_T)
    bones = list(range(len(rig)))
    assert not facing.faces_nowhere(rig, Pose.rest(rig), bones)
    zero = Pose(rig.rest, np.array([[0.0, 0.0, 0.1 * i] for i in range(len(rig))]), rig.lengths)
    assert facing.faces_nowhere(rig, zero, bones)


@pytest.mark.parametrize("degrees", [0, 90, 180, 270])
def test_placement_turns_the_source_to_face_the_targets_way(degrees):
    """A source facing another way (turned by degrees about up) is turned back: the placement's space is the
    inverse turn (scipy), whatever the two rigs' proportions."""
    source = _turned(characters.RIGIFY_A, degrees)
    target = from_spec(characters.MIXAMO_T)
    names = characters.MIXAMO_T.canonical
    pairs = [(source.index(b.name), target.index(names[b.canonical]))
             for b in characters.RIGIFY_A.bones if b.canonical in names]
    roots = (source.index(source.body.hips), target.index(target.body.hips))
    placed_ = facing.placement(facing.Standing(source, source.body, Pose.rest(source)),
                               facing.Standing(target, target.body, Pose.rest(target)), pairs, roots, True)
    expected = np.roll(Rotation.from_euler("z", -degrees, degrees=True).as_quat(), 1)
    assert abs(abs(placed_.space @ expected) - 1.0) < 1e-12
    assert np.allclose(placed_.up, UP) and np.allclose(placed_.source_up, UP, atol=1e-12)
    # Without thighs the joints' fit gives the same quarter turn.
    fitted = facing.fitted_turn(np.array([1.0, 0, 0, 0]), Pose.rest(source), Pose.rest(target), pairs, roots, UP)
    assert abs(abs(fitted @ expected) - 1.0) < 1e-12


def test_placement_carries_the_objects_rotations():
    """Two objects turned differently in the world: space is target world^-1 * source world, up the world's Z
    in each armature space."""
    a, b = Rotation.from_euler("x", 90, degrees=True), Rotation.from_euler("z", 30, degrees=True)
    source, target = from_spec(characters.MIXAMO_T, placed(a)), from_spec(characters.MIXAMO_T, placed(b))
    roots = (source.index(source.body.hips),) * 2
    found = facing.placement(facing.Standing(source, source.body, Pose.rest(source)),
                             facing.Standing(target, target.body, Pose.rest(target)), [], roots, False)
    expected = np.roll((b.inv() * a).as_quat(), 1)
    assert abs(abs(found.space @ expected) - 1.0) < 1e-12
    assert np.allclose(found.source_up, a.inv().apply(UP), atol=1e-12)
