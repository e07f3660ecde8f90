"""Foot contact detection, plants and blend weights on hand-made trajectories (no Blender)."""
import numpy as np
import pytest

from core import foot_contacts as fc
import foot_targets_reference as ref

LEG = 0.9


def step_pattern(fps, seconds=4.0, period=1.0, stance=0.5, lift=0.2, stride=0.6, floor=0.05):
    """One foot point walking: planted for `stance` of each `period`, then a smooth arc forward.
    Returns points (frames, 1, 3) and the true contact mask."""
    t = np.arange(int(round(seconds * fps))) / fps
    phase = (t % period) / period
    cycle = np.floor(t / period)
    swing = np.clip((phase - stance) / (1 - stance), 0, 1)
    ease = swing * swing * (3 - 2 * swing)
    x = (cycle + ease) * stride
    z = floor + lift * np.sin(np.pi * swing)
    points = np.stack([x, np.zeros_like(x), z], axis=1)[:, None, :]
    return points, t, phase < stance


def test_step_pattern_contacts_match_stance():
    points, t, stance = step_pattern(60)
    contacts = fc.detect(points, 60, LEG)
    runs = fc.intervals(contacts[:, 0])
    assert len(runs) == 4
    for s, e in runs:
        # Contact lies within a stance (give a frame for the lift-off's ramp) and covers most of it.
        assert stance[s:e - 1].all()
        assert (e - s) / 60 > 0.4


def test_floor_estimated_when_not_given():
    points, _, _ = step_pattern(60, floor=1.7)
    assert abs(fc.estimate_floor(points) - 1.7) < 1e-9
    assert np.array_equal(fc.detect(points, 60, LEG, floor=None), fc.detect(points - [0, 0, 1.7], 60, LEG))
    # Taken as given at 0, every point is far above the floor: it never lands.
    assert not fc.detect(points, 60, LEG, floor=0.0).any()


def test_units_do_not_matter():
    points, _, _ = step_pattern(60)
    assert np.array_equal(fc.detect(points, 60, LEG), fc.detect(points * 100, 60, LEG * 100))


def test_frame_rate_independent():
    a, ta, _ = step_pattern(60)
    b, tb, _ = step_pattern(30)
    ra = [(ta[s], ta[e - 1]) for s, e in fc.intervals(fc.detect(a, 60, LEG)[:, 0])]
    rb = [(tb[s], tb[e - 1]) for s, e in fc.intervals(fc.detect(b, 30, LEG)[:, 0])]
    assert len(ra) == len(rb) == 4
    assert np.allclose(ra, rb, atol=1.0 / 30 + 1e-9)


def test_hysteresis_does_not_flicker():
    fps = 60
    frames = 120
    points = np.zeros((frames, 1, 3))
    # Planted, with the speed dithering around the enter threshold: stays in once in.
    rng = np.random.default_rng(1)
    settings = fc.ContactSettings(smoothing=0.0)
    speed = settings.speed_enter * LEG * (1 + 0.2 * rng.standard_normal(frames))
    speed[:5] = 0.1 * settings.speed_enter * LEG
    points[:, 0, 0] = np.cumsum(np.abs(speed)) / fps
    contacts = fc.detect(points, fps, LEG, settings=settings)
    assert len(fc.intervals(contacts[:, 0])) == 1
    # Without hysteresis (leave == enter) the same motion flickers.
    strict = fc.ContactSettings(smoothing=0.0, speed_leave=settings.speed_enter,
                                height_leave=settings.height_enter, min_length=0, min_gap=0)
    assert len(fc.intervals(fc.detect(points, fps, LEG, settings=strict)[:, 0])) > 3


@pytest.mark.parametrize("wander, planted", [(0.059, True), (0.061, False)])
def test_a_slide_is_a_stance_but_no_plant(wander, planted):
    """A foot point low and slow throughout that wanders (a catwalk's turn, 26 cm over two seconds) stands on
    the floor (a contact) but is held still only within max_drift leg lengths of its mean position."""
    fps, frames = 60, 120
    points = np.zeros((frames, 1, 3))
    # Out and back along x: wander leg lengths from the mean at the ends and the middle, a slow slide.
    points[:, 0, 0] = wander * LEG * np.cos(np.linspace(0.0, 2 * np.pi, frames))
    contacts = fc.detect(points, fps, LEG)
    assert contacts[:, 0].all()
    held = fc.plantable(points, contacts, LEG)
    assert held[:, 0].all() == planted and held[:, 0].any() == planted


