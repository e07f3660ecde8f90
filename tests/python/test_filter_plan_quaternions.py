"""filter_groups on quaternion channels, which it normalises together and takes back as filter_rotations
returns them: the same as filter_rotations on the unit quaternions (the reference: numpy's normalisation
and the native call, written here), non-unit keys included, and a zero quaternion named with its frame."""
import numpy as np
import pytest

from core import filter_plan
from core.filter_plan import FilterSettings


def quaternion_keys(frames, bones, seed):
    """Smooth turns with noise, each bone's quaternions scaled by a length between 0.5 and 2 (Blender keeps
    quaternion channels as keyed) and with a sign flipped on some frames."""
    rng = np.random.default_rng(seed)
    t = np.arange(frames)[:, None] / 30.0
    out = []
    for _ in range(bones):
        v = 0.6 * np.sin(2 * np.pi * rng.uniform(0.2, 0.8, 3) * t + rng.uniform(0, 6, 3))
        v += rng.normal(0.0, 0.02, v.shape)
        angle = np.linalg.norm(v, axis=1, keepdims=True)
        q = np.hstack([np.cos(angle / 2), np.sin(angle / 2) * v / angle])
        q *= rng.uniform(0.5, 2.0) * np.where(rng.random((frames, 1)) < 0.1, -1.0, 1.0)
        out.append(q)
    return out


@pytest.mark.parametrize("settings", [FilterSettings("butterworth", cutoff=7.0), FilterSettings("gaussian")])
def test_quaternion_channels_are_filter_rotations_of_their_unit_quaternions(native, settings):
    frames = np.arange(1.0, 301.0)
    keys = quaternion_keys(len(frames), 5, 36)
    groups = [('rotation', 'QUATERNION', q, f"b{i}") for i, q in enumerate(keys)]
    got = filter_plan.filter_groups(native, groups, settings, 30.0, frames)
    unit = np.hstack([q / np.linalg.norm(q, axis=1, keepdims=True) for q in keys])
    expected = native.filter_rotations(np.ascontiguousarray(unit), settings.kind, 30.0, **settings.native_options())
    for b, values in enumerate(got):
        # One normalisation apart (an ulp or two of a unit quaternion), then the same filter: measured at
        # most 2.2e-16 (also with NumPy's AVX paths disabled), so ten times that.
        np.testing.assert_allclose(values, expected[:, 4 * b:4 * b + 4], rtol=0, atol=2.2e-15, err_msg=f"bone {b}")
        assert values[0] @ keys[b][0] > 0  # the first frame keeps its key's sign, the rest continuous
        assert np.all(np.sum(values[1:] * values[:-1], axis=1) > 0)


def test_a_zero_quaternion_is_named_with_its_frame(native):
    frames = np.arange(1.0, 21.0)
    keys = quaternion_keys(len(frames), 3, 7)
    keys[2][6] = 0.0
    groups = [('rotation', 'QUATERNION', q, f"b{i}") for i, q in enumerate(keys)]
    with pytest.raises(ValueError, match=r"^b2 is zero or not finite at frame 7$"):
        filter_plan.filter_groups(native, groups, FilterSettings("butterworth", cutoff=7.0), 30.0, frames)
