"""Where bones point (addon/core/bone_axes.py): the continuing child and the aims given to bones whose Y
axes do not run along their limbs, checked against hand-placed joints and scipy's rotations."""
import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from core import bone_axes

# A root (hips) with a spine of two bones and a thigh; an arm off the chest with a hand and three fingers.
NAMES = ["hips", "spine", "chest", "thigh", "arm", "hand", "index", "middle", "pinky"]
PARENTS = [-1, 0, 1, 0, 2, 4, 5, 5, 5]
HEADS = np.array([[0, 0, 1.0], [0, 0, 1.1], [0, 0, 1.3], [0.1, 0, 0.95], [0.2, 0, 1.45], [0.5, 0, 1.45],
                  [0.6, 0, 1.47], [0.6, 0, 1.45], [0.6, 0, 1.42]])


def _tails_along(directions, length=0.05):
    return HEADS + length * directions / np.linalg.norm(directions, axis=1, keepdims=True)


def _rest_from_y(directions):
    """Rest orientations (w x y z) whose Y axis runs along each direction."""
    out = []
    for d in directions:
        with warnings.catch_warnings():  # one vector leaves the roll free: any roll will do
            warnings.simplefilter("ignore", UserWarning)
            r, _ = Rotation.align_vectors([d / np.linalg.norm(d)], [[0.0, 1.0, 0.0]])
        x, y, z, w = r.as_quat()
        out.append([w, x, y, z])
    return np.array(out)


def test_continuing_children_follow_the_parents_line_and_for_a_root_the_biggest_subtree():
    got = bone_axes.continuing_children(HEADS, PARENTS)
    want = {"hips": "spine", "spine": "chest", "chest": "arm", "arm": "hand", "hand": "middle"}
    assert {NAMES[b]: NAMES[c] for b, c in enumerate(got) if c >= 0} == want
    assert [NAMES[b] for b, c in enumerate(got) if c < 0] == ["thigh", "index", "middle", "pinky"]


def test_a_rig_drawn_along_its_joints_needs_no_aims():
    ahead = np.array([HEADS[c] - HEADS[b] if c >= 0 else HEADS[b] - HEADS[PARENTS[b]]
                      for b, c in enumerate(bone_axes.continuing_children(HEADS, PARENTS))])
    assert bone_axes.aims(HEADS, _tails_along(ahead), PARENTS, _rest_from_y(ahead)) is None


@pytest.mark.parametrize("off_deg", [0.5, 7.0, 90.0])
def test_bones_off_their_next_joint_are_aimed_there_in_their_own_frames(off_deg):
    """Every bone turned off_deg from its next joint (an FBX import's nearest axis is 7 degrees off a
    spine): each aim, carried by the bone's rest orientation, runs to the next joint's head."""
    following = bone_axes.continuing_children(HEADS, PARENTS)
    ahead = np.array([HEADS[c] - HEADS[b] if c >= 0 else HEADS[b] - HEADS[PARENTS[b]]
                      for b, c in enumerate(following)])
    turn = Rotation.from_rotvec(np.radians(off_deg) * np.array([0.6, 0.0, 0.8]))
    crooked = turn.apply(ahead)
    rest = _rest_from_y(crooked)
    found = bone_axes.aims(HEADS, _tails_along(crooked), PARENTS, rest)
    assert found is not None
    aims, reach = found
    world = Rotation.from_quat(rest[:, [1, 2, 3, 0]]).apply(aims)
    for b, c in enumerate(following):
        if c >= 0:
            want = HEADS[c] - HEADS[b]
            assert np.degrees(np.arccos(np.clip(world[b] @ want / np.linalg.norm(want), -1, 1))) < 1e-6
            assert reach[b] == pytest.approx(np.linalg.norm(want))


def test_a_given_continuing_child_is_the_one_aimed_at():
    """A retarget passes one rig's choice to the other: the hand aimed at the index, not the middle."""
    following = bone_axes.continuing_children(HEADS, PARENTS)
    following[NAMES.index("hand")] = NAMES.index("index")
    ahead = np.array([HEADS[c] - HEADS[b] if c >= 0 else HEADS[b] - HEADS[PARENTS[b]]
                      for b, c in enumerate(bone_axes.continuing_children(HEADS, PARENTS))])
    rest = _rest_from_y(ahead)
    aims, _ = bone_axes.aims(HEADS, _tails_along(ahead), PARENTS, rest, following)
    hand = NAMES.index("hand")
    world = Rotation.from_quat(rest[hand, [1, 2, 3, 0]]).apply(aims[hand])
    want = HEADS[NAMES.index("index")] - HEADS[hand]
    assert world @ want / np.linalg.norm(want) == pytest.approx(1.0, abs=1e-12)


def _leg_rig(name, helper: bool):
    """Hips, a thigh, its knee and (helper) a skin joint under the thigh that carries the hip-to-thigh line
    on sideways, as girl2's of ../shared/data/pairs does; every bone's Y axis as a rig drawn along its limbs
    has it (the hips up, the leg down)."""
    from core.rig_data import RigData
    down, up = [np.sqrt(0.5), -np.sqrt(0.5), 0, 0], [np.sqrt(0.5), np.sqrt(0.5), 0, 0]
    heads = [[0, 0, 1.0], [0.1, 0, 0.95], [0.1, 0, 0.55]] + ([[0.2, 0, 0.92]] if helper else [])
    rest = [up, down, down] + ([down] if helper else [])
    heads = np.array(heads)
    tails = heads + np.array([[0, 0, 0.1]] + [[0, 0, -0.1]] * (len(heads) - 1))
    names = ("hips", "thigh", "knee") + (("helper",) if helper else ())
    parents = (-1, 0, 1) + ((1,) if helper else ())
    return RigData(name, names, parents, np.array(rest), heads, tails, np.full(len(names), 0.1),
                   (False,) * len(names))


