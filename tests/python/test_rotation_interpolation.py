"""Native rotation interpolation and key reduction, against scipy and independent re-evaluation."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

SPHERE_KINDS = ["slerp", "squad", "catmull-rom", "kochanek-bartels"]
ALL_KINDS = SPHERE_KINDS + ["euler-catmull-rom", "axis-angle-catmull-rom"]


def wxyz(rotation):
    return np.ascontiguousarray(np.roll(rotation.as_quat(), 1, axis=-1))


def xyzw(q):
    return np.roll(q, -1, axis=-1)


def angle_between(p, q):
    """Rotation angle between rows of two quaternion arrays (q and -q alike)."""
    p = p / np.linalg.norm(p, axis=-1, keepdims=True)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    q = q * np.sign(np.sum(p * q, axis=-1, keepdims=True) + 1e-300)
    return 4.0 * np.arctan2(np.linalg.norm(p - q, axis=-1), np.linalg.norm(p + q, axis=-1))


def random_keys(n, seed, uneven=True):
    rng = np.random.default_rng(seed)
    steps = rng.uniform(0.3, 2.0, n - 1) if uneven else np.full(n - 1, 0.5)
    times = np.concatenate([[0.25], 0.25 + np.cumsum(steps)])
    turns = Rotation.from_rotvec(rng.normal(scale=0.8, size=(n, 3)))
    rotations = [Rotation.random(random_state=seed)]
    for turn in turns[1:]:
        rotations.append(rotations[-1] * turn)
    q = wxyz(Rotation.concatenate(rotations))
    q *= rng.choice([-1.0, 1.0], size=(n, 1)) * rng.uniform(0.5, 2.0, size=(n, 1))
    return times, np.ascontiguousarray(q)


def test_slerp_kind_equals_scipy_slerp(native):
    times, q = random_keys(12, 1)
    at = np.linspace(times[0], times[-1], 2001)
    ours = native.interpolate_rotations(times, q, at, "slerp")
    theirs = wxyz(Slerp(times, Rotation.from_quat(xyzw(q)))(at))
    assert np.max(angle_between(ours, theirs)) < 1e-12
    assert np.max(np.abs(np.linalg.norm(ours, axis=1) - 1.0)) < 1e-12


def test_two_key_slerp_matches_scipy_and_the_closed_form(native):
    rng = np.random.default_rng(2)
    u = np.linspace(0.0, 1.0, 101)
    for _ in range(50):
        q0, q1 = wxyz(Rotation.random(2, random_state=rng))
        ours = native._testing.slerp(q0, q1, u)
        theirs = wxyz(Slerp([0.0, 1.0], Rotation.from_quat(xyzw(np.array([q0, q1]))))(u))
        assert np.max(angle_between(ours, theirs)) < 1e-12
        if q0 @ q1 < 0:
            q1 = -q1
        theta = np.arccos(np.clip(q0 @ q1, -1, 1))
        closed = (np.sin((1 - u) * theta)[:, None] * q0 + np.sin(u * theta)[:, None] * q1) / np.sin(theta)
        np.testing.assert_allclose(ours, closed, atol=1e-12)
    assert native._testing.slerp(q0, q1, 0.5).shape == (4,)
    np.testing.assert_allclose(native._testing.slerp(q0, q1, 0.5), ours[50], atol=1e-15)


@pytest.mark.parametrize("kind", ALL_KINDS)
def test_every_kind_passes_through_the_keys_and_stays_unit(native, kind):
    times, q = random_keys(10, 3)
    assert np.max(angle_between(native.interpolate_rotations(times, q, times, kind), q)) < 1e-12
    at = np.linspace(times[0] - 1, times[-1] + 1, 3001)
    out = native.interpolate_rotations(times, q, at, kind)
    assert np.all(np.isfinite(out))
    assert np.max(np.abs(np.linalg.norm(out, axis=1) - 1.0)) < 1e-12
    assert np.all(np.sum(out[1:] * out[:-1], axis=1) >= 0)  # sign-continuous
    assert np.max(angle_between(out[at < times[0]], q[:1])) < 1e-15  # held ends
    assert np.max(angle_between(out[at > times[-1]], q[-1:])) < 1e-15


def finite_difference_omega(q_before, q_after, span):
    return (Rotation.from_quat(xyzw(q_after)) * Rotation.from_quat(xyzw(q_before)).inv()).as_rotvec() / span


@pytest.mark.parametrize("kind", ALL_KINDS)
def test_angular_velocity_matches_finite_differences(native, kind):
    times, q = random_keys(8, 4)
    base = np.linspace(times[0] + 0.01, times[-1] - 0.01, 400)
    delta = 1e-6
    _, omega = native.interpolate_rotations(times, q, base, kind, angular_velocity=True)
    before = native.interpolate_rotations(times, q, base - delta, kind)
    after = native.interpolate_rotations(times, q, base + delta, kind)
    fd = finite_difference_omega(before, after, 2 * delta)
    scale = np.maximum(1.0, np.linalg.norm(omega, axis=1))
    assert np.max(np.linalg.norm(fd - omega, axis=1) / scale) < 1e-6


@pytest.mark.parametrize("kind", ["squad", "catmull-rom", "kochanek-bartels"])
def test_sphere_splines_are_c1_across_keys(native, kind):
    times, q = random_keys(10, 5)
    inner = times[1:-1]
    tcb = {}
    if kind == "kochanek-bartels":
        tcb = dict(tension=np.linspace(-0.4, 0.6, 10), bias=np.linspace(0.5, -0.5, 10))
    # Numerical velocity just before and just after each key.
    eps, span = 1e-5, 1e-7
    left = finite_difference_omega(native.interpolate_rotations(times, q, inner - eps - span, kind, **tcb),
                                   native.interpolate_rotations(times, q, inner - eps + span, kind, **tcb), 2 * span)
    right = finite_difference_omega(native.interpolate_rotations(times, q, inner + eps - span, kind, **tcb),
                                    native.interpolate_rotations(times, q, inner + eps + span, kind, **tcb), 2 * span)
    jump = np.linalg.norm(left - right, axis=1) / np.linalg.norm(right, axis=1)
    assert np.max(jump) < 1e-3
    # Piecewise slerp is only C0.
    left = finite_difference_omega(native.interpolate_rotations(times, q, inner - 2 * eps, "slerp"),
                                   native.interpolate_rotations(times, q, inner - eps, "slerp"), eps)
    right = finite_difference_omega(native.interpolate_rotations(times, q, inner + eps, "slerp"),
                                    native.interpolate_rotations(times, q, inner + 2 * eps, "slerp"), eps)
    assert np.max(np.linalg.norm(left - right, axis=1)) > 1e-2


def test_kochanek_bartels_with_zero_parameters_is_catmull_rom(native):
    times, q = random_keys(9, 6)
    at = np.linspace(times[0], times[-1], 999)
    zero = np.zeros(9)
    cr = native.interpolate_rotations(times, q, at, "catmull-rom")
    kb = native.interpolate_rotations(times, q, at, "kochanek-bartels", tension=zero, continuity=zero, bias=zero)
    np.testing.assert_array_equal(cr, kb)
    np.testing.assert_array_equal(cr, native.interpolate_rotations(times, q, at, "kochanek-bartels"))
    other = native.interpolate_rotations(times, q, at, "kochanek-bartels", tension=[0.5] * 9)
    assert np.max(angle_between(cr, other)) > 1e-3


@pytest.mark.parametrize("kind", ALL_KINDS)
def test_negative_dot_pairs_take_the_short_arc(native, kind):
    times = np.array([0.0, 1.0, 2.0, 3.0])
    q = wxyz(Rotation.from_rotvec(np.outer([0.0, 0.6, 1.2, 1.8], [1.0, 2.0, 2.0]) / 3.0))
    q[1] *= -1
    q[3] *= -1
    at = np.linspace(0, 3, 61)
    out = native.interpolate_rotations(times, q, at, kind)
    expected = wxyz(Rotation.from_rotvec(np.outer(0.6 * at, [1.0, 2.0, 2.0]) / 3.0))
    # Euler angles do not follow a tilted axis exactly, but the long way round
    # would be off by radians.
    assert np.max(angle_between(out, expected)) < (0.1 if kind == "euler-catmull-rom" else 1e-12)


@pytest.mark.parametrize("kind", SPHERE_KINDS)
def test_two_keys_reduce_to_slerp(native, kind):
    times = np.array([1.0, 2.5])
    q = wxyz(Rotation.random(2, random_state=7))
    at = np.linspace(1.0, 2.5, 77)
    expected = native._testing.slerp(q[0], q[1], (at - 1.0) / 1.5)
    assert np.max(angle_between(native.interpolate_rotations(times, q, at, kind), expected)) < 1e-13


@pytest.mark.parametrize("kind", ALL_KINDS)
def test_half_turn_pair_gives_no_nan(native, kind):
    times = np.array([0.0, 1.0, 2.0])
    q = np.array([[1.0, 0, 0, 0], [0, 0, 0, 1.0], [1.0, 0, 0, 0]])
    out, omega = native.interpolate_rotations(times, q, np.linspace(-1, 3, 401), kind, angular_velocity=True)
    assert np.all(np.isfinite(out)) and np.all(np.isfinite(omega))


def test_unsorted_eval_times(native):
    times, q = random_keys(15, 8)
    at = np.linspace(times[0], times[-1], 500)
    order = np.random.default_rng(0).permutation(500)
    for kind in ALL_KINDS:
        sorted_out = native.interpolate_rotations(times, q, at, kind)
        shuffled = native.interpolate_rotations(times, q, np.ascontiguousarray(at[order]), kind)
        assert np.max(angle_between(sorted_out[order], shuffled)) < 1e-15


def test_bad_input_is_named(native):
    times, q = random_keys(4, 9, uneven=False)
    with pytest.raises(native.MotionKitError, match="expected one of slerp, squad, catmull-rom, "
                       "kochanek-bartels, euler-catmull-rom, axis-angle-catmull-rom"):
        native.interpolate_rotations(times, q, times, "spline")
    bad = q.copy()
    bad[2] = 0
    with pytest.raises(native.MotionKitError, match="quaternion of key 2 .* is zero"):
        native.interpolate_rotations(times, bad, times)
    bad[2] = np.nan
    with pytest.raises(native.MotionKitError, match="quaternion of key 2 .* is not finite"):
        native.interpolate_rotations(times, bad, times)
    with pytest.raises(native.MotionKitError, match="bias has 3 values for 4 keys"):
        native.interpolate_rotations(times, q, times, "kochanek-bartels", bias=[0, 0, 0])
    with pytest.raises(native.MotionKitError, match="unknown Euler order 'XYX'"):
        native.interpolate_rotations(times, q, times, "euler-catmull-rom", euler_order="XYX")
    with pytest.raises(TypeError):
        native.interpolate_rotations(times.astype(np.float32), q, times)


# Key reduction ---------------------------------------------------------------

def redraw(times, values, indices, slopes_in, slopes_out):
    """The reduced curve at every sample as Blender draws Bezier keys with handles at thirds."""
    out = np.empty_like(values)
    segment = np.clip(np.searchsorted(times[indices], times, side="right") - 1, 0, max(len(indices) - 2, 0))
    if len(indices) == 1:
        return np.broadcast_to(values[:1], values.shape)
    a, b = indices[segment], indices[segment + 1]
    h = (times[b] - times[a])[:, None]
    u = ((times - times[a]) / (times[b] - times[a]))[:, None]
    p0, p3 = values[a], values[b]
    p1 = p0 + slopes_out[segment] * h / 3
    p2 = p3 - slopes_in[segment + 1] * h / 3
    v = 1 - u
    out[:] = v**3 * p0 + 3 * v * v * u * p1 + 3 * v * u * u * p2 + u**3 * p3
    return out


def test_reduce_keys_absolute(native):
    t = np.linspace(0, 250, 4001)
    y = np.ascontiguousarray(np.stack([np.sin(t / 9), 0.3 * np.cos(t / 4) + 0.01 * t], axis=1))
    indices, s_in, s_out = native.reduce_keys(t, y, 1e-3)
    assert indices.dtype == np.int64 and indices[0] == 0 and indices[-1] == 4000
    assert s_in.shape == s_out.shape == (len(indices), 2)
    assert len(indices) < 4001 / 10
    assert np.max(np.abs(redraw(t, y, indices, s_in, s_out) - y)) <= 1e-3 * (1 + 1e-9)


def test_reduce_keys_line_and_cubic(native):
    t = np.linspace(-1, 3, 321)
    line = np.ascontiguousarray(np.stack([2 * t + 1, 5 - t], axis=1))
    assert len(native.reduce_keys(t, line, 1e-10)[0]) == 2
    cubic = np.ascontiguousarray((t**3 - 2 * t)[:, None])
    indices, s_in, s_out = native.reduce_keys(t, cubic, 1e-10)
    assert list(indices) == [0, 320]
    np.testing.assert_allclose([s_out[0, 0], s_in[1, 0]], [3 - 2, 27 - 2], atol=1e-7)


def test_reduce_keys_quaternion_mode(native):
    t = np.linspace(0, 500, 2001)
    r = Rotation.from_euler("ZXY", np.stack([1.4 * np.sin(t / 29), 0.7 * np.sin(t / 13 + 1), 2 * np.sin(t / 41)], 1))
    q = wxyz(r)
    q[1:] *= np.sign(np.cumprod(np.sign(np.sum(q[1:] * q[:-1], axis=1))))[:, None]  # continuous signs
    for tolerance in (1e-2, 1e-3):
        indices, s_in, s_out = native.reduce_keys(t, q, tolerance, "quaternion")
        assert len(indices) < len(t) / 8
        back = redraw(t, q, indices, s_in, s_out)
        assert np.max(angle_between(back, q)) <= tolerance * (1 + 1e-6)


def test_reduce_keys_euler_mode_with_a_blender_rotation_mode(native):
    # Blender rotation_mode 'XYZ' with rotation_euler (x, y, z) is Rz Ry Rx:
    # euler_order "ZYX" with the columns reversed.
    t = np.linspace(0, 300, 1201)
    rotation_euler = np.stack([np.sin(t / 17), 0.5 * np.cos(t / 11), 0.01 * t], 1)
    columns = np.ascontiguousarray(rotation_euler[:, ::-1])
    indices, s_in, s_out = native.reduce_keys(t, columns, 1e-3, "euler", "ZYX")
    back = redraw(t, columns, indices, s_in, s_out)
    blender = Rotation.from_euler("xyz", rotation_euler)  # scipy lower case: extrinsic, as Blender
    np.testing.assert_allclose(blender.as_matrix(), Rotation.from_euler("ZYX", columns).as_matrix(), atol=1e-12)
    err = (Rotation.from_euler("ZYX", back) * Rotation.from_euler("ZYX", columns).inv()).magnitude()
    assert np.max(err) <= 1e-3 * (1 + 1e-6)
    assert len(indices) < len(t) / 8


def test_reduce_keys_degenerate_inputs(native):
    one = native.reduce_keys(np.array([2.0]), np.array([[1.0, 2.0]]), 0.1)
    assert list(one[0]) == [0] and one[1].shape == (1, 2)
    two = native.reduce_keys(np.array([0.0, 2.0]), np.array([[1.0], [3.0]]), 0.0)
    assert list(two[0]) == [0, 1] and two[2][0, 0] == 1.0
    const = native.reduce_keys(np.linspace(0, 1, 100), np.full((100, 3), 4.0), 0.0)
    assert list(const[0]) == [0, 99]


def test_reduce_keys_bad_input_is_named(native):
    t = np.linspace(0, 1, 5)
    with pytest.raises(native.MotionKitError, match="unknown key reduction mode 'angle'"):
        native.reduce_keys(t, np.zeros((5, 1)), 0.1, "angle")
    with pytest.raises(native.MotionKitError, match="quaternion mode needs 4 channels"):
        native.reduce_keys(t, np.zeros((5, 3)), 0.1, "quaternion")
    bad = np.zeros((5, 2))
    bad[3, 1] = np.inf
    with pytest.raises(native.MotionKitError, match="channel 1 of sample 3"):
        native.reduce_keys(t, bad, 0.1)
    with pytest.raises(native.MotionKitError, match="tolerance must be finite"):
        native.reduce_keys(t, np.zeros((5, 1)), float("nan"))
