"""The native filters (native/src/filters) against scipy and the published One-Euro algorithm, and the
rotation filter on the sphere against a clean curve."""
import math

import numpy as np
import pytest
from rotations import quaternion_angles
from scipy import ndimage, signal
from scipy.spatial.transform import Rotation


def random_walk(frames, channels, seed):
    rng = np.random.default_rng(seed)
    return np.ascontiguousarray(np.cumsum(rng.normal(size=(frames, channels)), axis=0))


def butterworth_sos(order, cutoff, fps):
    return signal.butter(order, cutoff, fs=fps, output="sos")


def sos_padding(sos, frames):
    """sosfiltfilt's default padding, 3 taps (2 sections + 1, less a section of first order), shortened as
    MotionKit shortens it for a clip no longer than that."""
    taps = 2 * len(sos) + 1 - min((sos[:, 2] == 0).sum(), (sos[:, 5] == 0).sum())
    return min(3 * taps, frames - 1)


def scipy_butterworth(x, order, cutoff, fps):
    sos = butterworth_sos(order, cutoff, fps)
    return signal.sosfiltfilt(sos, x, axis=0, padtype="odd", padlen=sos_padding(sos, x.shape[0]))


def rounding_bound(x, order, cutoff, fps):
    """What rounding can make two correct sosfiltfilt runs differ by, from the conditioning of the SOS form:
    each section's state update rounds a few times (3 ulps) at the amplitude of the odd-extended signal, and
    that error reaches the output through the rest of the cascade: 1 / A_s of its own section, then the
    sections after it, whose impulse response's L1 norm is its gain (worst case, summed over sections); the
    backward pass carries the forward error through the whole filter (its L1 gain) and adds its own.
    It is a worst case: measured errors are 0.25 of it at most (orders 1 and 2), 0.02 at the median and less
    at high orders near the Nyquist frequency, where errors of either sign cancel most."""
    sos = butterworth_sos(order, cutoff, fps)
    pad = sos_padding(sos, x.shape[0])
    amplitude = np.abs(np.concatenate([2 * x[:1] - x[pad:0:-1], x, 2 * x[-1:] - x[-2:-pad - 2:-1]])).max()
    impulse = np.zeros(20 * fps)  # 20 s: every design here decays to 1e-16 of its peak well before
    impulse[0] = 1.0

    def l1(sections):
        return np.abs(signal.sosfilt(sections, impulse)).sum() if len(sections) else 1.0

    state_gains = 0.0
    for s in range(len(sos)):
        # A state is b_k x - a_k y + ...: its terms are the section's input (the signal through the
        # sections before it) times b and its output times a; its rounding reaches the output through
        # 1 / A_s (the section with its numerator 1) and the sections after it.
        level = max(np.abs(sos[s, :3]).max() * l1(sos[:s]), np.abs(sos[s, 3:]).max() * l1(sos[:s + 1]))
        rest = sos[s:].copy()
        rest[0, :3] = (1.0, 0.0, 0.0)
        state_gains += level * l1(rest)
    return 3 * np.finfo(float).eps * amplitude * state_gains * (1.0 + l1(sos))


@pytest.mark.parametrize("fps", [24, 30, 60, 120])
@pytest.mark.parametrize("order", [1, 2, 3, 4, 5, 6, 7, 8])
def test_butterworth_is_scipys_sosfiltfilt(native, fps, order):
    x = random_walk(300, 4, seed=order * 1000 + fps)
    for cutoff in (7.0, 2.0, 0.45 * fps):
        got = native.filter_channels(x, "butterworth", fps, cutoff=cutoff, order=order)
        error = np.abs(got - scipy_butterworth(x, order, cutoff, fps)).max()
        bound = rounding_bound(x, order, cutoff, fps)
        print(f"order {order}, {cutoff:g} Hz at {fps} fps: {error:.1e}, {error / bound:.3f} of the bound {bound:.1e}")
        assert error <= bound, f"order {order}, cutoff {cutoff} Hz at {fps} fps: {error:.2e} > {bound:.2e}"


