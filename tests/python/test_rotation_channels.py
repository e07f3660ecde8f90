"""Rotation channels in every Blender rotation mode, against scipy.

Blender's Euler mode 'XYZ' rotates about X, then Y, then Z, about fixed axes:
scipy's extrinsic lower-case "xyz" with the angles in x, y, z order.
"""
import numpy as np
import pytest
from core import rotation_channels as rc
from rotations import quaternion_angles
from scipy.spatial.transform import Rotation


def _wxyz(rotation):
    xyzw = rotation.as_quat()
    return np.hstack([xyzw[:, 3:], xyzw[:, :3]])


def _smooth_rotations(n, seed=0):
    rng = np.random.default_rng(seed)
    vectors = np.cumsum(rng.normal(scale=0.3, size=(n, 3)), axis=0)
    return Rotation.from_rotvec(vectors)


@pytest.mark.parametrize("mode", rc.EULER_MODES)
def test_euler_modes_follow_blenders_fixed_axis_convention(native, mode):
    rng = np.random.default_rng(1)
    angles = rng.uniform(-np.pi, np.pi, size=(50, 3))
    expected = Rotation.from_euler(mode.lower(), angles[:, ["XYZ".index(a) for a in mode]])
    q = rc.to_quaternions(native, mode, angles)
    assert quaternion_angles(q, _wxyz(expected)).max() < 1e-12


@pytest.mark.parametrize("mode", rc.EULER_MODES + ('QUATERNION', 'AXIS_ANGLE'))
def test_round_trip_is_the_same_rotation_and_continuous(native, mode):
    rotations = _smooth_rotations(400)
    q = _wxyz(rotations)
    block = rc.from_quaternions(native, mode, q)
    assert block.shape == (400, rc.channel_property(mode)[1])
    back = rc.to_quaternions(native, mode, block)
    assert quaternion_angles(back, q).max() < 1e-12
    # Continuity: no channel jumps by more than the motion between rows allows.
    assert np.max(np.abs(np.diff(block, axis=0))) < 2.0


def test_euler_output_continues_from_the_previous_values(native):
    q = _wxyz(Rotation.from_euler("xyz", [[0.1, 0.2, 0.3]]))
    block = rc.from_quaternions(native, 'XYZ', q, previous=[0.1 + 2 * np.pi, 0.2, 0.3])
    np.testing.assert_allclose(block, [[0.1 + 2 * np.pi, 0.2, 0.3]], rtol=0, atol=1e-12)


def test_quaternion_output_keeps_the_hemisphere_of_the_previous_value(native):
    q = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]])
    out = rc.from_quaternions(native, 'QUATERNION', -q, previous=[1.0, 0.0, 0.0, 0.0])
    np.testing.assert_array_equal(out, q)


def test_axis_angle_of_identity_keeps_the_last_axis(native):
    q = np.array([[np.cos(0.1), 0.0, 0.0, np.sin(0.1)], [1.0, 0.0, 0.0, 0.0]])
    out = rc.from_quaternions(native, 'AXIS_ANGLE', q)
    np.testing.assert_allclose(out, [[0.2, 0.0, 0.0, 1.0], [0.0, 0.0, 0.0, 1.0]], rtol=0, atol=1e-12)


def test_zero_quaternion_names_the_frame(native):
    with pytest.raises(ValueError, match=r"bone 'Hips' rotation is zero or not finite at frame 7"):
        rc.to_quaternions(native, 'QUATERNION', np.zeros((2, 4)), "bone 'Hips' rotation", np.array([7.0, 8.0]))


def test_sign_continuity_flips_runs():
    q = np.array([[1.0, 0, 0, 0], [-1.0, 0, 0, 0], [-1.0, 0, 0, 0], [1.0, 0, 0, 0]])
    assert np.allclose(rc.sign_continuous(q)[:, 0], 1.0)


def test_quaternion_helpers_match_scipy():
    from scipy.spatial.transform import Rotation
    a, b = Rotation.random(50, random_state=1), Rotation.random(50, random_state=2)
    wxyz = lambda r: r.as_quat()[..., [3, 0, 1, 2]]  # noqa: E731
    product = rc.multiply(wxyz(a), wxyz(b))
    expected = wxyz(a * b)
    assert quaternion_angles(product, expected).max() < 1e-12
    np.testing.assert_allclose(rc.y_axes(wxyz(a)), a.apply([0.0, 1.0, 0.0]), atol=1e-12)
    points = np.random.default_rng(3).normal(size=(7, 3))
    np.testing.assert_allclose(rc.rotate(wxyz(a[0]), points), a[0].apply(points), atol=1e-12)
    np.testing.assert_allclose(rc.multiply(wxyz(a), rc.conjugate(wxyz(a)))[:, 0], 1.0, atol=1e-12)


@pytest.mark.parametrize("mode", rc.EULER_MODES + ('QUATERNION', 'AXIS_ANGLE'))
def test_many_bones_in_one_call_equal_one_call_per_bone(native, mode):
    """(n, k, 4) quaternions convert in one call per mode to what k separate calls give, each bone
    continuous from its own previous value (rest poses and identities that leave axis-angle's axis free
    included)."""
    k = 5
    q = np.stack([_wxyz(_smooth_rotations(120, seed)) for seed in range(k)], axis=1)
    q[:10, 2] = [1.0, 0.0, 0.0, 0.0]  # a bone at rest for a while
    q[::3, 1] *= -1.0  # hemisphere flips to undo
    previous = rc.from_quaternions(native, mode, _wxyz(_smooth_rotations(k, 9)))  # (k, size)
    together = rc.from_quaternions(native, mode, q, previous=previous)
    assert together.shape == (120, k, rc.channel_property(mode)[1])
    for j in range(k):
        alone = rc.from_quaternions(native, mode, q[:, j], previous=previous[j])
        assert np.array_equal(together[:, j], alone), j


def test_the_tests_angle_between_rotations_is_the_angle():
    """tests/common/rotations.quaternion_angles, which the exact rotation tests bound: known angles back,
    tiny ones included, whatever the sign of either quaternion."""
    angles = np.array([0.0, 1e-9, 1e-6, np.radians(0.5), 1.0, np.pi - 1e-6])
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    base = _wxyz(Rotation.from_rotvec([[0.4, 0.1, -0.7]] * len(angles)))
    turned = _wxyz(Rotation.from_rotvec(angles[:, None] * axis) * Rotation.from_rotvec([[0.4, 0.1, -0.7]] * len(angles)))
    np.testing.assert_allclose(quaternion_angles(turned, base), angles, rtol=1e-6, atol=1e-15)
    np.testing.assert_allclose(quaternion_angles(-turned, base), angles, rtol=1e-6, atol=1e-15)
