"""An armature's bones and pose channels as arrays: rest data and keyed motion, read in bulk.

The one place for what the features read off an armature: its bones parents first and their hierarchy,
its rest pose (heads, tails, orientations, size) as numpy and as a native Rig, the pose channels an action
gives every bone on many frames (evaluated natively, as Blender evaluates them), as quaternions whatever
each bone's rotation mode, the bones' IK settings and their evaluated matrices.
"""
from __future__ import annotations

import bpy
import numpy as np

from . import animdata
from ..core import bone_axes, bone_mapping, native_state, rotation_channels
from ..core.rotation_keys import Keyer, bone_path  # noqa: F401  (bone_path: pose_channels' too)
from ..core.rig_data import FLOOR_PROPERTY, PoseChannels, RigData


def depth_first(armature) -> list:
    order, stack = [], [b for b in reversed(armature.bones) if b.parent is None]
    while stack:
        bone = stack.pop()
        order.append(bone)
        stack.extend(reversed(bone.children))
    return order


def parent_indices(bones) -> list[int]:
    """Each bone's parent as an index into bones, -1 for a bone whose parent is not among them."""
    index = {b.name: i for i, b in enumerate(bones)}
    return [index[b.parent.name] if b.parent is not None and b.parent.name in index else -1 for b in bones]


def ancestors(bone) -> list:
    """The bone's parent, its parent's parent, ... up to the top bone."""
    out = []
    while bone.parent is not None:
        bone = bone.parent
        out.append(bone)
    return out


def is_below(bone, top) -> bool:
    """Whether bone is top or hangs from it."""
    return bone == top or top in ancestors(bone)


def heads(bones) -> np.ndarray:
    """The bones' rest heads in armature space (bones, 3)."""
    return np.array([b.head_local for b in bones], dtype=np.float64).reshape(-1, 3)


def tails(bones) -> np.ndarray:
    """The bones' rest tails in armature space (bones, 3)."""
    return np.array([b.tail_local for b in bones], dtype=np.float64).reshape(-1, 3)


def rest_points(armature) -> np.ndarray:
    """Every bone's rest head, then every tail, in the armature's own bone order (2 bones, 3), read in bulk."""
    points = np.empty((2, 3 * len(armature.bones)))
    armature.bones.foreach_get("head_local", points[0])
    armature.bones.foreach_get("tail_local", points[1])
    return points.reshape(-1, 3)


def rig_size(armature) -> float:
    """The diagonal of the box around the rest pose's heads and tails: the length the solvers' tolerances
    scale with."""
    return float(np.linalg.norm(np.ptp(rest_points(armature), axis=0)))


def rest_matrices(armature) -> np.ndarray:
    """Every bone's rest matrix in armature space as Blender stores it (float32, bones x 16), read in bulk."""
    flat = np.empty(16 * len(armature.bones), dtype=np.float32)
    armature.bones.foreach_get("matrix_local", flat)
    return flat


def armature_mapping_rig(obj, upright: bool = False):
    """The armature at rest as core.bone_mapping sees it; upright: turned by the object's world rotation, so
    that up is Z as the shape rules read it (Blender's FBX importer leaves armatures Y-up in their own space,
    turned upright by the object). Labels are names: nothing needs turning back."""
    bones = depth_first(obj.data)
    head, tail = heads(bones), tails(bones)
    if upright and isinstance(obj, bpy.types.Object):
        turn = np.array(obj.matrix_world.to_3x3().normalized())
        head, tail = head @ turn.T, tail @ turn.T
    return bone_mapping.Rig(tuple(b.name for b in bones), tuple(parent_indices(bones)), head, tail)


