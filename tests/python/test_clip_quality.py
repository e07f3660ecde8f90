"""A clip's quality figures on motions whose answers are known, rotations checked with scipy."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from core import clip_quality
from core.clip_quality import BoneMotion, FeetMotion

UP = np.array([0.0, 0.0, 1.0])


def _feet(points, stance, rest=None):
    points = np.asarray(points, dtype=float)
    return FeetMotion(points=points, rest=np.zeros((points.shape[1], 3)) if rest is None else rest,
                      stance=np.asarray(stance, dtype=bool), up=UP)


def test_a_foot_that_slides_5_mm_a_frame_over_a_stance_of_5_frames_slid_20_mm():
    frames = 10
    points = np.zeros((frames, 1, 3))
    points[:, 0, 0] = np.arange(frames) * 0.005   # 5 mm a frame along the floor
    points[:, 0, 2] = 0.3                         # and lifted, which is not sliding
    stance = np.zeros((frames, 1), dtype=bool)
    stance[2:7] = True
    assert clip_quality.foot_sliding_mm(_feet(points, stance)) == pytest.approx([20.0])


def test_each_stance_is_measured_from_where_it_began():
    points = np.zeros((8, 1, 3))
    points[4:, 0, 1] = 1.0                        # the foot moved a metre between the two stances
    points[7, 0, 1] = 1.003
    stance = np.array([[1], [1], [1], [0], [1], [1], [1], [1]], dtype=bool)
    assert clip_quality.foot_sliding_mm(_feet(points, stance)) == pytest.approx([0.0, 3.0])


def test_floor_offsets_are_heights_over_the_rest_pose_on_stance_frames_only():
    rest = np.array([[0.0, 0.0, 0.08]])           # an ankle 8 cm over the floor when the rig stands
    points = np.array([[[0.0, 0.0, 0.1]], [[0.0, 0.0, 0.07]], [[0.0, 0.0, 0.5]]])
    stance = np.array([[1], [1], [0]], dtype=bool)
    offsets = clip_quality.floor_offsets_mm(_feet(points, stance, rest))
    assert offsets == pytest.approx([20.0, -10.0])
    quality = clip_quality.measure(_feet(points, stance, rest), None)
    assert quality.floor_above_mm == pytest.approx(20.0) and quality.floor_below_mm == pytest.approx(10.0)


def _bones(source_rot, target_rot):
    y = np.array([0.0, 1.0, 0.0])
    s, t = Rotation.from_quat(source_rot), Rotation.from_quat(target_rot)
    w_first = lambda r: np.roll(r.as_quat(), 1, axis=-1)  # noqa: E731
    frames = len(source_rot)
    return BoneMotion(source_directions=s.apply(y).reshape(frames, 1, 3),
                      target_directions=t.apply(y).reshape(frames, 1, 3),
                      source_rotations=w_first(s).reshape(frames, 1, 4),
                      target_rotations=w_first(t).reshape(frames, 1, 4), names=["arm"])


def test_direction_error_and_a_pop_beyond_the_sources_motion():
    angles = np.radians([0.0, 10.0, 20.0, 30.0, 40.0])
    source = Rotation.from_rotvec(np.outer(angles, [1.0, 0.0, 0.0]))
    target_angles = angles.copy()
    target_angles[3] += np.radians(25.0)          # the target jumps 35 degrees where the source turns 10
    target = Rotation.from_rotvec(np.outer(target_angles, [1.0, 0.0, 0.0]))
    quality = clip_quality.measure(None, _bones(source.as_quat(), target.as_quat()))
    assert quality.direction_worst_deg == pytest.approx(25.0)
    assert quality.direction_worst_bone == "arm"
    assert quality.pop_worst_deg == pytest.approx(25.0) and quality.pop_frame == 3
    twist = Rotation.from_rotvec(np.outer(np.radians([0.0, 0.0, 90.0, 90.0, 90.0]), [0.0, 1.0, 0.0]))
    twisted = clip_quality.measure(None, _bones(source.as_quat(), (source * twist).as_quat()))
    assert twisted.direction_worst_deg == pytest.approx(0.0, abs=1e-6)   # a twist about the bone's line
    target = source * twist
    steps = np.degrees((target[1:] * target[:-1].inv()).magnitude() - (source[1:] * source[:-1].inv()).magnitude())
    assert twisted.pop_worst_deg == pytest.approx(steps.max()) and steps.max() > 70  # is a pop all the same


def test_nothing_to_measure_is_none_not_zero():
    quality = clip_quality.measure(_feet(np.zeros((3, 1, 3)), np.zeros((3, 1))), None)
    assert quality.sliding_worst_mm is None and quality.direction_worst_deg is None


def test_the_turn_that_lines_two_clips_up_about_the_vertical():
    rng = np.random.default_rng(3)
    a = rng.normal(size=(20, 5, 3))
    a /= np.linalg.norm(a, axis=-1, keepdims=True)
    turn = Rotation.from_rotvec([0.0, 0.0, np.radians(73.0)])
    found = clip_quality.best_turn_about(UP, a, turn.apply(a.reshape(-1, 3)).reshape(a.shape))
    assert np.degrees(Rotation.from_quat(np.roll(found, -1)).magnitude()) == pytest.approx(73.0)
    assert np.allclose(np.roll(found, -1), turn.as_quat()) or np.allclose(np.roll(found, -1), -turn.as_quat())


def test_a_foot_stands_on_its_lowest_standing_point():
    rest = np.array([[0.0, 0.0, 0.08], [0.0, 0.1, 0.0]])             # ankle 8 cm up, ball on the floor
    points = np.array([[[0.0, 0.0, 0.12], [0.0, 0.1, 0.0]],          # heel lifted 4 cm, ball down: on it
                       [[0.0, 0.0, 0.11], [0.0, 0.1, 0.03]]])        # the whole foot 3 cm up: a hover
    stance = np.array([[1, 1], [1, 1]], dtype=bool)
    feet = FeetMotion(points, rest, stance, UP, feet=((0, 1),))
    assert clip_quality.floor_offsets_mm(feet) == pytest.approx([0.0, 30.0])