def _foot(frames, ankle, ball):
    points = np.zeros((frames, 2, 3))
    points[:, 0, :2], points[:, 1, :2] = ankle, ball
    return points


def test_a_foot_turning_about_its_ball_holds_the_ball_only():
    """The ankle swings 30 degrees about a still ball (a pivot): the ball is held, the ankle is not; the same
    foot sliding along without turning (both points alike) is held whole."""
    frames, length = 60, 0.15 * LEG
    angle = np.radians(np.linspace(0.0, 30.0, frames))
    ankle = np.stack([-length * np.sin(angle), length * np.cos(angle)], axis=1)  # the ball at the origin
    points = _foot(frames, ankle, np.zeros((frames, 2)))
    both = np.ones((frames, 2), dtype=bool)
    held = fc.plantable(points, both, LEG, feet=((0, 1),))
    assert held[:, 1].all() and not held[:, 0].any()
    slide = np.stack([np.linspace(0.0, 0.04 * LEG, frames), np.zeros(frames)], axis=1)
    points = _foot(frames, slide + [0.0, length], slide)
    assert fc.plantable(points, both, LEG, feet=((0, 1),)).all()


@pytest.mark.parametrize("degrees, planted", [(24.0, True), (26.0, False)])
def test_a_foot_swivelling_is_no_plant(degrees, planted):
    """Both points of a foot swivel about its middle (a kick's standing foot): held only while the foot's line
    across the floor turns less than max_turn degrees from its mean."""
    frames, half = 60, 0.075 * LEG
    angle = np.radians(np.linspace(-degrees, degrees, frames))
    line = half * np.stack([-np.sin(angle), np.cos(angle)], axis=1)
    points = _foot(frames, -line, line)
    settings = fc.ContactSettings(max_drift=1.0, max_pivot=1.0)  # only the turn decides here
    held = fc.plantable(points, np.ones((frames, 2), dtype=bool), LEG, settings, feet=((0, 1),))
    assert held.all() == planted and held.any() == planted


def test_minimum_length_and_gap():
    c = np.zeros((40, 1), dtype=bool)
    c[2:4] = True      # 2 frames: too short at 60 fps for 0.05 s
    c[10:30] = True
    c[31:35] = True    # a 1-frame gap: closed
    out = fc._filter_runs(c, min_frames=3, min_gap_frames=1)
    assert fc.intervals(out[:, 0]) == [(10, 35)]


def test_hysteresis_vectorised_matches_state_machine():
    rng = np.random.default_rng(3)
    enter = rng.random((500, 3)) < 0.1
    stay = enter | (rng.random((500, 3)) < 0.8)
    expected = np.zeros_like(enter)
    for p in range(3):
        on = False
        for f in range(500):
            on = enter[f, p] or (on and stay[f, p])
            expected[f, p] = on
    assert np.array_equal(fc._hysteresis(enter, stay), expected)


def test_blend_weights_ramp():
    c = np.zeros((30, 1), dtype=bool)
    c[10:15] = True
    w = ref.blend_weights(c, 4)[:, 0]
    assert np.all(w[10:15] == 1)
    assert np.all(w[:5] == 0) and np.all(w[20:] == 0)
    assert np.all(np.diff(w[5:11]) > 0) and np.all(np.diff(w[14:20]) < 0)
    assert np.all((w >= 0) & (w <= 1))
    assert np.allclose(w[5:10], w[19:14:-1])  # symmetric ramps
    assert not ref.blend_weights(np.zeros((5, 2), bool), 3).any()


