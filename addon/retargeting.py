"""Retarget motion from one armature (or a BVH file) onto another: motionkit.retarget.

The source's keyed motion is read in bulk and posed natively, the whole clip
is retargeted in one native call (see native/include/motionkit/retarget.hpp
for the mathematics), and the target gets a new action with one key per
source frame, in each bone's own rotation mode. Everything is computed and
checked before anything in the file changes, so an error leaves it as it was.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

import bpy
import numpy as np

from . import animdata, bone_mapping, bvh, native_state, pose_channels, rotation_channels

ROOT_MOTIONS = (
    ("scaled", "Scaled", "Translation scaled by the ratio of leg lengths"),
    ("in_place", "In place", "Keep only the vertical motion (scaled)"),
    ("offset", "Horizontal scaled, vertical offset",
     "Horizontal translation scaled, vertical as the source's plus the difference in hip height"),
    ("none", "None", "The root stays where the match pose has it"),
)
SOURCE_MATCHES = (
    ('REST', "Rest pose", "The source's rest pose is its reference pose"),
    ('FRAME', "Frame", "The source's pose on a frame (say a T-pose on frame 0) is its reference pose"),
)
TARGET_MATCHES = (
    ('REST', "Rest pose", "The target's rest pose is its reference pose"),
    ('CURRENT', "Current pose", "The target's current pose, set to stand like the source's reference pose"),
)
_IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


@dataclass
class _Side:
    """One armature, bones parents first, with its native Rig."""
    obj: bpy.types.Object
    bones: list
    rig: object

    @property
    def names(self) -> list[str]:
        return [b.name for b in self.bones]

    def index(self, name: str) -> int:
        return self.names.index(name)


def _side(obj, role: str) -> _Side:
    if obj is None:
        raise ValueError(f"no {role} armature given")
    if not isinstance(obj, bpy.types.Object) or obj.type != 'ARMATURE':
        raise ValueError(f"the {role} '{getattr(obj, 'name', obj)}' is not an armature object")
    if not len(obj.data.bones):
        raise ValueError(f"the {role} armature '{obj.name}' has no bones")
    rig, bones = pose_channels.native_rig(obj.data)
    return _Side(obj, bones, rig)


def mapping_rig(obj):
    """The armature at rest as motionkit.bone_mapping sees it."""
    bones = pose_channels.depth_first(obj.data)
    index = {b.name: i for i, b in enumerate(bones)}
    return bone_mapping.Rig(tuple(b.name for b in bones),
                            tuple(index[b.parent.name] if b.parent else -1 for b in bones),
                            np.array([b.head_local for b in bones], dtype=np.float64).reshape(-1, 3),
                            np.array([b.tail_local for b in bones], dtype=np.float64).reshape(-1, 3))


def auto_map(source, target) -> list[tuple[str, str]]:
    """(source bone, target bone) pairs found from names and, where they say nothing, the skeletons."""
    return bone_mapping.auto_map(mapping_rig(source), mapping_rig(target))


def _pairs(bone_map, source: _Side, target: _Side) -> list[tuple[str, str]]:
    if bone_map is None:
        bone_map = auto_map(source.obj, target.obj)
    items = list(bone_map.items()) if isinstance(bone_map, dict) else [tuple(p) for p in bone_map]
    source_names, target_names = set(source.names), set(target.names)
    seen = set()
    pairs = []
    for pair in items:
        if len(pair) != 2:
            raise ValueError(f"bone map entries are (source bone, target bone) pairs, got {pair!r}")
        src, tgt = pair
        if not src or not tgt:
            continue
        if src not in source_names:
            raise ValueError(f"bone map: '{src}' is not a bone of the source '{source.obj.name}'")
        if tgt not in target_names:
            raise ValueError(f"bone map: '{tgt}' is not a bone of the target '{target.obj.name}'")
        if tgt in seen:
            raise ValueError(f"bone map: the target bone '{tgt}' is mapped twice")
        seen.add(tgt)
        pairs.append((src, tgt))
    if not pairs:
        raise ValueError(f"no common bones: nothing maps '{source.obj.name}' onto '{target.obj.name}'")
    return pairs


def _frames(action, frame_range) -> np.ndarray:
    if frame_range is None:
        start, end = action.frame_range
        frame_range = (int(np.floor(start + 1e-6)), int(np.ceil(end - 1e-6)))
    start, end = (int(v) for v in frame_range)
    if end < start:
        raise ValueError(f"frame range {start}..{end} is empty")
    return np.arange(start, end + 1, dtype=np.float64)


@dataclass
class _Pose:
    """A rig standing in its match pose, in its own armature space."""
    rotations: np.ndarray  # (bones, 4)
    heads: np.ndarray      # (bones, 3)
    lengths: np.ndarray    # (bones,)

    @property
    def points(self) -> np.ndarray:
        tails = self.heads + self.lengths[:, None] * rotation_channels.y_axes(self.rotations)
        return np.vstack([self.heads, tails])


def _lengths(side: _Side) -> np.ndarray:
    return np.array([b.length for b in side.bones], dtype=np.float64)


def _world_rotation_scale(obj) -> tuple[np.ndarray, float]:
    _, rotation, scale = obj.matrix_world.decompose()
    sigma = float(np.mean(scale))
    if not np.allclose(scale, sigma, rtol=1e-6):
        raise ValueError(f"'{obj.name}' has a non-uniform scale {tuple(scale)}; apply it first")
    return np.array(rotation, dtype=np.float64), sigma


def _facing(space, source_pose: _Pose, target_pose: _Pose, pairs_idx, source_root, target_root) -> np.ndarray:
    """The quarter turns about the target's Z that best lay the source's mapped joints over the target's.

    A least-squares fit (2-D Kabsch) of the joints' horizontal offsets from the
    roots, rounded to a multiple of 90 degrees, so that a character facing +Y
    retargets onto one facing -Y walking forwards, not backwards.
    """
    src = rotation_channels.rotate(space, source_pose.heads[[a for a, _ in pairs_idx]] - source_pose.heads[source_root])
    tgt = target_pose.heads[[b for _, b in pairs_idx]] - target_pose.heads[target_root]
    cross = np.sum(src[:, 0] * tgt[:, 1] - src[:, 1] * tgt[:, 0])
    dot = np.sum(src[:, 0] * tgt[:, 0] + src[:, 1] * tgt[:, 1])
    angle = np.arctan2(cross, dot) if abs(cross) + abs(dot) > 0 else 0.0
    # Rigs face along their axes; a fit's few degrees of asymmetry are not a turn.
    angle = np.pi / 2 * np.round(angle / (np.pi / 2))
    return np.array([np.cos(angle / 2), 0.0, 0.0, np.sin(angle / 2)])


def _hip_height(pose: _Pose, root: int, up: np.ndarray) -> float:
    """How high the root stands above the rig's lowest point, along up."""
    heights = pose.points @ up
    return float(pose.heads[root] @ up - heights.min())


