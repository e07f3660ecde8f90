"""A retargeted clip's quality (core/clip_quality) read off the two armatures as they now play: both actions
posed natively from their keys, no frame_set. The source's stance frames are detected on the source itself,
so that a target whose feet slide where the source's stood shows it.
"""
from __future__ import annotations

import numpy as np

from ..blender import animdata, object_channels, pose_channels
from ..core import bone_mapping, clip_quality, floor_fit, rotation_channels
from . import contacts, retargeting

WORLD_UP = np.array([0.0, 0.0, 1.0])  # the figures are in world space, where Blender's up is Z
FEET = ((0, 1), (2, 3))  # contacts.POINTS: each foot's ankle and ball


class _Posed:
    """One armature's action over frames, its channels read once: basis channels, and armature-space
    orientations and heads (the pose) with the orientations also in world space."""

    def __init__(self, obj, frames):
        self.obj = obj
        self.rig = pose_channels.read_rig(obj)
        self.index = {n: i for i, n in enumerate(self.rig.names)}
        action = animdata.assigned_action(obj)
        self.basis = pose_channels.rotations(obj, action, self.rig.names, frames)
        self.moved = np.ascontiguousarray(pose_channels.locations(obj, action, self.rig.names, frames)[0])
        # A clip whose object moves (root motion onto the object) is measured with that motion, as it plays.
        moving = object_channels.ObjectMotion.of_action(obj, action) if action is not None else None
        if moving is not None:
            self.rig = moving.placed(self.rig)
            self.basis, self.moved = moving.composed(self.rig, frames, self.basis, self.moved)
        self.pose = pose_channels.pose_basis(self.rig.native, frames, self.basis, self.moved)
        self.rotations = rotation_channels.multiply(self.rig.world_rotation, self.pose[0].reshape(len(frames), -1, 4))


def _rest_world(posed: _Posed, names) -> np.ndarray:
    """(n, 4) the named bones' rest orientations in world space."""
    rig = posed.rig
    return rotation_channels.multiply(rig.world_rotation, rig.rest[[rig.index(n) for n in names]].reshape(-1, 4))


def _directions(source: _Posed, target: _Posed, pairs, kept=()) -> tuple[np.ndarray, np.ndarray]:
    """World directions (frames, pairs, 3) of each pair's bones, each where the retarget aims it: the
    source's where the target bone takes its direction, and for a bone that keeps its own posture (kept:
    target bone names) the target's rest aim turned as the source's bone has turned from its rest."""
    aims = retargeting.pointing(source.obj, target.obj, pairs)
    out = []
    for posed, names, side_aims in ((source, [a for a, _ in pairs], aims[0]), (target, [t for _, t in pairs], aims[1])):
        q = posed.rotations[:, [posed.index[n] for n in names]]
        out.append(rotation_channels.rotate_each(q, np.array([side_aims[n] for n in names])[None]))
    held = [i for i, (_, t) in enumerate(pairs) if t in kept]
    if held:
        names = [pairs[i] for i in held]
        turned = rotation_channels.multiply(source.rotations[:, [source.index[a] for a, _ in names]],
                                            rotation_channels.conjugate(_rest_world(source, [a for a, _ in names])))
        rest = _rest_world(target, [t for _, t in names])
        aim = rotation_channels.rotate_each(rest, np.array([aims[1][t] for _, t in names]))
        out[0][:, held] = rotation_channels.rotate_each(turned, aim[None])
    return out[0], out[1]


def _stance(source: _Posed, fps: float) -> np.ndarray | None:
    try:
        feet = contacts.find_feet(source.obj)
    except ValueError:
        return None  # a rig without two recognised legs has no feet to judge
    return contacts.find_contacts(source.rig, source.basis, source.moved, feet, fps=fps, posed=source.pose,
                                  floor=None)


