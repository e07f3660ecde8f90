"""Native keyframe interpolation against scipy and numpy."""
import numpy as np
import pytest
from scipy.interpolate import (BarycentricInterpolator, CubicHermiteSpline, CubicSpline,
                               KroghInterpolator, PchipInterpolator)

RTOL = 1e-12


def keys(n, d=None, seed=0, loop=False):
    """Uneven, strictly increasing times and random values; loop=True repeats the first value."""
    rng = np.random.default_rng(seed)
    times = np.cumsum(rng.uniform(0.2, 2.0, n)) - 3.0
    values = rng.uniform(-2.0, 2.0, (n,) if d is None else (n, d))
    if loop:
        values[-1] = values[0]
    return times, values


def inside(times, m=1001):
    """Sample times within the keys (scipy extrapolates, we hold), keys included."""
    x = np.linspace(times[0], times[-1], m)
    return np.sort(np.concatenate([x, times]))


def close(actual, expected, rtol=RTOL):
    """Relative agreement, with an absolute floor at the data's scale for values near 0."""
    scale = max(1.0, float(np.max(np.abs(expected))))
    np.testing.assert_allclose(actual, expected, rtol=rtol, atol=rtol * scale)


KINDS = ["stepped", "linear", "polynomial", "natural", "clamped", "periodic", "not-a-knot",
         "hermite", "catmull-rom", "centripetal", "chordal", "kochanek-bartels", "monotone"]


def extras(kind, values, derivative=True):
    options = {"derivative": derivative}
    if kind == "hermite":
        options["slopes"] = np.cos(values)
    if kind == "kochanek-bartels":
        n = len(values)
        options.update(tension=np.linspace(-0.3, 0.3, n), continuity=np.full(n, 0.2),
                       bias=np.linspace(0.4, -0.4, n))
    return options


SPLINES = {"natural": "natural", "clamped": "clamped", "periodic": "periodic",
           "not-a-knot": "not-a-knot"}


def _cubic_spline(times, values, bc_type):
    """scipy's CubicSpline, one per component: scipy 1.10 (Debian 12's, which Blender 3.4 there runs with)
    mixes the components of a periodic spline through three keys, which 1.11 fixed; one component at a time
    is right on both."""
    if values.ndim == 1:
        return CubicSpline(times, values, bc_type=bc_type)
    columns = [CubicSpline(times, values[:, k], bc_type=bc_type) for k in range(values.shape[1])]
    return lambda x, nu=0: np.stack([c(x, nu) for c in columns], axis=-1)


@pytest.mark.parametrize("kind", SPLINES)
@pytest.mark.parametrize("n", [2, 3, 4, 5, 17, 200])
@pytest.mark.parametrize("d", [None, 3])
def test_splines_match_scipy_cubic_spline(native, kind, n, d):
    times, values = keys(n, d, seed=n, loop=kind == "periodic")
    x = inside(times)
    reference = _cubic_spline(times, values, SPLINES[kind])
    samples, derivatives = native.interpolate(times, values, x, kind, derivative=True)
    assert samples.shape == reference(x).shape
    close(samples, reference(x))
    close(derivatives, reference(x, 1))


def test_clamped_end_slopes_match_scipy(native):
    times, values = keys(12, 2, seed=4)
    ends = np.array([[0.5, -1.0], [2.0, 0.25]])
    x = inside(times)
    reference = CubicSpline(times, values, bc_type=((1, ends[0]), (1, ends[1])))
    samples, derivatives = native.interpolate(times, values, x, "clamped", end_slopes=ends,
                                              derivative=True)
    close(samples, reference(x))
    close(derivatives, reference(x, 1))
    first = np.ascontiguousarray(values[:, 0])  # a strided view would need a copy: TypeError
    scalar = native.interpolate(times, first, x, "clamped", end_slopes=[0.5, 2.0])
    close(scalar, CubicSpline(times, first, bc_type=((1, 0.5), (1, 2.0)))(x))


