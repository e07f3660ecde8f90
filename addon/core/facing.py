"""Which way a rig faces, and the turn that lays the source's motion on the target facing the target's
way (numpy, no bpy). Stage of a retarget: the placement of one armature space in the other.

Rigs face along their axes: every turn found here is a multiple of 90 degrees about up, so that a
character facing +Y retargets onto one facing -Y walking forwards, not backwards, and a fit's few
degrees of asymmetry never turn the motion.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import bone_mapping, rotation_channels
from .rig_data import Pose, RigData


@dataclass
class Placement:
    """space: the rotation from the source's armature space to the target's; up: Blender's up in the
    target's armature space, source_up in the source's."""
    space: np.ndarray
    up: np.ndarray
    source_up: np.ndarray


@dataclass
class Standing:
    """A rig in its match pose, for the facing: its labels and, for a source, its clip's orientations
    (frames, 4B) and heads (frames, 3B) (empty for a target)."""
    rig: RigData
    body: bone_mapping.Body
    pose: Pose
    clip_rotations: np.ndarray = None
    clip_heads: np.ndarray = None


def _quarter_turn(angle: float, up) -> np.ndarray:
    angle = np.pi / 2 * np.round(angle / (np.pi / 2))
    return np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * np.asarray(up, dtype=np.float64)])


def fitted_turn(space, source_pose: Pose, target_pose: Pose, pairs_idx, roots, up) -> np.ndarray:
    """The quarter turns about the target's up that best lay the source's mapped joints over the target's:
    a least-squares fit (2-D Kabsch) of the joints' offsets from the roots (source, target) across up."""
    src = rotation_channels.rotate(space, source_pose.heads[[a for a, _ in pairs_idx]] - source_pose.heads[roots[0]])
    tgt = target_pose.heads[[b for _, b in pairs_idx]] - target_pose.heads[roots[1]]
    across = np.cross(up, [1.0, 0.0, 0.0] if abs(up[0]) < 0.9 else [0.0, 1.0, 0.0])
    across /= np.linalg.norm(across)
    basis = np.stack([across, np.cross(up, across)])  # two axes across up, turning about up
    src, tgt = src @ basis.T, tgt @ basis.T
    cross = np.sum(src[:, 0] * tgt[:, 1] - src[:, 1] * tgt[:, 0])
    dot = np.sum(src[:, 0] * tgt[:, 0] + src[:, 1] * tgt[:, 1])
    return _quarter_turn(np.arctan2(cross, dot) if abs(cross) + abs(dot) > 0 else 0.0, up)


def faces_nowhere(rig: RigData, pose: Pose, bones) -> bool:
    """Whether a match pose is a zero pose (nearly every joint straight on from its parent's along one axis):
    it shows no facing. Read from the joints, not the bones' axes, which an FBX or glTF import may leave all
    pointing one way in a pose that faces somewhere."""
    parents = [(b, rig.parents[b]) for b in bones if rig.parents[b] >= 0]
    offsets = np.array([pose.heads[b] - pose.heads[p] for b, p in parents]).reshape(-1, 3)
    lengths = np.linalg.norm(offsets, axis=1)
    axes = offsets[lengths > 1e-9 * max(lengths.max(initial=0.0), 1e-30)]
    if len(axes) < 3:
        return False
    axes = axes / np.linalg.norm(axes, axis=1, keepdims=True)
    _, vectors = np.linalg.eigh(axes.T @ axes)
    along = np.abs(axes @ vectors[:, -1]) > np.cos(np.radians(10.0))
    return bool(np.mean(along) >= 0.9)


def forward(left, right, up) -> np.ndarray:
    """Where a body faces, across up, from its left and right hip joints (..., 3): left x up."""
    ahead = np.cross(left - right, up)
    return ahead - (ahead @ up)[..., None] * up


def turn_to(direction, onto, up) -> np.ndarray:
    """The quarter turns about up (a quaternion) that best carry one direction across up onto another."""
    return _quarter_turn(np.arctan2(np.cross(direction, onto) @ up, direction @ onto), up)


