"""core/floor_fit: each rig's floor, leg length and standing feet, on the sample characters as plain data,
against joints measured by hand with numpy and an independent posing (tests/common/rig_fk.py)."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import characters
import rig_fk
from core import floor_fit
from core.rig_data import Pose, RigData
from plain_rigs import bone_rest, from_spec, placed

UP = np.array([0.0, 0.0, 1.0])


def _joints(spec, side):
    bone = {b.canonical: b for b in spec.bones}
    return (np.array(bone[f"thigh.{side}"].head), np.array(bone[f"shin.{side}"].head),
            np.array(bone[f"foot.{side}"].head), np.array(bone[f"toe.{side}"].head),
            np.array(bone[f"toe.{side}"].tail))


def test_legs_are_the_labelled_thigh_shin_foot_and_all_below():
    rig = from_spec(characters.MIXAMO_T)
    legs = floor_fit.legs(rig, rig.body)
    assert len(legs) == 2
    for leg, side in zip(legs, "LR"):
        assert rig.names[leg.thigh] == rig.body.limbs[f"thigh.{side}"]
        assert {rig.names[b] for b in leg.below_ankle} == {rig.body.limbs[f"foot.{side}"],
                                                            rig.body.limbs[f"toe.{side}"]}


@pytest.mark.parametrize("spec", characters.CHARACTERS, ids=lambda s: s.name)
def test_leg_length_by_hand(spec):
    """thigh + shin + how far the foot reaches beyond the ankle along the shin, or how high the ankle stands
    above the foot's lowest point where that is more (the sample rigs' shins slant a little), both legs' mean."""
    rig = from_spec(spec)
    by_hand = []
    for side in "LR":
        hip, knee, ankle, ball, tip = _joints(spec, side)
        down = (ankle - knee) / np.linalg.norm(ankle - knee)
        ankle_height = max(max((p - ankle) @ down for p in (ball, tip)), max((ankle - p) @ UP for p in (ball, tip)))
        by_hand.append(np.linalg.norm(knee - hip) + np.linalg.norm(ankle - knee) + ankle_height)
    hips = rig.index(rig.body.hips)
    assert floor_fit.leg_length(rig, rig.body, Pose.rest(rig), UP, hips) == pytest.approx(np.mean(by_hand),
                                                                                           abs=1e-14)



@pytest.mark.parametrize("spec", characters.CHARACTERS, ids=lambda s: s.name)
def test_standing_height_by_hand_and_the_same_with_the_legs_spread(spec):
    """How high the hips stand: the hips' head above the hip joints, hip joint to ankle, the ankle above the sole
    (leg_length's), and the clearance; legs spread 20 degrees at the hip (an A-pose) measure the same, whereas
    the hips' head's height above the floor drops."""
    rig = from_spec(spec)
    hips = rig.index(rig.body.hips)
    rest = Pose.rest(rig)
    legs_length = floor_fit.leg_length(rig, rig.body, rest, UP, hips)
    by_hand = []
    for side in "LR":
        hip, knee, ankle, _, _ = _joints(spec, side)
        by_hand.append((rig.heads[hips] - hip) @ UP + np.linalg.norm(ankle - hip)
                       + legs_length - np.linalg.norm(knee - hip) - np.linalg.norm(ankle - knee))
    got = floor_fit.standing_height(rig, rig.body, rest, UP, hips, legs_length, 0.01)
    assert got == pytest.approx(np.mean(by_hand) + 0.01, abs=1e-12)
    heads = rest.heads.copy()
    for leg, sign in zip(floor_fit.legs(rig, rig.body), (1.0, -1.0)):
        turn = Rotation.from_euler("y", sign * 20.0, degrees=True)  # about the hip joint, sideways
        below = [leg.shin, leg.foot, *leg.below_ankle]
        heads[below] = heads[leg.thigh] + turn.apply(heads[below] - heads[leg.thigh])
    spread = Pose(rest.rotations, heads, rest.lengths)
    assert floor_fit.standing_height(rig, rig.body, spread, UP, hips, legs_length, 0.01) == pytest.approx(got,
                                                                                                         abs=1e-12)
    feet = [b for leg in floor_fit.legs(rig, rig.body) for b in leg.below_ankle]
    assert min(heads[feet] @ UP) > min(rest.heads[feet] @ UP) + 1e-3

