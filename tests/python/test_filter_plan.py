"""What motionkit.filter decides without Blender (addon/core/filter_plan.py): settings it refuses, the frames
it samples, values at the original keys, and a group's values through the native filters."""
import math

import numpy as np
import pytest

from core import filter_plan
from core.filter_plan import FilterSettings


@pytest.mark.parametrize("settings, message", [
    (FilterSettings("butterworth", cutoff=15.0), "Nyquist frequency 15 Hz of its 30 fps keys"),
    (FilterSettings("butterworth", cutoff=-1.0), "between 0"),
    (FilterSettings("butterworth", order=9), "order"),
    (FilterSettings("butterworth", order=2.5), "order"),
    (FilterSettings("gaussian", sigma=-1.0), "sigma"),
    (FilterSettings("median", size=6), "odd"),
    (FilterSettings("median", size=1), "odd"),
    (FilterSettings("one_euro", beta=-1.0), "One-Euro"),
    (FilterSettings("smooth"), "unknown filter"),
])
def test_settings_no_clip_could_take_are_refused_with_the_place(settings, message):
    with pytest.raises(ValueError, match=message):
        settings.check(30.0, "'Walk'")


def test_good_settings_pass():
    for kind in [f[0] for f in filter_plan.FILTERS]:
        FilterSettings(kind).check(30.0, "'Walk'")


def test_samples_are_frames_or_a_dense_captures_own_keys():
    assert filter_plan.grid_step(np.arange(1.0, 183.0)) == 1.0  # a key on every frame
    assert filter_plan.grid_step(np.arange(1.0, 100.0, 4.0)) == 1.0  # hand keys: every frame is sampled
    assert filter_plan.grid_step(np.array([1.0, 2.0, 2.5, 4.0])) == 1.0  # uneven
    # 60 fps keys in a 24 fps scene, as float32 stores them: the samples land on every key, the last one too.
    keys = (1.0 + np.arange(10_000) * 24.0 / 59.9988).astype(np.float32)
    step = filter_plan.grid_step(keys)
    samples = filter_plan.sample_frames(float(keys[0]), float(keys[-1]), step)
    assert samples.size == keys.size and np.max(np.abs(samples - keys)) < 1e-3


def test_frames_sampled_at_the_keys_rate():
    assert np.array_equal(filter_plan.sample_frames(1.0, 5.0, 1.0), [1, 2, 3, 4, 5])
    assert np.allclose(filter_plan.sample_frames(1.0, 3.0, 0.4), [1.0, 1.4, 1.8, 2.2, 2.6, 3.0])


def test_values_at_original_keys_between_samples_are_linear():
    samples = np.array([1.0, 2.0, 3.0])
    filtered = np.array([[0.0, 10.0], [1.0, 20.0], [4.0, 30.0]])
    assert np.allclose(filter_plan.at_frames(samples, filtered, np.array([1.0, 2.5])), [[0.0, 10.0], [2.5, 25.0]])


def test_euler_repair_keeps_rotations_and_makes_angles_continuous(native):
    angles = np.zeros((6, 3))
    angles[:, 2] = [0.0, 1.0, 2.0, 3.0 - 2 * math.pi, 4.0 - 2 * math.pi, 5.0 - 2 * math.pi]
    out, = filter_plan.filter_groups(native, [('rotation', 'XYZ', angles, "r")], FilterSettings("euler"), 30.0,
                                     np.arange(6.0))
    assert np.allclose(out[:, 2], [0, 1, 2, 3, 4, 5])
    assert np.allclose(out[:, :2], 0.0)


def test_a_rotation_group_comes_back_in_its_mode_continuous_from_its_first_row(native):
    frames = 90
    angle = np.linspace(0.0, 4.0 * math.pi, frames)  # two whole turns about Z at constant speed
    values = np.stack([np.zeros(frames), np.zeros(frames), angle], axis=1)
    out, = filter_plan.filter_groups(native, [('rotation', 'XYZ', values, "r")],
                                     FilterSettings("gaussian", sigma=2.0), 30.0, np.arange(float(frames)))
    assert np.allclose(out, values, atol=1e-9)


def test_groups_filtered_together_equal_each_filtered_alone(native):
    rng = np.random.default_rng(3)
    frames = np.arange(1.0, 121.0)
    location = np.cumsum(rng.normal(0, 0.01, (120, 3)), axis=0)
    turn = np.stack([0.3 * np.sin(frames / 9), 0.2 * np.cos(frames / 7), 0.01 * frames], axis=1)
    turn += rng.normal(0, 0.02, turn.shape)
    q = np.hstack([np.cos(0.4 + 0.01 * frames)[:, None], np.zeros((120, 1)), np.sin(0.4 + 0.01 * frames)[:, None],
                   np.zeros((120, 1))])
    groups = [('vector', '', location, "loc"), ('rotation', 'ZXY', turn, "rot"), ('scalar', '', location[:, :1], "s"),
              ('rotation', 'QUATERNION', q, "q")]
    settings = FilterSettings("butterworth", cutoff=4.0)
    together = filter_plan.filter_groups(native, groups, settings, 30.0, frames)
    for group, got in zip(groups, together):
        alone, = filter_plan.filter_groups(native, [group], settings, 30.0, frames)
        assert np.allclose(got, alone, atol=1e-12)
    assert not np.allclose(together[0], location, atol=1e-3)


def test_a_value_that_is_not_finite_is_named_with_its_frame(native):
    values = np.zeros((10, 3))
    values[4, 1] = np.nan
    with pytest.raises(ValueError, match=r"loc\[1\] is not finite at frame 5"):
        filter_plan.filter_groups(native, [('vector', '', values, "loc")], FilterSettings(), 30.0,
                                  np.arange(1.0, 11.0))
