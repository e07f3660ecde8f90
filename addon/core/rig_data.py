"""One armature at rest as plain data: what every stage of a retarget (and the feet's cleanup) reads of a
rig, read once (blender/pose_channels.read_rig, or a control rig's deform skeleton from its map) and never
an imitation of Blender's objects. No bpy.

Bones are parents first. Positions are in the armature's own space and units; `world` places that space
in the scene (the object's world matrix, its rotation and scale kept apart as Blender decomposes it).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from . import bone_axes, bone_mapping, native_state, rotation_channels

# The custom property an importer leaves on an armature's data to say where its floor is (armature units
# along up): a capture's floor, which its rest pose need not stand on.
FLOOR_PROPERTY = "motionkit_floor"


@dataclass(frozen=True, eq=False)
class PoseChannels:
    """An armature's pose channels as they stand, read with its rest: per bone its rotation mode (modes),
    that mode's property values (rotation_values: 3 or 4 each, what keys continue from) and the location
    channels (locations (B, 3), zero for a bone connected to its parent, which Blender does not move). name:
    the rig's, for messages."""
    name: str
    modes: tuple
    rotation_values: tuple
    locations: np.ndarray

    @cached_property
    def basis(self) -> np.ndarray:
        """(B, 4) the rotations as unit quaternions w x y z, whatever each bone's mode; a ValueError for one
        that is no rotation (a zero quaternion), naming the rig, only when a pose as it stands is asked for."""
        native = native_state.native()
        out = np.empty((len(self.modes), 4))
        modes = np.array(self.modes)
        for mode in np.unique(modes):
            rows = np.flatnonzero(modes == mode)
            out[rows] = rotation_channels.to_quaternions(native, str(mode), [self.rotation_values[i] for i in rows],
                                                         f"'{self.name}' pose rotation")
        return out