def test_floor_and_clearance():
    """The sample characters stand their balls 2.5 cm above the origin: the floor is the origin and a
    standing foot's lowest joint rides 2.5 cm above it; a floor given in world Z goes through the object's
    matrix; a recorded floor is kept."""
    rig = from_spec(characters.RIGIFY_A)
    floor, clearance = floor_fit.floor_height(rig, rig.body, UP)
    assert floor == 0.0 and clearance == pytest.approx(0.025, abs=1e-15)
    heights = floor_fit.foot_heights(rig, rig.body, rig.rest.reshape(1, -1), rig.heads.reshape(1, -1), UP)
    assert np.allclose(heights, 0.025, atol=1e-15)
    moved = from_spec(characters.RIGIFY_A, placed(Rotation.identity(), 2.0, (0, 0, 0.2)))
    assert floor_fit.floor_height(moved, moved.body, UP, given=0.5)[0] == pytest.approx(0.15, abs=1e-15)
    recorded = from_spec(characters.RIGIFY_A, floor=-0.3)
    assert floor_fit.floor_height(recorded, recorded.body, UP)[0] == -0.3


def test_a_target_hung_below_its_origin_stands_where_its_own_clip_stands_it():
    """The sample character's rest moved 0.9 m down (its hips near its origin, as girl1's FBX has it): alone
    it stands on its rest soles; with a clip of its own that stands it back on the origin, on the origin
    with the same 2.5 cm clearance, and the clip lifts it by the drop. A clip that never comes down near the
    origin (a jump, a climb) sets nothing: the rest soles. A rig standing on its origin is not lifted."""
    drop = 0.9
    rig = from_spec(characters.RIGIFY_A)
    hung = from_spec(characters.RIGIFY_A, placed(Rotation.identity(), 1.0, (0, 0, 0)))
    hung.heads, hung.tails = rig.heads - drop * UP, rig.tails - drop * UP
    assert floor_fit.floor_height(hung, hung.body, UP) == pytest.approx((0.025 - drop, 0.0), abs=1e-12)
    own = _standing(rig)[1]  # its clip: every frame where the unhung rest stands
    floor, clearance = floor_fit.floor_height(hung, hung.body, UP, None, own, own=True)
    assert (floor, clearance) == pytest.approx((0.0, 0.025), abs=1e-12)
    assert floor_fit.own_lift(hung, hung.body, UP, own) == pytest.approx(drop, abs=1e-12)
    jump = own + 0.8 * np.tile(UP, own.shape[1] // 3)  # never down near the origin
    assert floor_fit.floor_height(hung, hung.body, UP, None, jump, own=True)[0] == pytest.approx(0.025 - drop,
                                                                                               abs=1e-12)
    assert floor_fit.own_lift(rig, rig.body, UP, own) == 0.0


def _standing(rig, frames=4, drop=0.0):
    """The rig at rest on every frame, moved down by drop: (orientations, heads) as a native pose gives."""
    heads = (rig.heads - drop * UP).reshape(1, -1)
    return np.tile(rig.rest.reshape(1, -1), (frames, 1)), np.tile(heads, (frames, 1))


def test_a_target_standing_where_the_source_stands_stays_standing(core_native):
    """Both stand at rest: the target's hips come down no more than its legs' 0.1 % kept short of straight
    (the sample's knees are bent 0.6 degrees only), and the feet are to rise back by just that."""
    source, target = from_spec(characters.MIXAMO_T), from_spec(characters.RIGIFY_A)
    ground = lambda rig: floor_fit.Ground(rig, rig.body, UP, 0.025, 0.9)  # noqa: E731
    frames, hips = 4, target.index(target.body.hips)
    rotations = np.tile([1.0, 0.0, 0.0, 0.0], (frames, len(target)))
    locations = np.zeros((frames, 3 * len(target)))
    stances = np.ones((frames, 4), dtype=bool)
    lifts = floor_fit.stand_on_floor(ground(source), _standing(source), ground(target), rotations, locations,
                                     hips, stances, 1.0, 30.0)
    _, heads, _ = rig_fk.pose(target.parents, target.unit_rest, target.heads, target.lengths, rotations,
                              locations[:, 3 * hips:3 * hips + 3])
    drop = target.heads[hips] @ UP - heads[:, hips] @ UP
    assert np.all(drop >= 0) and np.all(drop < 1e-3 * 0.9)
    # Doubles, a few operations on lengths of about a metre.
    assert np.abs(lifts - drop[:, None]).max() < 1e-14


def test_feet_wanted_below_reach_bring_the_hips_down(core_native):
    """The source stands 3 cm lower than its rest (its floor not): the target's straight legs cannot reach, so
    its hips come down, and once posed (rig_fk) its ankles reach where they are wanted, within the 0.1 % of
    the leg the solve keeps short of a straight knee."""
    source, target = from_spec(characters.MIXAMO_T), from_spec(characters.MIXAMO_T)
    ground = lambda rig: floor_fit.Ground(rig, rig.body, UP, 0.025, 0.9)  # noqa: E731
    frames, hips = 3, target.index(target.body.hips)
    rotations = np.tile([1.0, 0.0, 0.0, 0.0], (frames, len(target)))
    locations = np.zeros((frames, 3 * len(target)))
    floor_fit.stand_on_floor(ground(source), _standing(source, frames, 0.03), ground(target), rotations, locations,
                             hips, np.ones((frames, 4), dtype=bool), 1.0, 30.0)
    _, heads, _ = rig_fk.pose(target.parents, target.unit_rest, target.heads, target.lengths, rotations,
                              locations[:, 3 * hips:3 * hips + 3])
    drop = target.heads[hips] @ UP - heads[:, hips] @ UP
    assert np.all(drop > 0.02) and np.all(drop < 0.031)


def test_on_its_feet_unless_a_knee_or_a_wrist_rests_on_the_floor():
    """At rest the rig stands on its feet; a knee, then a wrist, put 5 % of a leg above where it stands (under
    RESTING) rest on the floor; a knee 20 % up (a deep crouch's) does not."""
    rig = from_spec(characters.MIXAMO_T)
    leg = floor_fit.leg_length(rig, rig.body, Pose.rest(rig), UP, rig.index(rig.body.hips))
    ground = floor_fit.Ground(rig, rig.body, UP, 0.025, leg)
    orientations, heads = _standing(rig, 4)
    for frame, (bone, up) in enumerate([("shin.L", 0.05), ("hand.R", 0.05), ("shin.R", 0.2)], start=1):
        b = rig.index(rig.body.limbs[bone])
        heads[frame, 3 * b + 2] = ground.standing + up * leg
    assert floor_fit.on_its_feet(ground, (orientations, heads)).tolist() == [True, False, False, True]


def test_a_crouching_target_whose_feet_float_settles_its_hips_unless_the_source_kneels(core_native):
    """The source stands at rest, the target crouches (thighs 30 degrees forward, shins 60 back, posed by
    rig_fk) with its floor half the crouch's rise above its rest soles: its feet float, so its hips come down
    until they stand, the legs' bend kept (no foot left to move); with the source's knee on its floor the hips
    stay and the legs are to reach down instead."""
    source, target = from_spec(characters.MIXAMO_T), from_spec(characters.MIXAMO_T)
    frames, hips = 3, target.index(target.body.hips)
    rotations = np.tile([1.0, 0.0, 0.0, 0.0], (frames, len(target)))
    for key, degrees in (("thigh", 30.0), ("shin", -60.0)):
        for side in "LR":
            b = target.index(target.body.limbs[f"{key}.{side}"])
            rotations[:, 4 * b:4 * b + 4] = np.roll(Rotation.from_euler("x", degrees, degrees=True).as_quat(), 1)
    _, crouched, _ = rig_fk.pose(target.parents, target.unit_rest, target.heads, target.lengths, rotations)
    def soles(heads):  # rotations unused: every leg has a toe
        return floor_fit.foot_heights(target, target.body, np.zeros((len(heads), 4 * len(target))), heads, UP)
    floating = soles(crouched.reshape(frames, -1)) - soles(_standing(target, 1)[1])
    assert np.ptp(floating) < 1e-12 and 0.05 < floating[0, 0] < 0.3
    floating = floating[0, 0]
    for kneels in (False, True):
        pose = _standing(source, frames)
        if kneels:
            knee = source.index(source.body.limbs["shin.L"])
            pose[1][:, 3 * knee + 2] = 0.025 + 0.01
        locations = np.zeros((frames, 3 * len(target)))
        # The target's floor half the crouch's rise above its rest soles' (its legs can reach that far).
        lifts = floor_fit.stand_on_floor(floor_fit.Ground(source, source.body, UP, 0.025, 0.9), pose,
                                         floor_fit.Ground(target, target.body, UP, 0.025 + floating / 2, 0.9),
                                         rotations, locations, hips, np.ones((frames, 4), dtype=bool), 1.0, 30.0)
        _, heads, _ = rig_fk.pose(target.parents, target.unit_rest, target.heads, target.lengths, rotations,
                                  locations[:, 3 * hips:3 * hips + 3])
        drop = target.heads[hips] @ UP - heads[:, hips] @ UP
        # Doubles, a few operations on lengths of about a metre.
        np.testing.assert_allclose(drop, 0.0 if kneels else floating / 2, rtol=0, atol=1e-14)
        np.testing.assert_allclose(lifts, -floating / 2 if kneels else 0.0, rtol=0, atol=1e-14)


def test_feet_left_off_the_floor_by_more_than_half_a_millimetre_a_metre_ask_for_the_legs():
    assert not floor_fit.feet_left_off(np.zeros((5, 2)), 1.0)
    assert not floor_fit.feet_left_off(np.full((5, 2), 4.9e-4), 1.0)
    assert floor_fit.feet_left_off(np.array([[0.0, -6e-4]]), 1.0)
    assert not floor_fit.feet_left_off(np.array([[0.0, -6e-4]]), 2.0)  # a longer leg: a smaller share


def _with_heels(spec):
    """The sample character with a heel bone under each foot lying on the floor (Blender's metarig has
    heel.02 so), the ball 2.5 cm above it."""
    rig = from_spec(spec)
    names, parents, rest = list(rig.names), list(rig.parents), list(rig.rest)
    heads, tails, connected = list(rig.heads), list(rig.tails), list(rig.connected)
    for side in "LR":
        foot = rig.index(rig.body.limbs[f"foot.{side}"])
        x = rig.heads[foot][0]
        head, tail = np.array([x + 0.04, 0.02, 0.0]), np.array([x - 0.04, 0.02, 0.0])
        names.append(f"heel.02.{side}")
        parents.append(foot)
        rest.append(bone_rest(head, tail, 0.0))
        heads.append(head)
        tails.append(tail)
        connected.append(False)
    heads, tails = np.array(heads), np.array(tails)
    return RigData(rig.name, tuple(names), tuple(parents), np.array(rest), heads, tails,
                   np.linalg.norm(tails - heads, axis=1), tuple(connected))


def test_a_standing_foot_s_joints_ride_at_their_own_height_above_a_heel_on_the_floor():
    """A heel bone on the floor sets the floor and the soles (floor_height's clearance 0), but the joints a
    standing foot is put down by, the ankle and the ball, still ride 2.5 cm above it (joint_clearance): the
    height the feet's solve holds them at, so that a foot does not sink by its ball's height."""
    rig = _with_heels(characters.RIGIFY_A)
    floor, clearance = floor_fit.floor_height(rig, rig.body, UP)
    assert floor == 0.0 and clearance == pytest.approx(0.0, abs=1e-15)
    assert floor_fit.joint_clearance(rig, rig.body, UP, floor) == pytest.approx(0.025, abs=1e-12)
    plain = from_spec(characters.RIGIFY_A)
    assert floor_fit.joint_clearance(plain, plain.body, UP, 0.0) == pytest.approx(
        floor_fit.floor_height(plain, plain.body, UP)[1], abs=1e-12)
    # A floor a leg below (a capture's, on which the joints themselves stand): nothing to ride.
    assert floor_fit.joint_clearance(rig, rig.body, UP, -0.8) == 0.0


def test_first_frame_lift_puts_the_first_frame_s_lowest_point_on_the_floor_and_moves_every_frame_alike(core_native):
    """floor_fit="first_frame": the hips' channel changed so that, posed independently (rig_fk), the lowest
    head or tail on the first frame is on the floor and every frame's body moved by the same world lift;
    the hips turned (their channel is in their own posed frame) and the clip bent so its frames differ."""
    rig = from_spec(characters.MIXAMO_T)
    hips = rig.index(rig.body.hips)
    assert rig.parents[hips] < 0  # rig_fk places the root's location only
    frames, rng = 5, np.random.default_rng(3)
    turns = Rotation.from_rotvec(0.4 * rng.standard_normal((frames * len(rig), 3)))
    rotations = np.roll(turns.as_quat(), 1, axis=1).reshape(frames, 4 * len(rig))
    locations = np.zeros((frames, 3 * len(rig)))
    locations[:, 3 * hips:3 * hips + 3] = 0.1 * rng.standard_normal((frames, 3))
    floor = -0.3
    change = floor_fit.first_frame_lift(rig, UP, floor, rotations, locations, hips)
    pose = lambda loc: rig_fk.pose(rig.parents, rig.unit_rest, rig.heads, rig.lengths, rotations,  # noqa: E731
                                   loc[:, 3 * hips:3 * hips + 3])
    _, heads, tails = pose(locations)
    lifted = locations.copy()
    lifted[:, 3 * hips:3 * hips + 3] += change
    _, new_heads, new_tails = pose(lifted)
    # Doubles through a few dozen rotations of metre-long bones: 1e-12 is a hundred times their rounding.
    assert min((new_heads[0] @ UP).min(), (new_tails[0] @ UP).min()) == pytest.approx(floor, abs=1e-12)
    lift = floor - min((heads[0] @ UP).min(), (tails[0] @ UP).min())
    assert abs(lift) > 0.05
    np.testing.assert_allclose(new_heads - heads, np.broadcast_to(lift * UP, heads.shape), atol=1e-12)