def read_rig(obj, bones=None) -> RigData:
    """An armature object at rest as plain data (core.rig_data), read once: its bones parents first (or
    bones, a depth-first list of some of them), the object's placement, an importer's recorded floor and the
    pose channels as they stand (PoseChannels)."""
    bones = depth_first(obj.data) if bones is None else list(bones)
    _, rotation, scale = obj.matrix_world.decompose()
    recorded = obj.data.get(FLOOR_PROPERTY)
    floor = float(recorded) if isinstance(recorded, (int, float)) and np.isfinite(recorded) else None
    return RigData(obj.name, tuple(b.name for b in bones), tuple(parent_indices(bones)),
                   np.array([b.matrix_local.to_quaternion() for b in bones], dtype=np.float64).reshape(-1, 4),
                   heads(bones), tails(bones), np.array([b.length for b in bones], dtype=np.float64),
                   tuple(b.use_connect for b in bones), np.array(obj.matrix_world, dtype=np.float64),
                   np.array(rotation, dtype=np.float64), np.array(scale, dtype=np.float64), floor,
                   _pose_channels(obj, bones) if isinstance(obj, bpy.types.Object) and obj.pose else None)


def _pose_channels(obj, bones) -> PoseChannels:
    """The pose channels of bones as they stand, read in bulk (core.rig_data.PoseChannels)."""
    pose_bones = obj.pose.bones
    count = len(pose_bones)
    arrays = {}
    for prop, size in (("rotation_quaternion", 4), ("rotation_euler", 3), ("rotation_axis_angle", 4),
                       ("location", 3)):
        arrays[prop] = np.empty(count * size)
        pose_bones.foreach_get(prop, arrays[prop])
        arrays[prop] = arrays[prop].reshape(count, size)
    order = [pose_bones.find(b.name) for b in bones]
    # foreach_get gives an enum's storage, not its values: the modes one by one.
    modes = tuple(pose_bones[i].rotation_mode for i in order)
    values = tuple(arrays[rotation_channels.channel_property(mode)[0]][i].copy() for mode, i in zip(modes, order))
    moved = arrays["location"][order]
    moved[[b.use_connect for b in bones]] = 0.0
    return PoseChannels(obj.name, modes, values, moved)


def frames_between(start, end) -> np.ndarray:
    """The whole frames start..end (inclusive) as float64; ValueError when there are none."""
    start, end = int(start), int(end)
    if end < start:
        raise ValueError(f"frame range {start}..{end} is empty")
    return np.arange(start, end + 1, dtype=np.float64)


def action_frames(action, frame_range=None) -> np.ndarray:
    """Whole frames from frame_range (inclusive), or over the action's keys."""
    if frame_range is None:
        start, end = action.frame_range
        frame_range = (int(np.floor(start + 1e-6)), int(np.ceil(end - 1e-6)))
    return frames_between(*frame_range)


def rotation_keys(obj, names, q, *, placeholder: bool = False) -> tuple[list, np.ndarray]:
    """Pose bones' rotation channels and their values (channels, n) for quaternions q (n, 4k), bone j of
    names in columns 4j..4j+3: each bone in its own rotation mode, continuous from its pose's value, one
    native call per rotation mode; placeholder: zeros, the channels alone counting."""
    return rotation_keyer(obj, names)(q, placeholder=placeholder)


def rotation_keyer(obj, names) -> Keyer:
    """rotation_keys of some bones as a function of q alone (core.rotation_keys.Keyer): their rotation modes
    and current values are read here, so that the function touches no Blender data."""
    bones = [obj.pose.bones[name] for name in names]
    modes = tuple(bone.rotation_mode for bone in bones)
    previous = tuple(np.array(tuple(getattr(bone, rotation_channels.channel_property(mode)[0])), dtype=np.float64)
                     for bone, mode in zip(bones, modes))
    return Keyer(tuple(names), modes, previous)


def continuing_children(bones) -> np.ndarray:
    """(bones,) the index of the child that continues each of bones (parents first), -1 for none
    (core.bone_axes)."""
    return bone_axes.continuing_children(heads(bones), parent_indices(bones))


def bone_aims(armature, bones, continuing=None) -> tuple[np.ndarray, np.ndarray] | None:
    """Where each of bones (parents first) points in its own rest frame, (bones, 3), and how far, for an
    armature whose bones' Y axes do not run along their limbs; None for one whose do (core.bone_axes)."""
    rest = rest_quaternions(armature)
    return bone_axes.aims(heads(bones), tails(bones), parent_indices(bones), np.array([rest[b.name] for b in bones]),
                          continuing)


def rest_quaternions(armature) -> dict[str, np.ndarray]:
    """Each bone's rest orientation in armature space, as w x y z."""
    return {bone.name: np.array(bone.matrix_local.to_quaternion(), dtype=np.float64) for bone in armature.bones}