@dataclass(eq=False)
class RigData:
    """An armature at rest. rest: (B, 4) orientations w x y z as Blender stores them (float32 matrices:
    unit to about 1e-7; unit_rest normalises them); heads, tails (B, 3); lengths (B,); connected: each
    bone's head held on its parent's tail; world (4, 4), world_rotation (4,) and world_scale (3,): the
    object's placement; floor: an importer's recorded floor, or None; channels: the pose channels as they
    stand (PoseChannels), or None for a rig not read from an armature's pose."""
    name: str
    names: tuple
    parents: tuple
    rest: np.ndarray
    heads: np.ndarray
    tails: np.ndarray
    lengths: np.ndarray
    connected: tuple
    world: np.ndarray = field(default_factory=lambda: np.eye(4))
    world_rotation: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0, 0.0]))
    world_scale: np.ndarray = field(default_factory=lambda: np.ones(3))
    floor: float | None = None
    channels: PoseChannels | None = None

    def __post_init__(self):
        count = len(self.names)
        self.names, self.parents, self.connected = tuple(self.names), tuple(int(p) for p in self.parents), \
            tuple(bool(c) for c in self.connected)
        for what, value, shape in (("rest", self.rest, (count, 4)), ("heads", self.heads, (count, 3)),
                                   ("tails", self.tails, (count, 3)), ("lengths", self.lengths, (count,))):
            if np.shape(value) != shape:
                raise ValueError(f"rig '{self.name}': {what} must be {shape}, not {np.shape(value)}")
        if len(self.parents) != count or len(self.connected) != count:
            raise ValueError(f"rig '{self.name}': one parent and one connection per bone")
        if any(not -1 <= p < i for i, p in enumerate(self.parents)):
            raise ValueError(f"rig '{self.name}': bones must come parents first")
        if self.channels is not None and len(self.channels.modes) != count:
            raise ValueError(f"rig '{self.name}': one rotation mode per bone")
        self._index = {n: i for i, n in enumerate(self.names)}

    def __len__(self) -> int:
        return len(self.names)

    def __contains__(self, name) -> bool:
        return name in self._index

    def index(self, name: str) -> int:
        return self._index[name]

    def ancestors(self, bone: int) -> list[int]:
        """The bone's parent, its parent's parent, ... up to its top bone."""
        out, p = [], self.parents[bone]
        while p >= 0:
            out.append(p)
            p = self.parents[p]
        return out

    def is_below(self, bone: int, top: int) -> bool:
        """Whether bone is top or hangs from it."""
        return bone == top or top in self.ancestors(bone)

    def top(self, bone: int) -> int:
        above = self.ancestors(bone)
        return above[-1] if above else bone

    @cached_property
    def depths(self) -> list[int]:
        depth = [0] * len(self)
        for i, p in enumerate(self.parents):
            depth[i] = depth[p] + 1 if p >= 0 else 0
        return depth

    @cached_property
    def unit_rest(self) -> np.ndarray:
        return self.rest / np.linalg.norm(self.rest, axis=1, keepdims=True)

    def rest_of(self, name: str) -> np.ndarray:
        return self.rest[self.index(name)]

    @property
    def size(self) -> float:
        """The diagonal of the box around the rest heads and tails: what solver tolerances scale with."""
        return float(np.linalg.norm(np.ptp(np.vstack([self.heads, self.tails]), axis=0))) if len(self) else 0.0

    @property
    def scale(self) -> float:
        """The object's uniform scale; a ValueError for a non-uniform one (no single ratio to scale by)."""
        sigma = float(np.mean(self.world_scale))
        if not np.allclose(self.world_scale, sigma, rtol=1e-6):
            raise ValueError(f"'{self.name}' has a non-uniform scale {tuple(self.world_scale)}; apply it first")
        return sigma

    @property
    def up(self) -> np.ndarray:
        """World up (Z) in the armature's space: an FBX import turned 90 degrees about X has it along Y."""
        return rotation_channels.rotate(rotation_channels.conjugate(self.world_rotation),
                                        np.array([[0.0, 0.0, 1.0]]))[0]

    def world_height_to_armature(self, height: float) -> float:
        """A world Z height as a height along up in the armature's space (its units)."""
        return (float(height) - float(self.world[2, 3])) / self.scale

    def armature_height_to_world(self, height: float) -> float:
        return float(self.world[2, 3]) + self.scale * float(height)

    def native_rig(self, bones=None):
        """A native Rig of the bones listed (default all; parents outside them are none)."""
        bones = range(len(self)) if bones is None else list(bones)
        where = {b: i for i, b in enumerate(bones)}
        return native_state.native().Rig(
            [self.names[b] for b in bones], [where.get(self.parents[b], -1) for b in bones],
            np.ascontiguousarray(self.unit_rest[bones]), np.ascontiguousarray(self.heads[bones]),
            np.ascontiguousarray(self.lengths[bones]))

    @cached_property
    def native(self):
        """The whole rig as a native Rig, built once."""
        return self.native_rig()

    def mapping_rig(self, upright: bool = True) -> bone_mapping.Rig:
        """The rig as core.bone_mapping reads it; upright: turned by the object's rotation, so that up is Z as
        the shape rules read it (labels are names: nothing needs turning back)."""
        heads, tails = self.heads, self.tails
        if upright:
            turn = self.world[:3, :3] / np.linalg.norm(self.world[:3, :3], axis=0)
            heads, tails = heads @ turn.T, tails @ turn.T
        return bone_mapping.Rig(self.names, self.parents, heads, tails)

    @cached_property
    def body(self) -> bone_mapping.Body:
        """The body's labels (hips, spine, limbs, fingers...), read from the upright rig."""
        return bone_mapping.classify(self.mapping_rig(upright=True))

    def continuing_children(self) -> np.ndarray:
        return bone_axes.continuing_children(self.heads, list(self.parents))

    def aims(self, continuing=None):
        """core.bone_axes.aims of the rest pose: where each bone points in its own frame and how far, or None
        for a rig whose bones run along their Y axes."""
        return bone_axes.aims(self.heads, self.tails, list(self.parents), self.rest, continuing)


@dataclass
class Pose:
    """A rig standing in one pose (a match pose), in its own armature space: orientations (B, 4), heads
    (B, 3) and bone lengths (B,)."""
    rotations: np.ndarray
    heads: np.ndarray
    lengths: np.ndarray

    @property
    def tails(self) -> np.ndarray:
        return self.heads + self.lengths[:, None] * rotation_channels.y_axes(self.rotations)

    @property
    def points(self) -> np.ndarray:
        return np.vstack([self.heads, self.tails])

    @classmethod
    def rest(cls, rig: RigData) -> "Pose":
        return cls(rig.rest, rig.heads, rig.lengths)