@pytest.mark.parametrize("fps", [24, 30, 60, 120])
@pytest.mark.parametrize("order", [1, 2, 4, 6])
def test_butterworth_on_a_short_clip_shortens_the_padding(native, fps, order):
    x = random_walk(20, 3, seed=order + fps)
    got = native.filter_channels(x, "butterworth", fps, order=order)  # 7 Hz by default
    assert np.abs(got - scipy_butterworth(x, order, 7.0, fps)).max() <= rounding_bound(x, order, 7.0, fps)
    two = np.ascontiguousarray(x[:2])
    got = native.filter_channels(two, "butterworth", fps, order=order)
    assert np.abs(got - scipy_butterworth(two, order, 7.0, fps)).max() <= rounding_bound(two, order, 7.0, fps)


def test_butterworth_defaults_are_mayas_7_hz_order_4(native):
    x = random_walk(300, 2, seed=1)
    assert np.abs(native.filter_channels(x, "butterworth", 30.0) - scipy_butterworth(x, 4, 7.0, 30)).max() <= \
        rounding_bound(x, 4, 7.0, 30)


def test_butterworth_channels_side_by_side_are_each_filtered_alone(native):
    """Channels are filtered several at a time; each column's result is that of the column alone, bit for
    bit, whatever its neighbours (5 columns: a full group and a partial one)."""
    x = random_walk(200, 5, seed=8)
    together = native.filter_channels(x, "butterworth", 30.0, cutoff=4.0, order=6)
    for c in range(5):
        alone = native.filter_channels(np.ascontiguousarray(x[:, c:c + 1]), "butterworth", 30.0, cutoff=4.0,
                                       order=6)
        assert np.array_equal(together[:, c:c + 1], alone)


@pytest.mark.parametrize("sigma", [0.3, 1.0, 2.5, 7.0])
def test_gaussian_is_scipys_gaussian_filter1d(native, sigma):
    for x in (random_walk(300, 3, seed=5), random_walk(6, 2, seed=6)):  # the second shorter than the kernel
        got = native.filter_channels(x, "gaussian", 30.0, sigma=sigma)
        np.testing.assert_allclose(got, ndimage.gaussian_filter1d(x, sigma, axis=0, mode="reflect", truncate=4.0),
                                   rtol=0, atol=1e-9)
    assert np.array_equal(native.filter_channels(x, "gaussian", 30.0),
                          native.filter_channels(x, "gaussian", 30.0, sigma=1.0))


@pytest.mark.parametrize("size", [3, 5, 9, 15])
def test_median_is_ndimages_nearest_and_medfilt_inside(native, size):
    x = random_walk(300, 3, seed=size)
    x[[40, 41, 200], 1] += 30.0  # spikes
    got = native.filter_channels(x, "median", 30.0, size=size)
    np.testing.assert_array_equal(got, ndimage.median_filter(x, size=(size, 1), mode="nearest"))
    half = size // 2
    np.testing.assert_array_equal(got[half:-half], signal.medfilt(x, kernel_size=(size, 1))[half:-half])
    assert got[40, 1] < x[40, 1] - 20.0 or size == 3  # two frames wide: only a window of 5 or more removes it
    short = np.ascontiguousarray(x[:size])
    np.testing.assert_array_equal(native.filter_channels(short, "median", 30.0, size=size),
                                  ndimage.median_filter(short, size=(size, 1), mode="nearest"))