@dataclass
class Plan:
    """Everything the retarget computes, before anything is written."""
    target: bpy.types.Object
    frames: np.ndarray
    channels: list
    values: np.ndarray  # (channels, frames)
    source_name: str
    pairs: list
    still_channels: list  # bones that keep the match pose: one key on the first frame
    still_values: np.ndarray  # (still_channels, 1)


def plan(source, target, bone_map=None, frame_range=None, root: str = "scaled", *, source_match: str = 'REST',
         match_frame: float | None = None, target_match: str = 'REST', ground: bool = False,
         align_facing: bool = True) -> Plan:
    """Compute the retargeted keys without touching the file (see retarget)."""
    native = native_state.native()
    src, tgt = _side(source, "source"), _side(target, "target")
    if src.obj == tgt.obj:
        raise ValueError(f"the source and the target are the same armature '{src.obj.name}' (a cycle)")
    if root not in [r[0] for r in ROOT_MOTIONS]:
        raise ValueError(f"unknown root motion {root!r}; expected one of {[r[0] for r in ROOT_MOTIONS]}")
    if source_match not in [m[0] for m in SOURCE_MATCHES] or target_match not in [m[0] for m in TARGET_MATCHES]:
        raise ValueError(f"unknown match pose {source_match!r} / {target_match!r}")
    action = animdata.assigned_action(src.obj)
    if action is None:
        raise ValueError(f"the source '{src.obj.name}' has no action to retarget")
    pairs = _pairs(bone_map, src, tgt)
    frames = _frames(action, frame_range)

    source_rotations, source_heads = pose_channels.armature_motion(src.obj, action, frames, src.rig, src.bones)
    if source_match == 'FRAME':
        if match_frame is None:
            raise ValueError("a source match pose on a frame needs match_frame")
        match_rot, match_heads = pose_channels.armature_motion(src.obj, action, np.array([float(match_frame)]),
                                                                     src.rig, src.bones)
        source_pose = _Pose(match_rot.reshape(-1, 4), match_heads.reshape(-1, 3), _lengths(src))
    else:
        source_pose = _Pose(np.array([pose_channels.rest_quaternions(src.obj.data)[n] for n in src.names]),
                            np.array([b.head_local for b in src.bones], dtype=np.float64), _lengths(src))
    if target_match == 'CURRENT':
        target_basis, target_locations = pose_channels.current_pose(tgt.obj, tgt.bones)
    else:
        target_basis = np.tile(_IDENTITY, (len(tgt.bones), 1))
        target_locations = np.zeros((len(tgt.bones), 3))
    match_rotations, match_heads = native.armature_pose(tgt.rig, np.ascontiguousarray(target_basis.reshape(1, -1)),
                                                        np.ascontiguousarray(target_locations.reshape(1, -1)))
    target_pose = _Pose(match_rotations.reshape(-1, 4), match_heads.reshape(-1, 3), _lengths(tgt))

    bone_map_idx = np.full(len(tgt.bones), -1, dtype=np.int64)
    pairs_idx = [(src.index(a), tgt.index(b)) for a, b in pairs]
    for a, b in pairs_idx:
        bone_map_idx[b] = a
    depth = [0] * len(tgt.bones)
    for i, bone in enumerate(tgt.bones):
        depth[i] = depth[tgt.index(bone.parent.name)] + 1 if bone.parent else 0
    target_root = min((b for _, b in pairs_idx), key=lambda b: (depth[b], b))
    source_root = int(bone_map_idx[target_root])

    source_world, source_scale = _world_rotation_scale(src.obj)
    target_world, target_scale = _world_rotation_scale(tgt.obj)
    space = rotation_channels.multiply(rotation_channels.conjugate(target_world), source_world)
    if align_facing:
        space = rotation_channels.multiply(_facing(space, source_pose, target_pose, pairs_idx, source_root, target_root), space)
    up = np.array([0.0, 0.0, 1.0])
    source_up = rotation_channels.rotate(rotation_channels.conjugate(space), up[None, :])[0]
    source_height = _hip_height(source_pose, source_root, source_up)
    target_height = _hip_height(target_pose, target_root, up)
    if not (source_height > 1e-9 and target_height > 1e-9):
        raise ValueError("the root stands at the lowest point of a rig: no leg length to scale the motion by")
    rotations, root_locations = native.retarget(
        src.rig, tgt.rig, source_rotations, np.ascontiguousarray(source_heads[:, 3 * source_root:3 * source_root + 3]),
        [int(v) for v in bone_map_idx],
        source_match=np.ascontiguousarray(source_pose.rotations), source_match_root=source_pose.heads[source_root],
        target_match_basis=np.ascontiguousarray(target_basis), target_match_location=target_locations[target_root],
        source_root=source_root, target_root=target_root, space=space, scale=target_height / source_height,
        unit_scale=source_scale / target_scale,
        vertical_offset=target_height - source_scale / target_scale * source_height, root_motion=root,
        ground_bones=list(range(len(tgt.bones))) if ground else [])

    moving, still = _target_channels(native, tgt, rotations, target_basis, bone_map_idx, target_root,
                                     root_locations)
    plan_ = Plan(tgt.obj, frames, *moving, src.obj.name, pairs, *still)
    if not (np.all(np.isfinite(plan_.values)) and np.all(np.isfinite(plan_.still_values))):
        raise ValueError("the retargeted motion is not finite; check the rigs' rest poses")
    return plan_


