"""An object's own transform channels: read in bulk over frames (animdata.sample) as world matrices, with its
parents' (core/object_motion composes them), and written as keys (animdata.write_keys' channels)."""
from __future__ import annotations

from dataclasses import dataclass

import bpy
import numpy as np

from . import animdata
from ..core import native_state, object_motion, rotation_channels

GROUP = "Object Transforms"  # the group Blender keys an object's transform in


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


@dataclass
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

    def placement(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The reference world as RigData keeps one: (matrix (4, 4), rotation (4,), scale (3,))."""
        scale = np.linalg.norm(self.reference[:3, :3], axis=0)
        return self.reference.copy(), object_motion.quaternions(self.reference[None, :3, :3] / scale)[0], scale


def transform_keys(obj, locations, rotations) -> tuple[list, np.ndarray]:
    """Channels and values (channels, n) keying obj's location and rotation (quaternions (n, 4)), the rotation
    in obj's own mode, continuous from its current value."""
    mode = obj.rotation_mode
    prop, size = rotation_channels.channel_property(mode)
    values = rotation_channels.from_quaternions(native_state.native(), mode, rotations,
                                                np.array(getattr(obj, prop), dtype=np.float64))
    channels = [("location", k, GROUP) for k in range(3)] + [(prop, k, GROUP) for k in range(size)]
    return channels, np.vstack([np.asarray(locations, dtype=np.float64).T, values.T])


def placement(obj) -> tuple[np.ndarray, np.ndarray, float]:
    """obj's location (3,) and rotation channels as a quaternion (4,), and (its matrix_basis' rotation (4,),
    uniform scale): what object_motion.object_keys moves it from."""
    mode = obj.rotation_mode
    prop, _ = rotation_channels.channel_property(mode)
    native = native_state.native()
    own = rotation_channels.to_quaternions(native, mode, np.array([getattr(obj, prop)], dtype=np.float64),
                                           f"the object '{obj.name}' rotation")[0]
    basis = np.array(obj.matrix_basis, dtype=np.float64)[:3, :3]
    scale = np.linalg.norm(basis, axis=0)
    return np.array(obj.location, dtype=np.float64), own, \
        (object_motion.quaternions(basis[None] / scale)[0], float(np.mean(scale)))