def one_euro_published(x, fps, min_cutoff, beta, d_cutoff):
    """The One-Euro filter (Casiez, Roussel, Vogel, CHI 2012) as the paper writes it, one channel."""
    te = 1.0 / fps

    def alpha(cutoff):
        tau = 1.0 / (2.0 * math.pi * cutoff)
        return 1.0 / (1.0 + tau / te)

    out = [x[0]]
    dx_hat = 0.0
    for t in range(1, len(x)):
        dx = (x[t] - out[-1]) * fps
        a_d = alpha(d_cutoff)
        dx_hat = a_d * dx + (1.0 - a_d) * dx_hat
        a = alpha(min_cutoff + beta * abs(dx_hat))
        out.append(a * x[t] + (1.0 - a) * out[-1])
    return np.array(out)


def test_one_euro_is_the_published_algorithm(native):
    fps = 60.0
    t = np.arange(240) / fps
    rng = np.random.default_rng(11)
    ramp_step_noise = 0.3 * t + np.where(t > 2.0, 1.5, 0.0) + rng.normal(0.0, 0.02, t.size)
    x = np.ascontiguousarray(np.stack([ramp_step_noise, -2.0 * ramp_step_noise + 4.0], axis=1))
    for min_cutoff, beta, d_cutoff in ((1.0, 0.0, 1.0), (0.5, 0.7, 1.0), (2.0, 3.0, 0.3)):
        got = native.filter_channels(x, "one_euro", fps, min_cutoff=min_cutoff, beta=beta, d_cutoff=d_cutoff)
        for c in range(2):
            np.testing.assert_allclose(got[:, c], one_euro_published(x[:, c], fps, min_cutoff, beta, d_cutoff),
                                       rtol=0, atol=1e-12)
    # Causal: the past does not see a change to the future.
    changed = x.copy()
    changed[150:] += 5.0
    a = native.filter_channels(x, "one_euro", fps, beta=0.7)
    b = native.filter_channels(changed, "one_euro", fps, beta=0.7)
    assert np.array_equal(a[:150], b[:150]) and not np.array_equal(a[150:], b[150:])


def test_scalar_errors_name_the_place(native):
    x = random_walk(50, 3, seed=2)
    assert issubclass(native.MotionKitError, ValueError)
    with pytest.raises(native.MotionKitError, match=r"^butterworth: cutoff 16 Hz is at or above the Nyquist "
                                                    r"frequency 15 Hz of a 30 fps clip$"):
        native.filter_channels(x, "butterworth", 30.0, cutoff=16.0)
    with pytest.raises(native.MotionKitError, match="order must be 1 to 8, not 0"):
        native.filter_channels(x, "butterworth", 30.0, order=0)
    bad = x.copy()
    bad[17, 1] = np.nan
    with pytest.raises(native.MotionKitError, match="channel 1 at frame 17 is nan"):
        native.filter_channels(bad, "gaussian", 30.0)
    with pytest.raises(native.MotionKitError, match="median: size 51 is longer than the clip's 50 frames"):
        native.filter_channels(x, "median", 30.0, size=51)
    with pytest.raises(native.MotionKitError, match="unknown filter kind 'savgol'"):
        native.filter_channels(x, "savgol", 30.0)
    with pytest.raises(TypeError):  # no silent copy of another dtype
        native.filter_channels(x.astype(np.float32), "gaussian", 30.0)


# Rotations: w x y z quaternions from scipy's x y z w.
def wxyz(rotation):
    return rotation.as_quat()[..., [3, 0, 1, 2]]


def smooth_curve(frames, fps, seed, frequencies=(0.3, 0.7, 1.2)):
    """A rotation whose rotation vector is a sum of slow sinusoids (Hz), after a fixed start."""
    rng = np.random.default_rng(seed)
    t = np.arange(frames)[:, None] / fps
    path = sum(rng.uniform(0.2, 0.8, 3) * np.sin(2 * np.pi * f * t + rng.uniform(0, 6, 3)) for f in frequencies)
    return Rotation.from_quat(rng.normal(size=4)) * Rotation.from_rotvec(path)


def noisy(curve, degrees, seed):
    rng = np.random.default_rng(seed)
    return curve * Rotation.from_rotvec(rng.normal(0.0, np.radians(degrees) / np.sqrt(3), (len(curve), 3)))