@pytest.mark.parametrize("d", [None, 2])
def test_hermite_matches_cubic_hermite_spline(native, d):
    times, values = keys(30, d, seed=5)
    slopes = np.random.default_rng(6).normal(size=values.shape)
    x = inside(times)
    reference = CubicHermiteSpline(times, values, slopes)
    samples, derivatives = native.interpolate(times, values, x, "hermite", slopes=slopes,
                                              derivative=True)
    close(samples, reference(x))
    close(derivatives, reference(x, 1))


@pytest.mark.parametrize("n", [2, 3, 4, 50])
def test_monotone_matches_pchip(native, n):
    times, values = keys(n, 2, seed=n + 100)
    values[n // 2:, 0] = np.sort(values[n // 2:, 0])  # flat and monotone runs too
    values[1:3, 1] = values[0, 1]
    x = inside(times)
    reference = PchipInterpolator(times, values)
    samples, derivatives = native.interpolate(times, values, x, "monotone", derivative=True)
    close(samples, reference(x))
    close(derivatives, reference(x, 1))


def test_linear_matches_np_interp_and_holds_outside(native):
    times, values = keys(40, seed=7)
    x = np.linspace(times[0] - 2.0, times[-1] + 2.0, 999)
    samples, derivatives = native.interpolate(times, values, x, "linear", derivative=True)
    close(samples, np.interp(x, times, values))
    outside = (x < times[0]) | (x > times[-1])
    assert np.all(derivatives[outside] == 0.0)


@pytest.mark.parametrize("n", [2, 5, 9])
def test_polynomial_matches_barycentric(native, n):
    times, values = keys(n, 2, seed=n + 7)
    x = inside(times, 301)
    samples, derivatives = native.interpolate(times, values, x, "polynomial", derivative=True)
    close(samples, BarycentricInterpolator(times, values)(x), rtol=1e-10)
    close(derivatives, KroghInterpolator(times, values).derivative(x), rtol=1e-8)


def test_every_kind_holds_the_end_values_outside(native):
    times, values = keys(6, 2, seed=8, loop=True)
    x = np.array([times[0] - 5.0, times[-1] + 5.0])
    for kind in KINDS:
        samples, derivatives = native.interpolate(times, values, x, kind, **extras(kind, values))
        np.testing.assert_array_equal(samples, values[[0, -1]])
        np.testing.assert_array_equal(derivatives, 0.0)


def test_catmull_rom_slopes_follow_the_documented_rule(native):
    times = np.array([0.0, 1.0, 3.0, 4.0])
    values = np.array([0.0, 2.0, 3.0, 7.0])
    slopes_in, slopes_out = native.hermite_form(times, values, "catmull-rom")
    np.testing.assert_array_equal(slopes_out, [2.0, 1.0, 5.0 / 3.0, 4.0])
    np.testing.assert_array_equal(slopes_in, slopes_out)
    # Equal to scipy's CubicHermiteSpline with those slopes.
    x = inside(times)
    close(native.interpolate(times, values, x, "catmull-rom"),
          CubicHermiteSpline(times, values, slopes_out)(x))


def test_kochanek_bartels_at_zero_is_catmull_rom(native):
    times, values = keys(20, 3, seed=9)
    x = inside(times)
    zeros = np.zeros(20)
    np.testing.assert_array_equal(
        native.interpolate(times, values, x, "kochanek-bartels", tension=zeros, continuity=zeros,
                           bias=zeros),
        native.interpolate(times, values, x, "catmull-rom"))


@pytest.mark.parametrize("kind", [k for k in KINDS if k not in ("stepped", "polynomial")])
def test_hermite_form_reproduces_interpolate(native, kind):
    times, values = keys(15, 2, seed=10, loop=True)
    options = extras(kind, values, derivative=False)
    del options["derivative"]
    slopes_in, slopes_out = native.hermite_form(times, values, kind, **options)
    x = inside(times)
    samples = native.interpolate(times, values, x, kind, **options)
    # Piecewise Hermite with separate in/out slopes, built segment by segment.
    expected = np.empty_like(samples)
    for i in range(len(times) - 1):
        segment = CubicHermiteSpline(times[i:i + 2], values[i:i + 2],
                                     np.stack([slopes_out[i], slopes_in[i + 1]]))
        pick = (x >= times[i]) & (x <= times[i + 1])
        expected[pick] = segment(x[pick])
    close(samples, expected)


def test_hermite_form_refuses_stepped(native):
    times, values = keys(4, seed=11)
    with pytest.raises(native.MotionKitError, match="CONSTANT keys"):
        native.hermite_form(times, values, "stepped")


@pytest.mark.parametrize("kind", KINDS)
def test_curves_batch_equals_single(native, kind):
    rng = np.random.default_rng(12)
    lengths = [1, 2, 3, 7, 30]
    curves = [keys(n, seed=20 + n, loop=True) for n in lengths]
    offsets = np.concatenate([[0], np.cumsum(lengths)])
    times = np.concatenate([c[0] for c in curves])
    values = np.concatenate([c[1] for c in curves])
    x = np.sort(rng.uniform(-5.0, 40.0, 777))
    options = extras(kind, values)
    samples, derivatives = native._testing.interpolate_curves(offsets, times, values, x, kind, **options)
    assert samples.shape == (len(lengths), 777)
    for c, (t, v) in enumerate(curves):
        single = {k: (a[offsets[c]:offsets[c + 1]] if isinstance(a, np.ndarray) else a)
                  for k, a in options.items()}
        one, one_derivative = native.interpolate(t, v, x, kind, **single)
        close(samples[c], one, rtol=1e-14)
        close(derivatives[c], one_derivative, rtol=1e-14)


def test_curves_clamped_end_slopes_per_curve(native):
    curves = [keys(n, seed=n) for n in (4, 6)]
    offsets = np.array([0, 4, 10])
    times = np.concatenate([c[0] for c in curves])
    values = np.concatenate([c[1] for c in curves])
    ends = np.array([[1.0, -2.0], [0.5, 3.0]])  # (start, end) x curve
    x = np.linspace(-3, 8, 100)
    samples = native._testing.interpolate_curves(offsets, times, values, x, "clamped", end_slopes=ends)
    for c, (t, v) in enumerate(curves):
        inner = (x >= t[0]) & (x <= t[-1])
        reference = CubicSpline(t, v, bc_type=((1, ends[0, c]), (1, ends[1, c])))
        close(samples[c][inner], reference(x[inner]))


def test_unknown_kind_lists_the_valid_ones(native):
    times, values = keys(3, seed=1)
    with pytest.raises(native.MotionKitError, match="unknown interpolation kind 'cubic'.*"
                                                    "natural.*kochanek-bartels.*monotone"):
        native.interpolate(times, values, times, "cubic")


def test_bad_input_raises_with_the_place(native):
    times = np.array([0.0, 1.0, 1.0])
    with pytest.raises(native.MotionKitError, match=r"key 2 \(1.000000\) does not come after key 1"):
        native.interpolate(times, np.zeros(3), np.zeros(1))
    values = np.zeros((3, 2))
    values[1, 1] = np.nan
    with pytest.raises(native.MotionKitError, match="value of key 1 .*component 1 is not finite"):
        native.interpolate(np.arange(3.0), values, np.zeros(1))
    loop = np.array([[0.0, 1.0], [1.0, 1.0], [0.0, 2.0]])
    with pytest.raises(native.MotionKitError, match="periodic.*component 1"):
        native.interpolate(np.arange(3.0), loop, np.zeros(1), "periodic")
    with pytest.raises(native.MotionKitError, match="curve 1 has no keys"):
        native._testing.interpolate_curves(np.array([0, 2, 2]), np.arange(2.0), np.zeros(2), np.zeros(1))
    with pytest.raises(TypeError):  # float32 would need a copy: refused, not converted
        native.interpolate(np.arange(3.0), np.zeros(3, np.float32), np.zeros(1))


def test_shapes_follow_the_values(native):
    times, values = keys(5, seed=2)
    x = np.linspace(times[0], times[-1], 7)
    assert native.interpolate(times, values, x).shape == (7,)
    assert native.interpolate(times, values[:, None], x).shape == (7, 1)
    slopes_in, slopes_out = native.hermite_form(times, values[:, None])
    assert slopes_in.shape == slopes_out.shape == (5, 1)