def source_stance(source, target) -> np.ndarray | None:
    """On which of the target action's frames the source stands on each foot point (frames, 4), as
    detected on the source (contacts.POINTS); None when the source has no two legs."""
    action = animdata.assigned_action(target)
    return _stance(_Posed(source, pose_channels.action_frames(action)), animdata.frame_rate(action))


def _feet(source: _Posed, target: _Posed, fps: float) -> clip_quality.FeetMotion | None:
    stance = _stance(source, fps)
    try:
        target_feet = contacts.find_feet(target.obj)
    except ValueError:
        return None
    if stance is None:
        return None
    points, _ = contacts.foot_points(target.rig, target.basis, target.moved, target_feet, posed=target.pose)
    rest_basis = np.tile([1.0, 0.0, 0.0, 0.0], (1, len(target.rig)))
    rest, _ = contacts.foot_points(target.rig, rest_basis, np.zeros((1, 3 * len(target.rig))), target_feet)
    return clip_quality.FeetMotion(points=points, rest=rest[0] + _floor_shift(target) * WORLD_UP, stance=stance,
                                   up=WORLD_UP, feet=FEET)


def _floor_shift(target: _Posed) -> float:
    """How far (world, along Z) the target's clip stands it above its rest where the retarget reads its floor
    from that clip (floor_fit.own_lift: a rest hanging off its origin while the clip walks on it), else 0:
    its feet are judged against its rest's feet stood there."""
    rig = target.rig
    try:
        return rig.scale * floor_fit.own_lift(rig, rig.body, rig.up, target.pose[1])
    except ValueError:  # no legs to stand on, or a non-uniform scale: the rest soles
        return 0.0


def measure(source, target, pairs, kept=()) -> clip_quality.Quality:
    """The figures of the target's action against the source's, over the target action's frames; pairs:
    the (source bone, target bone) map the retarget used; kept: the target bones that kept their own
    posture (retargeting.kept_bones), measured against the source's turn from its rest."""
    action = animdata.assigned_action(target)
    frames = pose_channels.action_frames(action)
    src, tgt = _Posed(source, frames), _Posed(target, frames)
    pairs = [(a, t) for a, t in pairs if a in src.index and t in tgt.index]
    source_dirs, target_dirs = _directions(src, tgt, pairs, set(kept))
    turn = clip_quality.best_turn_about(WORLD_UP, source_dirs, target_dirs)
    bones = clip_quality.BoneMotion(
        source_directions=rotation_channels.rotate(turn, source_dirs),
        target_directions=target_dirs,
        source_rotations=src.rotations[:, [src.index[a] for a, _ in pairs]],
        target_rotations=tgt.rotations[:, [tgt.index[t] for _, t in pairs]],
        names=[t for _, t in pairs])
    return clip_quality.measure(_feet(src, tgt, animdata.frame_rate(action)), bones)


def count_mapped(target, pairs) -> tuple[int, int]:
    """(body bones, finger bones) among the pairs' target bones."""
    body = bone_mapping.classify(pose_channels.armature_mapping_rig(target, upright=True))
    fingers = {bone for chain in body.fingers.values() for bone in chain}
    mapped = {t for _, t in pairs}
    return len(mapped - fingers), len(mapped & fingers)


def row_figures(source, target, pairs, kept=()) -> dict:
    """A batch report's figures of the target's new action (batch_report.COLUMNS). Only an action that keys
    the mapped bones themselves is measured: on a control rig the controls move them, through constraints
    that posing the keys alone does not evaluate, and its figures stay None."""
    action = animdata.assigned_action(target)
    start, end = action.frame_range
    body, fingers = count_mapped(target, pairs)
    figures = {"frames": int(round(end - start)) + 1, "fps": round(animdata.frame_rate(action), 3),
               "bones_mapped": body, "fingers_mapped": fingers}
    keyed = {c.data_path for c in animdata.fcurves(action, target)}
    if all(any(path.startswith(pose_channels.bone_path(t)) for path in keyed) for _, t in pairs):
        figures.update(measure(source, target, pairs, kept).as_dict())
    return figures