def stack(*quaternions):
    return np.ascontiguousarray(np.concatenate(quaternions, axis=1))


def test_rotation_noise_is_removed_on_the_sphere(native):
    fps, frames, bones = 60.0, 300, 3
    clean = [smooth_curve(frames, fps, seed) for seed in range(bones)]
    observed = [noisy(c, 2.0, seed + 10) for seed, c in enumerate(clean)]
    got = native.filter_rotations(stack(*map(wxyz, observed)), "butterworth", fps, cutoff=3.0)
    for b in range(bones):
        before = quaternion_angles(wxyz(observed[b]), wxyz(clean[b]))
        after = quaternion_angles(got[:, 4 * b:4 * b + 4], wxyz(clean[b]))
        ratio = np.sqrt(np.mean(before ** 2) / np.mean(after ** 2))
        print(f"bone {b}: rms error {np.degrees(np.sqrt(np.mean(before ** 2))):.3f} deg -> "
              f"{np.degrees(np.sqrt(np.mean(after ** 2))):.3f} deg, reduced {ratio:.2f} times")
        assert ratio > 2.3
    # The Gaussian reduces it too.
    got = native.filter_rotations(stack(wxyz(observed[0])), "gaussian", fps, sigma=3.0)
    before = quaternion_angles(wxyz(observed[0]), wxyz(clean[0]))
    after = quaternion_angles(got, wxyz(clean[0]))
    ratio = np.sqrt(np.mean(before ** 2) / np.mean(after ** 2))
    print(f"gaussian sigma 3: reduced {ratio:.2f} times")
    assert ratio > 2.0


def test_rotation_median_about_a_fixed_axis_is_the_angles_median(native):
    """About one axis the tangent-space median is the scalar median of the angle, spikes and ends included."""
    fps = 60.0
    angle = 0.8 * np.sin(np.arange(300) / 25.0) + 0.3
    angle[[50, 51, 140, 230, 231, 232]] += np.radians([30.0, -20.0, 25.0, 40.0, 35.0, 30.0])
    axis = np.array([0.36, -0.48, 0.8])
    q = np.ascontiguousarray(wxyz(Rotation.from_rotvec(angle[:, None] * axis)))
    for size in (3, 7, 9):
        expected = ndimage.median_filter(angle, size=size, mode="nearest")
        got = native.filter_rotations(q, "median", fps, size=size)
        assert quaternion_angles(got, wxyz(Rotation.from_rotvec(expected[:, None] * axis))).max() < 1e-12


def test_rotation_spikes_are_removed_by_the_median(native):
    fps = 60.0
    clean = smooth_curve(300, fps, 21, frequencies=(0.2, 0.4))
    spikes = np.zeros((300, 3))
    spikes[[50, 140, 230]] = np.radians([30.0, -20.0, 10.0])
    spiked = clean * Rotation.from_rotvec(spikes)
    got = native.filter_rotations(np.ascontiguousarray(wxyz(spiked)), "median", fps, size=5)
    error = np.degrees(quaternion_angles(got, wxyz(clean)))
    # With the outlier on one side of each component, a median is off by up to a frame's motion there.
    step = np.degrees(quaternion_angles(wxyz(clean[1:]), wxyz(clean[:-1])))
    print(f"median 5: worst error {error.max():.4f} deg, at the spikes {error[[50, 140, 230]].max():.4f} deg, "
          f"for spikes of {np.degrees(quaternion_angles(wxyz(spiked), wxyz(clean)).max()):.1f} deg; largest "
          f"step of the curve {step.max():.4f} deg")
    for t in (50, 140, 230):
        assert error[t - 2:t + 3].max() < 1.5 * step[t - 2:t + 2].max()


