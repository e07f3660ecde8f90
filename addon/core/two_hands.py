"""Two hands on one prop (numpy, no bpy): a prop bone that hangs from one hand (a rifle under the right
hand) and that the source's other hand holds. Arms of other lengths than the source's leave the other
hand elsewhere on the target; this puts its wrist where the source's is relative to the prop (in the
prop's own axes, scaled as the motion is), bending its upper arm and forearm in their own plane (a
two-bone solve: the elbow stays on its side), wherever the source's wrist is near the prop, eased in and
out by that distance. The hand keeps its own rotation."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .rig_data import RigData
from .root_motion import local_channels
from .rotation_channels import conjugate, multiply, rotate_each as rotate, y_axes

# The source's wrist holds the prop where it lies within HOLD of the prop's bone (head to tail), in its
# forearm's lengths; held fully within HOLD / 2, eased between.
HOLD = 0.5


@dataclass(frozen=True)
class Grip:
    """The bones of a two-handed hold, by index: the prop on each rig and the other arm's (the source's
    hand; the target's upper arm, forearm and hand)."""
    source_prop: int
    source_hand: int
    source_forearm: int
    target_prop: int
    upper: int
    forearm: int
    hand: int


def weights(source: RigData, grip: Grip, pose) -> np.ndarray:
    """(frames,) how much the source's other hand holds the prop: 1 within HOLD / 2 forearms of the prop's
    bone (head to tail), 0 beyond HOLD, smooth between. pose: the source's armature-space (orientations
    (frames, 4B), heads (frames, 3B))."""
    rot, heads = pose
    head = heads[:, 3 * grip.source_prop:3 * grip.source_prop + 3]
    wrist = heads[:, 3 * grip.source_hand:3 * grip.source_hand + 3]
    forearm = np.linalg.norm(source.heads[grip.source_hand] - source.heads[grip.source_forearm])
    # No point of the prop's bone lies nearer the wrist than its head less its length: a wrist that far on
    # every frame never holds it (most bones under a hand, on most clips), and nothing more is computed.
    if np.min(np.sum((wrist - head) ** 2, axis=1)) > (HOLD * forearm + float(source.lengths[grip.source_prop])) ** 2:
        return np.zeros(len(head))
    axis = source.lengths[grip.source_prop] * y_axes(rot[:, 4 * grip.source_prop:4 * grip.source_prop + 4])
    along = np.clip(np.sum((wrist - head) * axis, axis=1) / max(float(source.lengths[grip.source_prop]) ** 2,
                                                                  1e-24), 0.0, 1.0)
    distance = np.linalg.norm(wrist - head - along[:, None] * axis, axis=1)
    return _smooth(distance / max(forearm, 1e-12))


