"""An object's own transform channels: read in bulk over frames (animdata.sample) as world matrices, with its
parents' (core/object_motion composes them), and written as keys (animdata.write_keys' channels)."""
from __future__ import annotations

import dataclasses

import bpy
import numpy as np

from . import animdata, pose_channels
from ..core import native_state, object_motion, rotation_channels
from ..core.retarget_inputs import ObjectRotation

GROUP = object_motion.GROUP
# On an action whose keys move its object by root motion (root_motion_onto="object"): where the object stood
# before (ObjectBase.values), so that the next clip put onto it starts from there too, not from wherever the
# last one's keys left the object's channels.
BASE = "motionkit_object_base"


def _delta_property(mode: str) -> str | None:
    """The delta rotation that applies in this rotation mode (Blender has none for axis-angle)."""
    if mode == 'QUATERNION':
        return "delta_rotation_quaternion"
    return "delta_rotation_euler" if mode in rotation_channels.EULER_MODES else None


def basis_matrices(obj, action, frames) -> tuple[np.ndarray, bool]:
    """(n, 4, 4) obj.matrix_basis over frames from action's curves of obj (its values where unkeyed), delta
    transforms included as Blender composes them; and whether any of those channels is keyed."""
    mode = obj.rotation_mode
    prop, size = rotation_channels.channel_property(mode)
    delta = _delta_property(mode)
    parts = [("location", 3), ("delta_location", 3), (prop, size), ("scale", 3), ("delta_scale", 3)]
    parts += [(delta, 4 if mode == 'QUATERNION' else 3)] if delta else []
    channels = [(name, k) for name, count in parts for k in range(count)]
    static = np.concatenate([np.array(getattr(obj, name), dtype=np.float64) for name, _ in parts])
    values, found = animdata.sample(action, obj, channels, frames, static)
    if not np.isfinite(values).all():
        row, column = np.argwhere(~np.isfinite(values.T))[0]
        raise ValueError(f"the object '{obj.name}': {channels[column][0]}[{channels[column][1]}] is not finite at "
                         f"frame {frames[row]:g}")
    blocks, start = {}, 0
    for name, count in parts:
        blocks[name] = values[start:start + count].T
        start += count
    native = native_state.native()
    what = f"the object '{obj.name}' rotation"
    turn = rotation_channels.to_quaternions(native, mode, blocks[prop], what, frames)
    if delta:  # Blender's delta rotation is in front of the keyed one, in the same Euler order
        turn = rotation_channels.multiply(rotation_channels.to_quaternions(
            native, mode, blocks[delta], f"the object '{obj.name}' delta rotation", frames), turn)
    return object_motion.basis_matrices(blocks["location"] + blocks["delta_location"], turn,
                                        blocks["scale"] * blocks["delta_scale"]), bool(found.any())


def world_matrices(obj, action, frames) -> tuple[np.ndarray, bool]:
    """(n, 4, 4) obj's world matrices over frames, from its action's transform curves (action) and its object
    parents' own actions; and whether any of them is keyed. Above the first parent that is no plain object
    parent (a bone, a vertex), the world is taken as it stands."""
    chain, o = [obj], obj
    while o.parent is not None and o.parent_type == 'OBJECT':
        o = o.parent
        chain.append(o)
    frames = np.asarray(frames, dtype=np.float64)
    keyed, world = False, None
    for o in reversed(chain):
        basis, moves = basis_matrices(o, action if o is obj else animdata.assigned_action(o), frames)
        keyed |= moves
        if world is None:
            top = np.eye(4) if o.parent is None else \
                np.array(o.matrix_world, dtype=np.float64) @ np.linalg.inv(np.array(o.matrix_basis, dtype=np.float64))
            world = top @ basis
        else:
            world = world @ np.array(o.matrix_parent_inverse, dtype=np.float64) @ basis
    return world, keyed