@pytest.mark.parametrize("kind", ["butterworth", "gaussian", "median"])
def test_a_constant_speed_rotation_comes_back(native, kind):
    fps, frames = 30.0, 200
    rng = np.random.default_rng(4)
    bones = [Rotation.from_quat(rng.normal(size=4)) * Rotation.from_rotvec(np.arange(frames)[:, None] * omega)
             for omega in (rng.normal(0, 0.3, 3), np.array([0.0, 0.0, 0.9]), np.zeros(3))]
    q = stack(*map(wxyz, bones))
    got = native.filter_rotations(q, kind, fps, sigma=2.0)
    for b in range(len(bones)):
        assert quaternion_angles(got[:, 4 * b:4 * b + 4], q[:, 4 * b:4 * b + 4]).max() < 1e-9


def test_rotation_signs_in_and_out(native):
    fps = 30.0
    observed = wxyz(noisy(smooth_curve(120, fps, 3), 2.0, 4))
    got = native.filter_rotations(np.ascontiguousarray(observed), "butterworth", fps)
    flipped = observed.copy()
    flipped[1::3] *= -1.0
    flipped[50:60] *= -1.0
    np.testing.assert_array_equal(native.filter_rotations(flipped, "butterworth", fps), got)
    flipped[0] *= -1.0  # the output's first frame takes the input's sign
    np.testing.assert_array_equal(native.filter_rotations(flipped, "butterworth", fps), -got)
    np.testing.assert_allclose(np.linalg.norm(got, axis=1), 1.0, rtol=0, atol=1e-12)
    assert np.all(np.sum(got[1:] * got[:-1], axis=1) > 0) and got[0] @ observed[0] > 0


def one_euro_rotations_published(q, fps, min_cutoff, beta, d_cutoff):
    """The One-Euro filter's quaternion form written out: slerp towards each sample by alpha, the cut-off
    from the smoothed angular speed."""
    def alpha(cutoff):
        return 1.0 / (1.0 + fps / (2.0 * math.pi * cutoff))

    out = [Rotation.from_quat(q[0][[1, 2, 3, 0]])]
    speed_hat = 0.0
    for row in q[1:]:
        step = (out[-1].inv() * Rotation.from_quat(row[[1, 2, 3, 0]])).as_rotvec()
        a_d = alpha(d_cutoff)
        speed_hat = a_d * np.linalg.norm(step) * fps + (1.0 - a_d) * speed_hat
        out.append(out[-1] * Rotation.from_rotvec(alpha(min_cutoff + beta * speed_hat) * step))
    return wxyz(Rotation.concatenate(out))


def test_one_euro_on_rotations_is_the_quaternion_form(native):
    fps = 60.0
    observed = wxyz(noisy(smooth_curve(150, fps, 8), 2.0, 9))
    got = native.filter_rotations(np.ascontiguousarray(observed), "one_euro", fps, min_cutoff=1.5, beta=0.4)
    expected = one_euro_rotations_published(observed, fps, 1.5, 0.4, 1.0)
    assert quaternion_angles(got, expected).max() < 1e-12


def test_rotation_errors_name_the_place(native):
    q = stack(*(wxyz(smooth_curve(40, 30.0, seed)) for seed in range(2)))
    with pytest.raises(native.MotionKitError, match="Nyquist frequency 12 Hz of a 24 fps clip"):
        native.filter_rotations(q, "butterworth", 24.0, cutoff=12.0)
    bad = q.copy()
    bad[5, 4:8] *= 1.01
    with pytest.raises(native.MotionKitError, match="quaternion of bone 1 at frame 5 has length 1.01, not 1"):
        native.filter_rotations(bad, "gaussian", 30.0)
    bad = q.copy()
    bad[31, 2] = np.nan
    with pytest.raises(native.MotionKitError, match="quaternion of bone 0 at frame 31 is not finite"):
        native.filter_rotations(bad, "gaussian", 30.0)
    with pytest.raises(native.MotionKitError, match=r"\(frames, 4 \* bones\)"):
        native.filter_rotations(np.ascontiguousarray(q[:, :6]), "gaussian", 30.0)