def _names(bones) -> list[str]:
    """Bone names from names or bones (anything with a name)."""
    return [getattr(b, "name", b) for b in bones]


def rotations(obj, action, bones, frames) -> np.ndarray:
    """Pose quaternions (frames, 4 * bones) from the action, in each bone's rotation mode. bones: names or
    bones."""
    native = native_state.native()
    names = _names(bones)
    channels, kinds, static = [], [], []
    for name in names:
        pose_bone = obj.pose.bones[name]
        mode = pose_bone.rotation_mode
        prop, size = rotation_channels.channel_property(mode)
        kinds.append((mode, len(channels), size))
        channels += [(f"{bone_path(name)}.{prop}", k) for k in range(size)]
        static += tuple(getattr(pose_bone, prop))
    values, _ = animdata.sample(action, obj, channels, frames, static)
    out = np.empty((frames.size, 4 * len(names)))
    for j, (mode, start, size) in enumerate(kinds):
        block = values[start:start + size].T
        q = rotation_channels.to_quaternions(native, mode, block, f"bone '{names[j]}' rotation", frames)
        out[:, 4 * j:4 * j + 4] = q
    return out


def _connected(obj, names) -> np.ndarray:
    """Per bone, whether it is connected to its parent: Blender ignores such a bone's location channel."""
    bones = obj.data.bones
    return np.array([bones[name].use_connect for name in names], dtype=bool)


def locations(obj, action, bones, frames) -> tuple[np.ndarray, list[bool]]:
    """Location channels (frames, 3 * bones) as Blender poses them, and per bone whether it moves at all: a
    bone connected to its parent reads zero (Blender ignores its channel, keyed or not), so that a native
    pose puts it where Blender does. A value that is not finite is a ValueError naming the bone and the
    frame, as rotations() gives for rotations. bones: names or bones."""
    names = _names(bones)
    channels = [(f"{bone_path(name)}.location", k) for name in names for k in range(3)]
    static = np.array([obj.pose.bones[name].location for name in names], dtype=np.float64).reshape(-1)
    values, found = animdata.sample(action, obj, channels, frames, static)
    out = np.ascontiguousarray(values.T)
    if not np.isfinite(out).all():
        frame, column = np.argwhere(~np.isfinite(out))[0]
        raise ValueError(f"'{obj.name}': bone '{names[column // 3]}' location is not finite at frame "
                         f"{frames[frame]:g} (action '{action.name}')")
    connected = _connected(obj, names)
    out.reshape(frames.size, -1, 3)[:, connected] = 0.0
    animated = (found.reshape(-1, 3).any(axis=1) | (static.reshape(-1, 3) != 0).any(axis=1)) & ~connected
    return out, animated.tolist()


def build_rig(names, parents, rest, rest_heads, lengths):
    """A native Rig from arrays: bone names and parent indices (parents first), rest orientations (bones,
    4) w x y z, rest heads (bones, 3) and lengths (bones,)."""
    return native_state.native().Rig(list(names), [int(p) for p in parents],
                                     np.ascontiguousarray(rest, dtype=np.float64).reshape(-1, 4),
                                     np.ascontiguousarray(rest_heads, dtype=np.float64).reshape(-1, 3),
                                     np.ascontiguousarray(lengths, dtype=np.float64).reshape(-1))


def native_rig(armature, bones=None):
    """The armature at rest as a native Rig (bones parents first), and that bone order."""
    bones = bones if bones is not None else depth_first(armature)
    rest = rest_quaternions(armature)
    unit = [rest[b.name] / np.linalg.norm(rest[b.name]) for b in bones]  # float32 matrices: unit to ~1e-6 only
    return build_rig([b.name for b in bones], parent_indices(bones), np.array(unit), heads(bones),
                     [b.length for b in bones]), bones


def armature_motion(obj, action, frames, rig=None, bones=None) -> tuple[np.ndarray, np.ndarray]:
    """The action's armature-space bone orientations (frames, 4B) and heads (frames, 3B), posed natively
    from its keys (bones parents first; the armature's own order unless given with their rig)."""
    if rig is None:
        rig, bones = native_rig(obj.data)
    moved, _ = locations(obj, action, bones, frames)
    return pose_basis(rig, frames, rotations(obj, action, bones, frames), moved)


