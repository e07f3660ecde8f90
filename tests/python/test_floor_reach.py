"""core.floor.leg_reaches (no Blender): how far a leg reaches in the feet's solve, whose knee straightens only
as far as its rest pose or the clip has it, against the law of cosines; and the hips' drop it gives."""
import numpy as np
import pytest

from core import floor

THIGH, SHIN = 0.45, 0.43
STRAIGHT = THIGH + SHIN


def bent(degrees):
    """Hip joint to ankle of a leg whose knee bends by degrees (the law of cosines: the angle between the
    thigh's and the shin's directions)."""
    return float(np.sqrt(THIGH ** 2 + SHIN ** 2 + 2 * THIGH * SHIN * np.cos(np.radians(degrees))))


def test_a_straight_rest_reaches_a_thousandth_short_of_straight():
    reach = floor.leg_reaches([STRAIGHT], [STRAIGHT], [bent(30.0)])
    assert reach == pytest.approx([0.999 * STRAIGHT], rel=1e-15)


def test_a_knee_bent_at_rest_reaches_as_far_as_its_rest():
    """Blender's metarig stands with its knees bent 10 degrees; a clip that never straightens them further."""
    reach = floor.leg_reaches([STRAIGHT], [bent(10.0)], [bent(25.0)])
    assert reach == pytest.approx([bent(10.0) - 1e-3 * STRAIGHT], rel=1e-15)
    assert reach[0] < 0.999 * STRAIGHT - 2e-3  # farther than the solve's knee allows, before


def test_a_clip_that_straightens_further_reaches_as_far_as_it_does():
    reach = floor.leg_reaches([STRAIGHT, STRAIGHT], [bent(10.0), bent(10.0)], [bent(4.0), STRAIGHT * (1 + 1e-7)])
    # Never beyond straight (a float32 pose may measure a hair over it).
    assert reach == pytest.approx([bent(4.0) - 1e-3 * STRAIGHT, 0.999 * STRAIGHT], rel=1e-15)


def test_the_hips_come_down_to_where_the_bent_knee_reaches():
    """reach_drops with that reach: the hip joint ends as far from the lowered ankle as the leg reaches."""
    up = np.array([0.0, 0.0, 1.0])
    hip, ankle = np.array([[[0.1, 0.0, 0.95]]]), np.array([[[0.1, 0.05, 0.09]]])
    rise = np.array([[-0.03]])  # the foot must come 3 cm down
    reach = floor.leg_reaches([STRAIGHT], [bent(10.0)], [bent(10.0)])
    drop = floor.reach_drops(hip, ankle, rise, up, reach)
    assert drop[0, 0] < 0
    lowered_hip, lowered_ankle = hip[0, 0] + drop[0, 0] * up, ankle[0, 0] + rise[0, 0] * up
    assert np.linalg.norm(lowered_hip - lowered_ankle) == pytest.approx(reach[0], rel=1e-12)
