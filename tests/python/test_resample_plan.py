"""Resampling decisions that need no Blender: timing, grids, channel groups, Bezier handles."""
import numpy as np
import pytest
from core import resample_plan as rp


def test_paths_split_into_owner_and_property():
    assert rp.split_path('pose.bones["a.b"].location') == ('pose.bones["a.b"]', "location")
    assert rp.split_path("rotation_euler") == ("", "rotation_euler")
    assert rp.split_path('["prop"]') == ('["prop"]', "")


def test_channels_group_by_owner_and_kind():
    curves = [('pose.bones["A"].rotation_quaternion', i, f"q{i}") for i in range(4)]
    curves += [('pose.bones["A"].location', i, f"l{i}") for i in (2, 0)]
    curves += [('pose.bones["B"].rotation_euler', 1, "e1"), ('["custom"]', 0, "c"), ("location", 0, "ol")]
    groups = rp.group_channels(curves, euler_mode_of=lambda owner: 'ZXY' if "B" in owner else 'XYZ')
    kinds = [(g.owner, g.prop, g.kind, g.mode, sorted(g.curves)) for g in groups]
    assert kinds == [
        ('pose.bones["A"]', "rotation_quaternion", "rotation", "QUATERNION", [0, 1, 2, 3]),
        ('pose.bones["A"]', "location", "vector", "", [0, 2]),
        ('pose.bones["B"]', "rotation_euler", "rotation", "ZXY", [1]),
        ('["custom"]', "", "scalar", "", [0]),
        ("", "location", "vector", "", [0]),
    ]
    assert groups[0].size == 4 and groups[2].size == 3 and groups[1].size == 3
    assert groups[0].data_path == 'pose.bones["A"].rotation_quaternion'


def test_step_keeps_the_timeline():
    timing = rp.plan_timing(60.0, anchor=1.0, step=2.0)
    assert timing.scale == 1.0 and timing.step == 2.0 and timing.scene_fps is None


def test_new_rate_with_the_scene_rescales_frames_about_the_anchor():
    timing = rp.plan_timing(60.0, anchor=1.0, fps=24.0, change_scene_rate=True)
    assert timing.scene_fps == 24.0 and timing.step == 1.0
    assert np.allclose(timing.map([1.0, 61.0]), [1.0, 25.0])  # one second stays one second


def test_new_rate_without_the_scene_spaces_keys_in_scene_frames():
    timing = rp.plan_timing(60.0, anchor=1.0, fps=24.0)
    assert timing.scale == 1.0 and timing.step == 2.5 and timing.scene_fps is None


@pytest.mark.parametrize("kwargs, message", [
    ({}, "either a frame step or a frame rate"),
    ({"step": 1.0, "fps": 24.0}, "either a frame step or a frame rate"),
    ({"step": 0.0}, "frame step must be positive"),
    ({"fps": float("nan")}, "frame rate must be positive"),
])
def test_bad_timing_is_refused(kwargs, message):
    with pytest.raises(ValueError, match=message):
        rp.plan_timing(24.0, 1.0, **kwargs)


def test_grid_keeps_the_last_frame():
    assert np.allclose(rp.key_grid(1.0, 10.0, 2.5), [1.0, 3.5, 6.0, 8.5, 10.0])
    assert np.allclose(rp.key_grid(1.0, 11.0, 2.5), [1.0, 3.5, 6.0, 8.5, 11.0])
    assert np.allclose(rp.key_grid(5.0, 5.0, 1.0), [5.0])
    assert np.allclose(rp.key_grid(1.0, 4000.6, 1.0), np.arange(1.0, 4001.0))  # no key between frames


def test_a_groups_keys_are_the_grid_within_its_own_range():
    grid = np.arange(1.0, 41.0)
    assert np.allclose(rp.segment_grid(grid, 3.0, 7.0), [3, 4, 5, 6, 7])
    assert np.allclose(rp.segment_grid(grid, 2.4, 7.6), [3, 4, 5, 6, 7])  # fractional ends left out
    assert np.allclose(rp.segment_grid(grid, 2.2, 2.6), [2.2, 2.6])  # unless nothing else is left


def test_bezier_handles_reproduce_the_hermite_cubic():
    """De Casteljau on the handles equals the Hermite cubic, at non-uniform keys."""
    frames = np.array([0.0, 1.0, 3.5, 4.0])
    values = np.array([[0.0, 2.0, -1.0, 0.5]])
    slopes_in = np.array([[0.3, 1.0, -0.5, 2.0]])
    slopes_out = np.array([[0.1, 1.0, 0.7, 1.0]])
    lf, lv, rf, rv, aligned = rp.bezier_handles(frames, values, slopes_in, slopes_out)
    assert aligned.tolist() == [[False, True, False, False]]
    for i in range(3):
        h = frames[i + 1] - frames[i]
        for u in np.linspace(0, 1, 11):
            x = np.array([frames[i], rf[i], lf[i + 1], frames[i + 1]])
            y = np.array([values[0, i], rv[0, i], lv[0, i + 1], values[0, i + 1]])
            b = np.array([(1 - u) ** 3, 3 * u * (1 - u) ** 2, 3 * u * u * (1 - u), u ** 3])
            t = frames[i] + u * h
            assert b @ x == pytest.approx(t, abs=1e-12)  # time linear in u
            h00, h10, h01, h11 = 2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u, -2 * u**3 + 3 * u**2, u**3 - u**2
            hermite = (h00 * values[0, i] + h10 * h * slopes_out[0, i]
                       + h01 * values[0, i + 1] + h11 * h * slopes_in[0, i + 1])
            assert b @ y == pytest.approx(hermite, abs=1e-12)