def pose_basis(rig, frames, basis, moved) -> tuple[np.ndarray, np.ndarray]:
    """armature_motion's pose of pose channels already read (basis (frames, 4B), moved (frames, 3B))."""
    with native_state.blender_frames(frames):
        return native_state.native().armature_pose(rig, basis, np.ascontiguousarray(moved))


def current_pose(obj, bones) -> tuple[np.ndarray, np.ndarray]:
    """The pose as it stands, read in bulk: rotations as quaternions (bones, 4), whatever each bone's
    rotation mode, and locations (bones, 3) as Blender poses them (zero for a connected bone, as
    locations()), in the order of bones (names or bones)."""
    channels = _pose_channels(obj, [obj.data.bones[name] for name in _names(bones)])
    return channels.basis, channels.locations

_CHANNELS = (("location", 3), ("rotation_quaternion", 4), ("rotation_euler", 3), ("rotation_axis_angle", 4),
             ("scale", 3))


def channel_values(obj) -> dict:
    """Every pose bone's channels as they stand ({property: (bones, size) array}), read in bulk."""
    bones = obj.pose.bones
    out = {}
    for prop, size in _CHANNELS:
        out[prop] = np.empty(size * len(bones), dtype=np.float32)
        bones.foreach_get(prop, out[prop])
    return out


def set_channel_values(obj, values: dict) -> None:
    """channel_values' values back on the pose bones, in bulk (the same armature)."""
    for prop, array in values.items():
        obj.pose.bones.foreach_set(prop, array)


def ik_settings(obj, bones) -> dict:
    """The bones' IK settings (ik_min_*, ik_max_*, use_ik_limit_*, lock_ik_*, ik_stiffness_*, ik_stretch),
    read in bulk, in the order of bones, as the native IK solve takes them."""
    pose_bones = obj.pose.bones
    order = [pose_bones.find(bone.name) for bone in bones]

    def read(prop, dtype=np.float64):
        values = np.empty(len(pose_bones), dtype=dtype)
        pose_bones.foreach_get(prop, values)
        return values[order]

    def per_axis(pattern, dtype=np.float64):
        return np.stack([read(pattern.format(axis), dtype) for axis in "xyz"], axis=1)

    limited = per_axis("use_ik_limit_{}", bool)
    stretch = read("ik_stretch")
    scale_range = np.ones((len(bones), 2))
    scale_range[stretch > 0] = (0.5, 2.0)
    return {"limit_min": np.where(limited, per_axis("ik_min_{}"), -np.inf),
            "limit_max": np.where(limited, per_axis("ik_max_{}"), np.inf),
            "locked": per_axis("lock_ik_{}", bool), "stiffness": np.minimum(per_axis("ik_stiffness_{}"), 0.99),
            "stretch": stretch, "scale_range": scale_range}


def pose_matrices(obj) -> dict:
    """Each pose bone's evaluated matrix in armature space ({name: (4, 4)} float64), read in bulk."""
    flat = np.empty(16 * len(obj.pose.bones), dtype=np.float32)
    obj.pose.bones.foreach_get("matrix", flat)
    mats = flat.reshape(-1, 4, 4).transpose(0, 2, 1).astype(np.float64)  # Blender's matrices are column-major
    return {pb.name: mats[i] for i, pb in enumerate(obj.pose.bones)}

# Blender 5.0 moved bone selection from the armature's bones to the pose bones.
BONE_SELECTION_ON_POSE = "select" not in bpy.types.Bone.bl_rna.properties


def select_all(obj) -> None:
    """Select every bone of an armature object, wherever this Blender keeps bone selection."""
    bones = obj.pose.bones if BONE_SELECTION_ON_POSE else obj.data.bones
    bones.foreach_set("select", np.ones(len(bones), dtype=bool))


def selected(obj) -> list[bool]:
    """Each bone's selection, in the armature's order, wherever this Blender keeps it."""
    return [b.select for b in (obj.pose.bones if BONE_SELECTION_ON_POSE else obj.data.bones)]