def mid_thighs(rig: RigData, body, rotations, heads) -> tuple | None:
    """The middle of the left and right thighs (..., 3) in a pose (rotations (..., 4B), heads (..., 3B)), or
    None without two labelled thighs: across the body, whatever the arms do. Between hip and knee joint where
    the shin is labelled (a bone's axis may not run along it), else half the thigh along its Y axis."""
    found = [(body.limbs.get(f"thigh.{s}"), body.limbs.get(f"shin.{s}")) for s in bone_mapping.SIDES]
    if not all(thigh in rig for thigh, _ in found):
        return None
    out = []
    for thigh, shin in found:
        b = rig.index(thigh)
        if shin in rig:
            k = rig.index(shin)
            out.append(0.5 * (heads[..., 3 * b:3 * b + 3] + heads[..., 3 * k:3 * k + 3]))
            continue
        axis = rotation_channels.y_axes(rotations[..., 4 * b:4 * b + 4])
        out.append(heads[..., 3 * b:3 * b + 3] + 0.5 * rig.lengths[b] * axis)
    return tuple(out)


def hip_joints(rig: RigData, body, heads) -> tuple | None:
    """The left and right thighs' heads (3,) in a pose's heads (B, 3), or None without two labelled thighs."""
    found = [body.limbs.get(f"thigh.{s}") for s in bone_mapping.SIDES]
    return tuple(heads[rig.index(n)] for n in found) if all(n in rig for n in found) else None


def body_turn(space, source: Standing, target: Standing, up, zero_pose: bool) -> np.ndarray | None:
    """The quarter turns about up that carry the way the source's body faces onto the way the target's match
    pose faces, from their hips' left-right line (the thighs): the source's match pose's, or, for a match
    pose that shows no facing (zero_pose, the thighs on one line), the clip's mean. None without thighs."""
    # A match pose's hip joints: the pelvis carries them, whatever stance the legs take (a fighter's guard).
    onto = hip_joints(target.rig, target.body, target.pose.heads)
    match = hip_joints(source.rig, source.body, source.pose.heads)
    if onto is None or match is None:
        return None
    turn = lambda points: rotation_channels.rotate(space, np.asarray(points))  # noqa: E731
    direction = forward(turn(match[0]), turn(match[1]), up)
    if zero_pose or np.linalg.norm(direction) < 1e-3 * max(np.ptp(target.pose.heads, axis=0).max(), 1e-9):
        if source.clip_heads is None or not len(source.clip_heads):
            return None
        left, right = mid_thighs(source.rig, source.body, source.clip_rotations, source.clip_heads)
        faces = forward(turn(left), turn(right), up)
        mean = (faces / np.maximum(np.linalg.norm(faces, axis=1, keepdims=True), 1e-30)).mean(axis=0)
        # A clip that turns all the way round has no mean facing: its first frame's then.
        direction = mean if np.linalg.norm(mean) > 0.3 else faces[0]
    return turn_to(direction, forward(onto[0], onto[1], up), up)


def placement(source: Standing, target: Standing, pairs_idx, roots, align_facing: bool) -> Placement:
    """The rotation from the source's armature space to the target's (the objects' world rotations, and with
    align_facing the quarter turns about up that face the motion the target's way: body_turn, else
    fitted_turn), with Blender's up in each. roots: (source, target) hips."""
    space = rotation_channels.multiply(rotation_channels.conjugate(target.rig.world_rotation),
                                       source.rig.world_rotation)
    up = target.rig.up
    if align_facing:
        zero_pose = faces_nowhere(source.rig, source.pose, [a for a, _ in pairs_idx])
        turn = body_turn(space, source, target, up, zero_pose)
        if turn is None:
            turn = fitted_turn(space, source.pose, target.pose, pairs_idx, roots, up)
        space = rotation_channels.multiply(turn, space)
    return Placement(space, up, rotation_channels.rotate(rotation_channels.conjugate(space), up[None, :])[0])