def _smooth(ratio) -> np.ndarray:
    t = np.clip((HOLD - ratio) / (HOLD / 2), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def one_hold(weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A hand holds one prop at a time: on each frame the one it holds most (the first of equals). weights
    (props, frames) as weights() gives them; returns that hold's weight (frames,) and which prop it is
    (frames,), an index into weights' rows."""
    which = np.argmax(weights, axis=0)
    return weights[which, np.arange(weights.shape[1])], which


def wanted_wrists(source: RigData, target: RigData, grip: Grip, source_pose, target_pose, space, scale):
    """(frames, 3) where the target's other wrist is to be: the source's wrist in the source prop's axes,
    carried into the target prop's axes (through the two rests and the turn between the armatures) and
    scaled. source_pose, target_pose: (orientations (frames, 4B), heads (frames, 3B)) armature space."""
    s_rot = source_pose[0][:, 4 * grip.source_prop:4 * grip.source_prop + 4]
    s_head = source_pose[1][:, 3 * grip.source_prop:3 * grip.source_prop + 3]
    s_wrist = source_pose[1][:, 3 * grip.source_hand:3 * grip.source_hand + 3]
    in_prop = rotate(conjugate(s_rot), s_wrist - s_head)
    axes = multiply(multiply(conjugate(target.unit_rest[grip.target_prop]), space),
                    source.unit_rest[grip.source_prop])
    t_rot = target_pose[0][:, 4 * grip.target_prop:4 * grip.target_prop + 4]
    t_head = target_pose[1][:, 3 * grip.target_prop:3 * grip.target_prop + 3]
    return t_head + rotate(t_rot, rotate(np.broadcast_to(axes, s_rot.shape), scale * in_prop))


def reach(target: RigData, grip: Grip, basis, pose, wanted, weight, up) -> None:
    """The target's other arm bent so that its wrist moves to wanted (frames, 3) by weight (frames,): its
    upper arm's and forearm's basis rotations (basis (frames, 4B), in place). pose: the target's
    armature-space (orientations, heads) as basis has it; up: Blender's up in its armature space (a straight
    arm, which shows no side to bend to, bends its elbow down)."""
    rot, heads = pose
    joint = lambda b: heads[:, 3 * b:3 * b + 3]  # noqa: E731
    shoulder, elbow, wrist = joint(grip.upper), joint(grip.forearm), joint(grip.hand)
    goal = wrist + weight[:, None] * (wanted - wrist)
    a = np.linalg.norm(target.heads[grip.forearm] - target.heads[grip.upper])
    b = np.linalg.norm(target.heads[grip.hand] - target.heads[grip.forearm])
    to_goal = goal - shoulder
    d = np.clip(np.linalg.norm(to_goal, axis=1), abs(a - b) + 1e-6 * (a + b), (1 - 1e-6) * (a + b))
    along = to_goal / np.maximum(np.linalg.norm(to_goal, axis=1, keepdims=True), 1e-12)
    side = _across(elbow - shoulder, along)
    straight = np.linalg.norm(side, axis=1) < 1e-6 * a
    side[straight] = _across(np.broadcast_to(-np.asarray(up, dtype=np.float64), along.shape), along)[straight]
    side /= np.maximum(np.linalg.norm(side, axis=1, keepdims=True), 1e-12)
    cos = np.clip((a * a + d * d - b * b) / (2 * a * d), -1.0, 1.0)
    new_elbow = shoulder + a * (cos[:, None] * along + np.sqrt(1 - cos * cos)[:, None] * side)
    new_wrist = shoulder + d[:, None] * along
    turn_upper = _between(elbow - shoulder, new_elbow - shoulder)
    carried_wrist = new_elbow + rotate(turn_upper, wrist - elbow)
    turn_fore = multiply(_between(carried_wrist - new_elbow, new_wrist - new_elbow), turn_upper)
    upper_rot = multiply(turn_upper, rot[:, 4 * grip.upper:4 * grip.upper + 4])
    above = target.parents[grip.upper]
    # The upper arm under its unchanged parent; the forearm under the upper arm as now turned.
    for bone, parent, parent_pose, orientation, head in (
            (grip.upper, above, (rot[:, 4 * above:4 * above + 4], heads[:, 3 * above:3 * above + 3]), upper_rot,
             shoulder),
            (grip.forearm, grip.upper, (upper_rot, shoulder),
             multiply(turn_fore, rot[:, 4 * grip.forearm:4 * grip.forearm + 4]), new_elbow)):
        basis[:, 4 * bone:4 * bone + 4] = local_channels(target.unit_rest, target.heads, bone, parent, *parent_pose,
                                                         orientation, head)[0]


def _across(v, along) -> np.ndarray:
    """v's part across the unit directions along (frames, 3)."""
    return v - np.sum(v * along, axis=1, keepdims=True) * along


def _between(a, b) -> np.ndarray:
    """(frames, 4) the shortest rotation turning each direction of a (frames, 3) onto b's (an arm never turns
    half a turn in one solve)."""
    a = a / np.linalg.norm(a, axis=1, keepdims=True)
    b = b / np.linalg.norm(b, axis=1, keepdims=True)
    q = np.concatenate([1.0 + np.sum(a * b, axis=1, keepdims=True), np.cross(a, b)], axis=1)
    return q / np.linalg.norm(q, axis=1, keepdims=True)
