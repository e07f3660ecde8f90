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
    out = filter_plan.filter_values(native, 'rotation', 'XYZ', angles, FilterSettings("euler"), 30.0, "r")
    assert np.allclose(out[:, 2], [0, 1, 2, 3, 4, 5])
    assert np.allclose(out[:, :2], 0.0)


def test_a_rotation_group_comes_back_in_its_mode_continuous_from_its_first_row(native):
    frames = 90
    angle = np.linspace(0.0, 4.0 * math.pi, frames)  # two whole turns about Z at constant speed
    values = np.stack([np.zeros(frames), np.zeros(frames), angle], axis=1)
    out = filter_plan.filter_values(native, 'rotation', 'XYZ', values, FilterSettings("gaussian", sigma=2.0),
                                    30.0, "r")
    assert np.allclose(out, values, atol=1e-9)