def _target_channels(native, tgt: _Side, rotations, target_basis, bone_map_idx, target_root, root_locations):
    """The F-curves to key, in each bone's own rotation mode: (channels, values) for the bones the retarget
    moves and the root's location, one key per frame; (channels, values) for the bones that keep the match
    pose, one key."""
    moving, still = ([], []), ([], [])
    frames = rotations.shape[0]
    for b, bone in enumerate(tgt.bones):
        q = rotations[:, 4 * b:4 * b + 4]
        moved = bone_map_idx[b] >= 0 or bool(np.any(np.abs(q @ target_basis[b]) < 1.0 - 1e-12))
        path = f'pose.bones["{bpy.utils.escape_identifier(bone.name)}"]'
        if b == target_root:
            moving[0].extend((f"{path}.location", k, bone.name) for k in range(3))
            moving[1].append(root_locations.T)
        pose_bone = tgt.obj.pose.bones[bone.name]
        mode = pose_bone.rotation_mode
        prop, size = rotation_channels.channel_property(mode)
        previous = np.array(tuple(getattr(pose_bone, prop)), dtype=np.float64)
        q = q if moved else q[:1]
        values = rotation_channels.from_quaternions(native, mode, np.ascontiguousarray(q), previous=previous)
        out = moving if moved else still
        out[0].extend((f"{path}.{prop}", k, bone.name) for k in range(size))
        out[1].append(values.T)
    stack = lambda rows, n: np.vstack(rows) if rows else np.empty((0, n))  # noqa: E731
    return (moving[0], stack(moving[1], frames)), (still[0], stack(still[1], 1))


