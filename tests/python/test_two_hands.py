"""core/two_hands: the other arm's two-bone reach, on the sample character as plain data, posed by the
native rig and checked against the goal and by hand."""
import numpy as np

import characters
from core import two_hands
from plain_rigs import from_spec


def _grip(rig):
    at = {n: rig.index(n) for n in rig.names}
    left = rig.body.limbs
    return two_hands.Grip(0, 0, 0, 0, at[left["upper_arm.L"]], at[left["forearm.L"]], at[left["hand.L"]])


def test_a_straight_arm_bends_its_elbow_down_to_reach_a_nearer_goal(core_native):
    rig = from_spec(characters.MIXAMO_T)
    grip = _grip(rig)
    frames = 3
    basis = np.tile([1.0, 0.0, 0.0, 0.0], (frames, len(rig)))
    locations = np.zeros((frames, 3 * len(rig)))
    posed = core_native.armature_pose(rig.native, basis, locations)
    shoulder = rig.heads[grip.upper]
    goals = shoulder + np.array([[0.40, 0.0, 0.0], [0.3, -0.2, 0.1], [0.2, 0.0, -0.3]])
    weight = np.array([1.0, 1.0, 0.5])
    wrist = posed[1][:, 3 * grip.hand:3 * grip.hand + 3]
    two_hands.reach(rig, grip, basis, posed, goals, weight, np.array([0.0, 0.0, 1.0]))
    after = core_native.armature_pose(rig.native, basis, locations)[1]
    reached = after[:, 3 * grip.hand:3 * grip.hand + 3]
    wanted = wrist + weight[:, None] * (goals - wrist)
    assert np.abs(reached - wanted).max() < 1e-12  # doubles, two rotations of bones under a metre
    elbow = after[0, 3 * grip.forearm:3 * grip.forearm + 3]
    assert elbow[2] < shoulder[2] - 0.05  # a straight T-pose arm bends its elbow down, as a person's
    # The bones keep their lengths: the shoulder and the elbow where they were along the arm.
    assert np.isclose(np.linalg.norm(elbow - shoulder), np.linalg.norm(rig.heads[grip.forearm] - shoulder))


def test_the_hold_eases_with_the_wrist_s_distance_from_the_prop():
    ratios = np.array([0.0, two_hands.HOLD / 2, 0.75 * two_hands.HOLD, two_hands.HOLD, 2.0])
    assert np.allclose(two_hands._smooth(ratios), [1.0, 1.0, 0.5, 0.0, 0.0])


def test_a_hand_holds_the_prop_it_holds_most_one_at_a_time():
    """Two props under one hand (a rifle and its magazine): on each frame the hold the other wrist is
    nearest, with its weight; equal holds take the first."""
    weights = np.array([[1.0, 0.2, 0.0, 0.5],
                        [0.0, 0.7, 0.0, 0.5]])
    weight, which = two_hands.one_hold(weights)
    np.testing.assert_array_equal(weight, [1.0, 0.7, 0.0, 0.5])
    np.testing.assert_array_equal(which, [0, 1, 0, 0])