def test_plants_and_targets(native):
    points, _, _ = step_pattern(60)
    contacts = fc.detect(points, 60, LEG)
    plants = ref.plant_positions(points, contacts)[0]
    runs = fc.intervals(contacts[:, 0])
    for (s, e), plant in zip(runs, plants):
        assert np.allclose(plant, points[s:e, 0].mean(axis=0))
    targets, weights = ref.plant_targets(points, contacts, 6)
    for (s, e), plant in zip(runs, plants):
        assert np.allclose(targets[s:e, 0], plant)
    # The native job the add-on uses: the same weights, and the points blended to the plants by them.
    native_targets, native_weights = fc.plant_targets(native, points, contacts, 6)
    assert np.allclose(native_weights, weights, rtol=0, atol=1e-15)
    assert np.allclose(native_targets, ref.foot_targets(points, targets, weights, feet=()), rtol=0, atol=1e-12)
    ik = ref.foot_targets(np.repeat(points, 2, axis=1), np.repeat(targets, 2, axis=1),
                          np.concatenate([weights, np.zeros_like(weights)], axis=1), feet=((0, 1),))
    # The unplanted point rides along with the planted one.
    assert np.allclose(ik[:, 1] - points[:, 0], ik[:, 0] - points[:, 0])
    assert np.allclose(ref.foot_targets(points, targets, np.zeros_like(weights), feet=()), points)


def test_rigid_pairs_keep_the_distance(native):
    frames = 50
    ankle = np.zeros((frames, 3)) + [0, 0, 0.08]
    ankle[:, 0] += np.linspace(0, 0.02, frames)  # a slide: the two means differ by other spans
    ball = ankle + [0.15, 0, -0.06]
    points = np.stack([ankle, ball], axis=1)
    contacts = np.zeros((frames, 2), dtype=bool)
    contacts[0:30, 0] = True
    contacts[20:50, 1] = True
    a, b = ref.plant_positions(points, contacts, rigid_pairs=[(0, 1)])
    assert np.isclose(np.linalg.norm(b[0] - a[0]), np.linalg.norm([0.15, 0, -0.06]))
    targets, _ = fc.plant_targets(native, points, contacts, 3, rigid_pairs=[(0, 1)])
    assert np.allclose(np.linalg.norm(targets[:, 1] - targets[:, 0], axis=1), np.linalg.norm([0.15, 0, -0.06]))


@pytest.mark.parametrize("seed", range(6))
def test_native_targets_equal_the_numpy_reference(native, seed):
    """Random feet with random contacts (some overlapping, some none): the native job gives the reference's
    targets and weights, step for step."""
    rng = np.random.default_rng(seed)
    frames = int(rng.integers(1, 400))
    points = np.cumsum(rng.normal(scale=0.01, size=(frames, 4, 3)), axis=0) + rng.normal(size=(1, 4, 3))
    contacts = rng.random((frames, 4)) < rng.uniform(0.0, 0.2)
    contacts = np.logical_or.accumulate(contacts, axis=0) & ~np.logical_or.accumulate(
        rng.random((frames, 4)) < 0.02, axis=0) if seed % 2 else np.repeat(contacts[::7], 7, axis=0)[:frames]
    if seed == 0:
        contacts[:, 2:] = False  # a foot with no contact at all
    blend = int(rng.integers(0, 12))
    pairs = ((0, 1), (2, 3))
    expected_planted, expected_weights = ref.plant_targets(points, contacts, blend, pairs)
    expected = ref.foot_targets(points, expected_planted, expected_weights, pairs)
    targets, weights = fc.plant_targets(native, points, contacts, blend, pairs)
    assert np.allclose(weights, expected_weights, rtol=0, atol=1e-15)
    assert np.allclose(targets, expected, rtol=0, atol=1e-12)


def test_errors():
    with pytest.raises(ValueError, match="shape"):
        fc.detect(np.zeros((5, 3)), 60, 1)
    bad = np.zeros((5, 1, 3))
    bad[3, 0, 1] = np.nan
    with pytest.raises(ValueError, match="frame index 3"):
        fc.detect(bad, 60, 1)
    with pytest.raises(ValueError, match="leave"):
        fc.detect(np.zeros((5, 1, 3)), 60, 1, settings=fc.ContactSettings(speed_leave=0.1))

