"""A BVH file's printed frame time to Blender's (fps, fps_base): the rate the file meant, exactly."""
import pytest
from core.frame_rates import scene_rate


@pytest.mark.parametrize("frame_time, expected", [
    (0.016667, (60, 1.0)),       # 60 fps as files print it (1/0.016667 = 59.9988)
    (0.0166667, (60, 1.0)),
    (1 / 60, (60, 1.0)),
    (0.033333, (30, 1.0)),
    (0.008333, (120, 1.0)),
    (0.01, (100, 1.0)),
    (0.041667, (24, 1.0)),
    (0.041708, (24, 1.001)),     # 23.976 fps (NTSC film)
    (0.033367, (30, 1.001)),     # 29.97 fps
    (0.016683, (60, 1.001)),     # 59.94 fps
])
def test_printed_frame_times_give_the_rate_meant(frame_time, expected):
    fps, base = scene_rate(frame_time)
    assert (fps, base) == expected


def test_an_odd_rate_is_kept_exactly():
    fps, base = scene_rate(1 / 37.3)
    assert fps == 37 and abs(fps / base - 37.3) < 1e-9


@pytest.mark.parametrize("bad", [0.0, -0.1, float("nan"), float("inf")])
def test_bad_frame_times_are_refused(bad):
    with pytest.raises(ValueError, match="frame time"):
        scene_rate(bad)
