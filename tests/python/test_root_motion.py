"""root_motion (no Blender): leg length along the leg, smoothing, heading and the floor root's carry,
against hand-derived cases and scipy's rotations."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from core import root_motion as rm
from rotations import quaternion_angles


def wxyz(r: Rotation) -> np.ndarray:
    return np.roll(r.as_quat(), 1, axis=-1)


def leg(turn=None):
    """A leg: hip (0.1, 0, 1), knee 0.45 below, ankle 0.45 below that, a foot to the ball 0.08 above the
    floor; heads and tails of thigh, shin, foot, toe. turn: a Rotation applied to everything below the hip."""
    hip = np.array([0.1, 0.0, 1.0])
    knee, ankle = hip + [0, -0.01, -0.45], hip + [0, 0.0, -0.90]
    ball, tip = np.array([0.1, -0.14, 0.02]), np.array([0.1, -0.2, 0.02])
    heads = np.array([hip, knee, ankle, ball])
    tails = np.array([knee, ankle, ball, tip])
    if turn is not None:
        heads = hip + turn.apply(heads - hip)
        tails = hip + turn.apply(tails - hip)
    return rm.Leg(0, 1, 2, (2, 3)), heads, tails


def test_leg_length_is_thigh_shin_and_the_ankles_height_above_the_sole():
    spec, heads, tails = leg()
    down = (heads[2] - heads[1]) / np.linalg.norm(heads[2] - heads[1])
    expected = (np.linalg.norm(heads[1] - heads[0]) + np.linalg.norm(heads[2] - heads[1])
                + max((p - heads[2]) @ down for p in (heads[3], tails[2], tails[3])))
    assert rm.leg_length(spec, heads, tails) == pytest.approx(expected, abs=1e-15)
    # By hand: two bones of 0.450111, the ball 0.0769 beyond the ankle along the (slightly tilted) shin.
    assert rm.leg_length(spec, heads, tails) == pytest.approx(2 * 0.450111 + 0.07687, abs=1e-5)


@pytest.mark.parametrize("seed", range(5))
def test_turning_the_whole_leg_at_the_hip_changes_nothing(seed):
    """An A-pose spreads the legs: the same leg, turned anyhow at the hip, measures the same."""
    spec, heads, tails = leg()
    turned = leg(Rotation.random(random_state=seed))
    assert rm.leg_length(spec, *turned[1:]) == pytest.approx(rm.leg_length(spec, heads, tails), abs=1e-14)
    # The hips' height above the lowest point, the old measure, does change.
    assert abs(turned[1][:, 2].min() - heads[:, 2].min()) > 1e-3 or seed == 0


def test_a_bent_knee_on_a_flat_foot_counts_the_ankle_as_high_as_it_stands():
    """Goblin's stance: thigh forward, shin slanted back 23 degrees, the foot flat on the floor. Along the slanted
    shin the ball is only 5 cm beyond the ankle; given up, the ankle's 15 cm above the sole counts, as it will when
    the leg straightens (thigh 41.9, shin 41.2, the ankle 15.1 above the ball: Goblin_m's rest, in cm)."""
    hip = np.array([0.0, 0.0, 98.0])
    knee = hip + [0.0, -13.0, -39.6]        # the file's (x, y, z) offsets as Blender's (x, -z, y)
    ankle = knee + [0.0, 16.0, -37.7]
    ball = ankle + [0.0, -20.6, -15.1]
    tip = ball + [0.0, -11.3, 0.9]
    heads, tails = np.array([hip, knee, ankle, ball]), np.array([knee, ankle, ball, tip])
    spec = rm.Leg(0, 1, 2, (2, 3))
    upper, lower = np.linalg.norm(knee - hip), np.linalg.norm(ankle - knee)
    down = (ankle - knee) / lower
    along = max((p - ankle) @ down for p in (ball, tip))
    assert along < 6.0
    assert rm.leg_length(spec, heads, tails) == pytest.approx(upper + lower + along, abs=1e-12)
    assert rm.leg_length(spec, heads, tails, up=(0, 0, 1)) == pytest.approx(upper + lower + 15.1, abs=1e-12)
    # An upright leg whose foot turned with it (the A-pose case above) keeps the measure along the shin.
    spec, heads, tails = leg(Rotation.from_euler("y", 20, degrees=True))
    assert rm.leg_length(spec, heads, tails, up=(0, 0, 1)) == pytest.approx(rm.leg_length(spec, heads, tails),
                                                                             abs=1e-14)

def test_a_zero_pose_foot_takes_the_height_it_is_given():
    spec = rm.Leg(0, 1, 2, (2,))
    heads = np.array([[0, 0, 0], [0.4, 0, 0], [0.8, 0, 0]], dtype=float)  # everything along X
    tails = np.array([[0.4, 0, 0], [0.8, 0, 0], [0.95, 0, 0]], dtype=float)
    assert rm.leg_length(spec, heads, tails, ankle_lowest=0.07) == pytest.approx(0.87)
    assert rm.leg_length(spec, heads, tails) == pytest.approx(0.88)  # a tenth of thigh + shin


def test_smoothing_keeps_a_straight_line_exactly_and_calms_a_sway():
    t = np.arange(200.0)
    line = np.stack([0.013 * t - 2.0, -0.004 * t, np.zeros_like(t)], axis=1)
    np.testing.assert_allclose(rm.smooth(line, 7.5), line, atol=1e-12)
    sway = line + np.stack([0.02 * np.sin(t / 3), np.zeros_like(t), np.zeros_like(t)], axis=1)
    inside = slice(25, -25)  # the ends are point-reflected: they keep the sway they end on
    assert np.abs(rm.smooth(sway, 7.5) - line)[inside].max() < 0.1 * np.abs(sway - line).max()
    np.testing.assert_array_equal(rm.smooth(sway, 0.0), sway)


def test_heading_is_the_turn_about_z_and_runs_on_past_half_a_turn():
    angles = np.linspace(0.0, 3 * np.pi, 50)
    tilt = wxyz(Rotation.from_euler("x", 0.3))
    q = rm.multiply(rm.about_z(angles), np.broadcast_to(tilt, (50, 4)))  # turned about Z after a tilt
    np.testing.assert_allclose(rm.heading(q), angles, atol=1e-12)


def test_extracted_root_follows_the_hips_on_the_floor():
    n = 120
    t = np.arange(n)
    yaw = np.radians(0.5) * t
    hips_q = rm.about_z(yaw)
    hips_h = np.stack([0.01 * t, 0.02 * t, 0.95 + 0.02 * np.sin(t)], axis=1)
    root_q, root_h = rm.extract_track(hips_q, hips_h, np.array([1.0, 0, 0, 0]), np.array([0, 0, 0.95]),
                                      np.array([1.0, 0, 0, 0]), np.zeros(3), sigma_frames=5)
    np.testing.assert_allclose(root_h[:, 2], 0.0)
    np.testing.assert_allclose(root_h[:, :2], hips_h[:, :2], atol=1e-12)  # a straight track stays exact
    np.testing.assert_allclose(rm.heading(root_q), yaw, atol=1e-12)


def test_a_copied_floor_root_scales_its_stride_apart_from_its_height():
    """copy_track: the source's floor root moved from its match pose, turned into the target's space and
    scaled; across the floor times horizontal besides (Unreal's Scale Horizontal), 0 keeping the match pose's
    place; its height only scaled, or kept when vertical is False."""
    n = 40
    t = np.arange(n)
    source_q = rm.about_z(np.radians(0.7) * t)
    source_h = np.stack([0.03 * t, -0.01 * t, 0.05 * np.sin(t)], axis=1) + [0.2, 0.1, 0.0]
    match_q, match_h = np.array([1.0, 0, 0, 0]), np.array([0.2, 0.1, 0.0])
    space = wxyz(Rotation.from_euler("z", 90, degrees=True))  # the target faces a quarter turn round
    root_h = np.array([0.0, 0.0, 0.01])
    moved = 0.5 * Rotation.from_euler("z", 90, degrees=True).apply(source_h - match_h)
    for horizontal, vertical in ((1.0, True), (1.3, True), (0.0, True), (1.3, False)):
        _, heads = rm.copy_track(source_q, source_h, match_q, match_h, space, match_q, root_h, 0.5, horizontal,
                                 vertical)
        np.testing.assert_allclose(heads[:, :2], root_h[:2] + horizontal * moved[:, :2], atol=1e-12)
        np.testing.assert_allclose(heads[:, 2], root_h[2] + (moved[:, 2] if vertical else 0.0), atol=1e-12)


def test_carry_keeps_the_hips_where_they_were_under_a_moving_root():
    """Blender's pose: pose = parent_pose @ parent_rest^-1 @ rest @ basis; re-expressed channels must
    put the hips back exactly, whatever the root does."""
    rng = np.random.default_rng(4)
    rest_q = wxyz(Rotation.random(2, random_state=5))
    rest_h = np.array([[0.0, 0.0, 0.0], [0.02, 0.03, 0.94]])
    rest = rm.FloorRootRest(0, -1, 1, 0, rest_q, rest_h)
    n = 30
    hips_rot = wxyz(Rotation.random(n, random_state=6))
    hips_head = rng.normal(size=(n, 3))
    root_rot = wxyz(Rotation.random(n, random_state=7))
    root_head = rng.normal(size=(n, 3)) * [1, 1, 0]

    def hips_parent(root_basis, root_location):  # the root is the top bone: its pose from its channels
        return rm.multiply(rest_q[0], root_basis), rest_h[0] + rm.rotate(rest_q[0], root_location)

    rb, rl, hb, hl = rm.carry(rest, root_rot, root_head, None, hips_parent, hips_rot, hips_head)
    parent_q, parent_h = hips_parent(rb, rl)
    np.testing.assert_allclose(parent_q * np.sign(parent_q[:, :1] * root_rot[:, :1]), root_rot, atol=1e-12)
    np.testing.assert_allclose(parent_h, root_head, atol=1e-12)
    relative = rm.multiply(rm.conjugate(rest_q[0]), rest_q[1])
    frame = rm.multiply(parent_q, relative)
    got_q = rm.multiply(frame, hb)
    got_h = parent_h + rm.rotate(parent_q, rm.rotate(rm.conjugate(rest_q[0]), rest_h[1] - rest_h[0])) \
        + rm.rotate(frame, hl)
    assert quaternion_angles(got_q, hips_rot).max() < 1e-12
    np.testing.assert_allclose(got_h, hips_head, atol=1e-12)
