"""object_motion (no Blender): an object's motion composed into its top bones, and a track as the object's
keys, against 4x4 matrices composed in the test (Blender's pose = rest @ basis, world = object @ pose) and
scipy's rotations."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from core import object_motion as om

# Float64 products of a few unit quaternions and 4x4 matrices of metre-sized numbers: about 1e-15 each;
# a thousand times that leaves room for the handful of products and nothing for a wrong formula (which is off
# by the motion itself, centimetres at least).
EXACT = 1e-12


def wxyz(r: Rotation) -> np.ndarray:
    return np.roll(r.as_quat(), 1, axis=-1)


def matrix(q, t, s=1.0) -> np.ndarray:
    """(n, 4, 4) from quaternions (n, 4) w x y z, translations (n, 3) and a uniform scale, by scipy."""
    q = np.atleast_2d(q)
    out = np.tile(np.eye(4), (len(q), 1, 1))
    out[:, :3, :3] = s * Rotation.from_quat(np.roll(q, -1, axis=-1)).as_matrix()
    out[:, :3, 3] = t
    return out


def test_quaternions_and_matrices_agree_with_scipy_everywhere():
    # Random turns, and the near-half-turns where a trace-only formula divides by almost zero.
    turns = Rotation.concatenate([Rotation.random(200, random_state=3),
                                  Rotation.from_rotvec(np.pi * np.eye(3)), Rotation.from_rotvec([[0, 0, 3.14159]])])
    q = wxyz(turns)
    q *= np.where(q[:, :1] < 0, -1.0, 1.0)
    assert np.abs(om.rotation_matrices(q) - turns.as_matrix()).max() < EXACT
    back = om.quaternions(turns.as_matrix())
    # q and -q are one turn: compare up to sign where w = 0.
    assert np.minimum(np.abs(back - q).max(axis=1), np.abs(back + q).max(axis=1)).max() < EXACT


def test_relative_motion_is_the_reference_inverse_times_the_world():
    rng = np.random.default_rng(1)
    reference = matrix(wxyz(Rotation.from_euler("x", 90, degrees=True)), [1.0, 2.0, 0.5], s=0.01)[0]
    turns, shifts = wxyz(Rotation.random(30, random_state=4)), rng.normal(size=(30, 3))
    worlds = reference @ matrix(turns, shifts)
    rotations, translations = om.relative_motion(worlds, reference, "the source 'A'", np.arange(30.0))
    assert np.abs(matrix(rotations, translations) - matrix(turns, shifts)).max() < EXACT


def test_a_change_of_scale_is_refused_naming_the_object_and_frame():
    reference = np.eye(4)
    worlds = matrix(np.tile([1.0, 0, 0, 0], (3, 1)), np.zeros((3, 3)))
    worlds[2, :3, :3] *= 1.5
    with pytest.raises(ValueError, match=r"the source 'A' changes its scale over the clip .* at frame 12"):
        om.relative_motion(worlds, reference, "the source 'A'", np.array([10.0, 11.0, 12.0]))


def _pose(rest, head, basis, location):
    """A top bone's armature-space pose as Blender makes it: rest matrix @ basis matrix."""
    return matrix(np.broadcast_to(rest, basis.shape), head) @ matrix(basis, location)


def test_composed_top_bones_pose_as_the_object_moved_them():
    """Every top bone's new pose is motion @ its old pose (their children follow unchanged); other bones'
    channels stay as they were."""
    n = 25
    rest = wxyz(Rotation.random(3, random_state=5))
    heads = np.array([[0.0, 0.1, 0.9], [0.3, 0.0, 1.0], [0.0, 0.0, 0.0]])
    parents = [-1, 0, -1]  # two top bones (say hips and an IK bone), one child
    basis = wxyz(Rotation.random(3 * n, random_state=6)).reshape(n, 12)
    locations = np.random.default_rng(7).normal(size=(n, 9))
    motion = wxyz(Rotation.random(n, random_state=8)), np.random.default_rng(9).normal(size=(n, 3))
    new_basis, new_locations = om.compose_tops(rest, heads, parents, basis, locations, *motion)
    for b in (0, 2):
        before = _pose(rest[b], heads[b], basis[:, 4 * b:4 * b + 4], locations[:, 3 * b:3 * b + 3])
        after = _pose(rest[b], heads[b], new_basis[:, 4 * b:4 * b + 4], new_locations[:, 3 * b:3 * b + 3])
        assert np.abs(after - matrix(*motion) @ before).max() < EXACT
    assert np.array_equal(new_basis[:, 4:8], basis[:, 4:8]) and np.array_equal(new_locations[:, 3:6], locations[:, 3:6])


def test_object_keys_move_the_object_by_the_track_in_its_own_space():
    """matrix_basis' = matrix_basis @ track, with a delta rotation in front of the keyed one (Blender's
    order) and a uniform scale."""
    n = 20
    location, keyed, delta, scale = np.array([1.0, -2.0, 0.3]), wxyz(Rotation.from_euler("z", 30, degrees=True)), \
        wxyz(Rotation.from_euler("x", 90, degrees=True)), 0.01
    track = wxyz(Rotation.from_euler("z", np.linspace(0, 200, n), degrees=True)), \
        np.column_stack([np.linspace(0, 300, n), np.linspace(0, -50, n), np.zeros(n)])
    full = Rotation.from_quat(np.roll(delta, -1)) * Rotation.from_quat(np.roll(keyed, -1))
    placement = (wxyz(full), scale)
    locations, rotations = om.object_keys(location, keyed, placement, *track)
    before = matrix(wxyz(full), location, scale)
    after = matrix(om.quaternions(np.einsum("ij,njk->nik", Rotation.from_quat(np.roll(delta, -1)).as_matrix(),
                                            om.rotation_matrices(rotations))), locations, scale)
    assert np.abs(after - before @ matrix(*track)).max() < EXACT