def test_a_mapped_bone_points_at_its_mapped_child_past_a_straighter_helper():
    """The source's thigh carries a helper joint that continues the hip's line better than its knee: paired,
    the thigh still points at its knee (along its own Y axis), as the target's does; aimed at the helper it
    would point 70 degrees off, and the retarget would turn the target's leg sideways."""
    source, target = _leg_rig("source", helper=True), _leg_rig("target", helper=False)
    assert bone_axes.continuing_children(source.heads, list(source.parents))[1] == 3  # the helper, alone
    source_aims, target_aims = bone_axes.paired_aims(source, target, [0, 1, 2])
    for aims in (source_aims, target_aims):
        np.testing.assert_allclose(aims[1], [0.0, 1.0, 0.0], atol=1e-12)  # a rotation of exact unit vectors


def _clavicle_rig(name, middle=None, middle_name="LeftShoulder_split"):
    """A chest, a clavicle and an arm (along X); middle: the head of an unmapped joint between the clavicle and
    the arm. Each bone's Y axis runs to its child's head (the arm's along X), as Blender's BVH import draws it."""
    from core.rig_data import RigData
    heads = [[0, 0, 1.4], [0.02, 0, 1.45]] + ([middle] if middle is not None else []) + [[0.15, 0, 1.45]]
    heads = np.array(heads, dtype=float)
    ends = np.vstack([heads[1:], heads[-1:] + [0.25, 0, 0]])
    names = ("chest", "clavicle") + ((middle_name,) if middle is not None else ()) + ("arm",)
    parents = tuple(range(-1, len(names) - 1))
    return RigData(name, names, parents, _rest_from_y(ends - heads), heads, ends,
                   np.linalg.norm(ends - heads, axis=1), (False,) * len(names))


def _aimed_at(rig, aims, bone, target):
    world = Rotation.from_quat(rig.rest[bone, [1, 2, 3, 0]]).apply(aims[bone])
    want = rig.heads[target] - rig.heads[bone]
    return float(world @ want / np.linalg.norm(want))


def test_a_mapped_bone_points_past_a_helper_joint_off_its_line_at_its_mapped_descendant():
    """Mixamo's `*_split` joints: Mousey's clavicle runs to a split joint 63 degrees up (its Y axis there) and
    the arm hangs under that; the source's clavicle runs to its arm. Paired, the target's clavicle points at
    its arm, as the source's does: aimed at the split joint it is taken for a clavicle raised 60 degrees."""
    source = _clavicle_rig("source")
    target = _clavicle_rig("target", middle=[0.04, 0, 1.49])   # 63 degrees up from the clavicle's head
    _, target_aims = bone_axes.paired_aims(source, target, [0, 1, -1, 2])
    assert _aimed_at(target, target_aims, 1, 3) == pytest.approx(1.0, abs=1e-12)


def test_a_middle_joint_on_the_line_is_a_segment_not_a_helper():
    """A two-bone neck under a one-bone neck: its middle joint lies 5 degrees off the line to the head, a
    segment of the chain that shares its turn (the retarget's chains): the first bone keeps pointing at it."""
    source = _clavicle_rig("source")
    middle = [0.085, 0, 1.45 + 0.065 * np.tan(np.radians(5.0))]
    target = _clavicle_rig("target", middle=middle, middle_name="neck.001")
    _, target_aims = bone_axes.paired_aims(source, target, [0, 1, -1, 2])
    assert target_aims is None or _aimed_at(target, target_aims, 1, 2) == pytest.approx(1.0, abs=1e-12)
    assert bone_axes.helpers_between(target, [True, True, False, True]) == []
    # Named a helper (Mousey's Spine1_split lies on its spine's line), the same joint is passed and carried.
    target = _clavicle_rig("target", middle=middle, middle_name="Spine1_split")
    _, target_aims = bone_axes.paired_aims(source, target, [0, 1, -1, 2])
    assert _aimed_at(target, target_aims, 1, 3) == pytest.approx(1.0, abs=1e-12)
    assert bone_axes.helpers_between(target, [True, True, False, True]) == [2]


def test_a_bone_whose_children_all_start_at_its_head_has_no_direction():
    # 0 -> 1 -> 2 (on 1's head, a `*_split` joint) -> 3, and a leaf 4 off 3: only 1 points nowhere of its own.
    heads = np.array([[0, 0, 0], [0, 0, 1], [0, 0, 1], [0, 0.1, 2], [0, 0.1, 3]], dtype=float)
    parents = [-1, 0, 1, 2, 3]
    np.testing.assert_array_equal(bone_axes.without_direction(heads, parents), [False, True, False, False, False])


def test_a_bone_with_one_child_apart_among_children_on_its_head_keeps_its_direction():
    heads = np.array([[0, 0, 0], [0, 0, 0], [0, 0, 1]], dtype=float)  # a twist bone on its head, a child apart
    np.testing.assert_array_equal(bone_axes.without_direction(heads, [-1, 0, 0]), [False, False, False])