def apply(plan_: Plan, *, action_name: str | None = None, overwrite: bool = False) -> bpy.types.Action:
    """Write a plan's keys: a new action on the target, or its own one with overwrite."""
    target = plan_.target
    previous = animdata.assigned_action(target)
    if overwrite and previous is not None:
        _write(target, previous, plan_)
        return previous
    action = animdata.new_action(action_name or f"{plan_.source_name} -> {target.name}")
    try:
        _write(target, action, plan_)
        if previous is not None and previous.users == 1 and not previous.use_fake_user:
            previous.use_fake_user = True  # the user's action must outlive losing its last user
        animdata.assign(target, action)
    except BaseException:
        bpy.data.actions.remove(action)
        raise
    return action


def _write(target, action, plan_: Plan) -> None:
    if plan_.channels:
        animdata.write_keys(target, action, plan_.channels, plan_.frames, plan_.values)
    if plan_.still_channels:
        animdata.write_keys(target, action, plan_.still_channels, plan_.frames[:1], plan_.still_values)


def retarget(source, target, bone_map=None, frame_range=None, root: str = "scaled", *,
             source_match: str = 'REST', match_frame: float | None = None, target_match: str = 'REST',
             ground: bool = False, align_facing: bool = True, action_name: str | None = None,
             overwrite: bool = False):
    """Retarget the source's action onto the target; returns the target's new action.

    source: an armature object with an action, or a BVH file path (imported
    first with motionkit.bvh.load; the imported armature stays in the scene).
    bone_map: (source bone, target bone) pairs or a {source: target} dict;
    None maps automatically (motionkit.bone_mapping). frame_range: inclusive
    source frames (default: the action's), one key per frame on the same
    frames. root: "scaled", "in_place", "offset" or "none" (ROOT_MOTIONS).
    source_match 'REST' or 'FRAME' (with match_frame) and target_match 'REST'
    or 'CURRENT': the poses in which the two rigs stand alike. ground: move the
    root so that the target's lowest point touches its floor (armature Z = 0) on
    the first frame. align_facing: turn the motion so that each rig walks the
    way it faces. The new action is assigned to the target (its previous
    action keeps a fake user rather than being lost); with overwrite the keys
    replace the target's own action's curves instead. A ValueError leaves the
    file as it was (a BVH source is removed again).
    """
    imported = None
    if isinstance(source, (str, os.PathLike)):
        imported, _ = bvh.load(os.fspath(source))
        source = imported
    try:
        result = plan(source, target, bone_map, frame_range, root, source_match=source_match,
                      match_frame=match_frame, target_match=target_match, ground=ground,
                      align_facing=align_facing)
        return apply(result, action_name=action_name, overwrite=overwrite)
    except BaseException:
        if imported is not None:
            remove_armature(imported)
        raise


def remove_armature(obj) -> None:
    action, armature = animdata.assigned_action(obj), obj.data
    bpy.data.objects.remove(obj)
    bpy.data.armatures.remove(armature)
    if action is not None and action.users == 0:
        bpy.data.actions.remove(action)


def retarget_files(paths, target, *, keep_sources: bool = False, **options) -> list:
    """Retarget every BVH file onto the target: one action per file, named after it.

    For pipelines (blender --background): each file is imported, retargeted
    and, unless keep_sources, its armature removed again. The target ends with
    the last file's action assigned; every action keeps a fake user so that
    saving the file keeps them all. Returns the actions in the order of paths.
    A file that fails raises ValueError naming it; the files before it keep
    their actions.
    """
    actions = []
    for path in paths:
        name = os.path.splitext(os.path.basename(path))[0]
        source, _ = bvh.load(os.fspath(path))
        try:
            action = apply(plan(source, target, **options), action_name=name)
            action.use_fake_user = True
            actions.append(action)
        except ValueError as ex:
            raise ValueError(f"{path}: {ex}") from None
        finally:
            if not keep_sources:
                remove_armature(source)
        action.name = name  # the imported source's action held the name until now
    return actions
