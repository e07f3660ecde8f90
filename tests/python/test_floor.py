"""core.floor (no Blender): feet_lifts, how far each standing foot is still to rise, eased on and off its stance
so that a large lift changes at most a given amount a frame, while a small one eases over the blend as before;
hips_lift, how far the hips come down where the feet float; judged on the returned curves themselves."""
import numpy as np
import pytest

from core import floor

FRAMES = 60
BLEND = 2.4          # frames (0.1 s at 24 fps)
SLOPE = 0.0167       # metres a frame (half a 0.8 m leg a second at 24 fps)


def lifts(lack: float, stance_frames=range(10, 30)):
    """One leg standing over stance_frames lacking lack metres of height, the other never standing; the
    floor far below (no sinking to prevent)."""
    stance = np.zeros((FRAMES, 2), dtype=bool)
    stance[list(stance_frames), 0] = True
    wanted = np.zeros((FRAMES, 2))
    heights = np.full((FRAMES, 2), -lack)
    heights[:, 1] = 1.0
    return floor.feet_lifts(wanted, heights, stance, -10.0, BLEND, slope=SLOPE)[:, 0]


def test_a_large_lift_comes_on_and_off_at_most_slope_a_frame():
    lift = lifts(0.08)  # an 8 cm lack: eased over 1.5 * 0.08 / SLOPE = 7.2 frames, not 2.4
    np.testing.assert_allclose(lift[10:30], 0.08, rtol=0, atol=1e-15)
    # The smoothstep's steepest change is 1.5 times its mean: SLOPE at most, up to rounding.
    assert np.abs(np.diff(lift)).max() <= SLOPE * (1 + 1e-12)
    assert lift[2] == 0.0 and lift[37] == 0.0  # eased out within 7.2 frames either side


def test_a_small_lift_eases_over_the_blend_as_before():
    lift = lifts(0.01)  # 1.5 * 0.01 / SLOPE = 0.9 frames: the blend's 2.4 frames
    x = 1.0 - np.arange(1, 4) / BLEND
    eased = np.clip(x, 0, 1) ** 2 * (3 - 2 * np.clip(x, 0, 1))
    np.testing.assert_allclose(lift[30:33], 0.01 * eased, rtol=0, atol=1e-15)
    np.testing.assert_allclose(lift[7:10][::-1], 0.01 * eased, rtol=0, atol=1e-15)


def test_without_a_slope_the_blend_alone_sets_the_ease():
    stance = np.zeros((FRAMES, 1), dtype=bool)
    stance[10:30] = True
    lift = floor.feet_lifts(np.zeros((FRAMES, 1)), np.full((FRAMES, 1), -0.08), stance, -10.0, BLEND)[:, 0]
    step = lambda x: x * x * (3 - 2 * x)  # noqa: E731
    steepest = 0.08 * (step(1 - 1 / BLEND) - step(1 - 2 / BLEND))  # 2.6 times SLOPE
    assert lift[33] == 0.0 and np.abs(np.diff(lift)).max() == pytest.approx(steepest, rel=1e-12)


def _both_standing(floats_0, floats_1, frames=range(10, 30)):
    stance = np.zeros((FRAMES, 2), dtype=bool)
    stance[list(frames)] = True
    floats = np.tile([floats_0, floats_1], (FRAMES, 1))
    return floor.hips_lift(np.zeros((FRAMES, 2)), stance, SLOPE, floats=floats)


def test_where_every_standing_foot_floats_the_hips_settle_until_the_nearest_stands():
    """Both feet standing 5 and 12 cm above where they should: the hips come down 5 cm (the other foot is the
    legs' to put down), eased in and out at most SLOPE a frame; without floats nothing moves."""
    lift = _both_standing(-0.05, -0.12)
    np.testing.assert_allclose(lift[10:30], -0.05, rtol=0, atol=1e-15)
    assert np.abs(np.diff(lift)).max() <= SLOPE * (1 + 1e-12)
    assert lift[0] == 0.0 and lift[-1] == 0.0
    stance = np.zeros((FRAMES, 2), dtype=bool)
    stance[10:30] = True
    assert not floor.hips_lift(np.zeros((FRAMES, 2)), stance, SLOPE).any()


def test_a_foot_that_stands_or_sinks_keeps_the_hips_up_and_a_swinging_one_is_not_asked():
    assert not _both_standing(-0.05, 0.0).any()       # one foot where it should be
    assert not _both_standing(-0.05, 0.03).any()      # one below it (the legs lift it)
    stance = np.zeros((FRAMES, 2), dtype=bool)
    stance[10:30, 0] = True                           # only the first foot stands
    floats = np.tile([-0.05, -0.3], (FRAMES, 1))
    lift = floor.hips_lift(np.zeros((FRAMES, 2)), stance, SLOPE, floats=floats)
    np.testing.assert_allclose(lift[10:30], -0.05, rtol=0, atol=1e-15)


def test_a_leg_that_cannot_reach_still_brings_the_hips_further_down():
    """reach_drops' need (here 8 cm) wins over a smaller float (5 cm)."""
    stance = np.zeros((FRAMES, 2), dtype=bool)
    stance[10:30] = True
    drops = np.zeros((FRAMES, 2))
    drops[:, 1] = -0.08
    lift = floor.hips_lift(drops, stance, SLOPE, floats=np.full((FRAMES, 2), -0.05))
    np.testing.assert_allclose(lift[10:30], -0.08, rtol=0, atol=1e-15)


def test_a_clip_whose_feet_come_down_where_the_rest_has_them_walks_on_the_rest_floor():
    # A child (its ankles 13 cm above its soles on a 50 cm leg, 26 %) and an adult (9 cm on 90 cm): the clip's
    # ankles held against the rest's ankles, each stands on its rest's floor (here the origin's level).
    for ankles, leg in ((13.28, 50.0), (9.0, 90.0)):
        lowest = ankles + np.array([0.0, 0.4, 3.0, 12.0])
        assert floor.clip_floor(0.0, lowest, leg, rest_lowest=ankles) == 0.0


def test_a_rest_hanging_below_its_origin_walks_on_the_origin_s_level_or_where_the_feet_come_down():
    lowest = np.full(10, 8.0)  # ankles 8 cm above the origin on every frame
    assert floor.clip_floor(-90.0, lowest, 90.0, rest_lowest=-82.0) == 0.0
    assert floor.clip_floor(-190.0, lowest + 60.0, 90.0, rest_lowest=-182.0) == pytest.approx(68.0)