@dataclasses.dataclass
class ObjectMotion:
    """An object whose own transform (or a parent's) is keyed: its world on the reference frame, and how to
    read its motion from there."""
    obj: bpy.types.Object
    action: bpy.types.Action
    reference: np.ndarray  # (4, 4) its world matrix on the reference frame

    @classmethod
    def read(cls, obj, action, reference_frame: float) -> "ObjectMotion | None":
        """obj's motion, or None when neither its transform nor a parent's is keyed."""
        worlds, keyed = world_matrices(obj, action, np.array([float(reference_frame)]))
        return cls(obj, action, worlds[0]) if keyed else None

    def at(self, frames) -> tuple[np.ndarray, np.ndarray]:
        """(rotations (n, 4), translations (n, 3)): the motion from the reference placement to each frame's,
        in the object's own (armature) space."""
        worlds, _ = world_matrices(self.obj, self.action, frames)
        return object_motion.relative_motion(worlds, self.reference, f"the source '{self.obj.name}'", frames)

    @classmethod
    def of_action(cls, obj, action) -> "ObjectMotion | None":
        """obj's motion from its base where the action records one (BASE), else from where it stands on the
        action's first frame (the armature space that the bones' channels are then read in); None when
        nothing moves the object."""
        motion = cls.read(obj, action, pose_channels.action_frames(action, None)[0])
        recorded = ObjectBase.recorded(action)
        if motion is None or recorded is None:
            return motion
        return dataclasses.replace(motion, reference=recorded.world.copy())

    def placed(self, rig):
        """rig (core.rig_data.RigData) placed where the object stands on the reference frame."""
        return placed_at(rig, self.reference)

    def composed(self, rig, frames, basis, locations) -> tuple[np.ndarray, np.ndarray]:
        """The bones' channels (basis (n, 4B), locations (n, 3B)) with the object's motion over frames
        composed into its top bones', so that they pose in the reference frame's armature space."""
        basis, locations = object_motion.compose_tops(rig.unit_rest, rig.heads, rig.parents, basis, locations,
                                                      *self.at(np.asarray(frames, dtype=np.float64)))
        return np.ascontiguousarray(basis), np.ascontiguousarray(locations)


def transform_keys(obj, locations, rotations) -> tuple[list, np.ndarray]:
    """Channels and values (channels, n) keying obj's location and rotation (quaternions (n, 4)), the rotation
    in obj's own mode, continuous from its current value."""
    return rotation_of(obj).keys(locations, rotations)


def rotation_of(obj) -> ObjectRotation:
    """The object's rotation channels as they stand (core.retarget_inputs.ObjectRotation)."""
    prop, _ = rotation_channels.channel_property(obj.rotation_mode)
    return ObjectRotation(obj.rotation_mode, np.array(getattr(obj, prop), dtype=np.float64))


def placed_at(rig, world):
    """rig (core.rig_data.RigData) placed at a world matrix (4, 4)."""
    scale = np.linalg.norm(world[:3, :3], axis=0)
    rotation = object_motion.quaternions(world[None, :3, :3] / scale)[0]
    return dataclasses.replace(rig, world=np.array(world, dtype=np.float64), world_rotation=rotation,
                               world_scale=scale)


@dataclasses.dataclass(frozen=True)
class ObjectBase:
    """Where an object stands before root motion is put on it: its location (3,) and rotation channels as a
    quaternion (4,), its matrix_basis' rotation (4,) and uniform scale (what object_motion.object_keys moves
    it from), and its world matrix (4, 4)."""
    location: np.ndarray
    rotation: np.ndarray
    turn: np.ndarray
    scale: float
    world: np.ndarray

    def values(self) -> list[float]:
        return [*self.location, *self.rotation, *self.turn, self.scale, *self.world.reshape(-1)]

    @classmethod
    def recorded(cls, action) -> "ObjectBase | None":
        """The base an action records (BASE), or None."""
        if action is None or BASE not in action:
            return None
        v = np.array(action[BASE], dtype=np.float64)
        return cls(v[:3], v[3:7], v[7:11], float(v[11]), v[12:28].reshape(4, 4))

    @classmethod
    def of(cls, obj) -> "ObjectBase":
        """obj's base: the one its action records, else its channels and world as they stand."""
        recorded = cls.recorded(animdata.assigned_action(obj))
        if recorded is not None:
            return recorded
        mode = obj.rotation_mode
        prop, _ = rotation_channels.channel_property(mode)
        own = rotation_channels.to_quaternions(native_state.native(), mode,
                                               np.array([getattr(obj, prop)], dtype=np.float64),
                                               f"the object '{obj.name}' rotation")[0]
        basis = np.array(obj.matrix_basis, dtype=np.float64)[:3, :3]
        scale = np.linalg.norm(basis, axis=0)
        return cls(np.array(obj.location, dtype=np.float64), own, object_motion.quaternions(basis[None] / scale)[0],
                   float(np.mean(scale)), np.array(obj.matrix_world, dtype=np.float64))

    def record(self, action) -> None:
        action[BASE] = self.values()

    def keys(self, track) -> tuple[np.ndarray, np.ndarray]:
        """The object's location (n, 3) and rotation (n, 4) that move it from here by a track (rotations
        (n, 4), translations (n, 3) in its own space)."""
        return object_motion.object_keys(self.location, self.rotation, (self.turn, self.scale), *track)


def at_base(obj, rig):
    """rig (obj's, core.rig_data.RigData) placed where obj stood before the root motion its action keys
    (ObjectBase.recorded), or as read, when its action records none."""
    recorded = ObjectBase.recorded(animdata.assigned_action(obj))
    return rig if recorded is None else placed_at(rig, recorded.world)
