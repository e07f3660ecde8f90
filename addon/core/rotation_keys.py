"""Pose bones' rotation channels from quaternions, each bone in its own rotation mode (no bpy): what a plan
keys. The modes and the values each bone stands at come from the rig as read (core.rig_data.PoseChannels),
so that making the keys touches no Blender data and may run on a worker thread."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import native_state, rotation_channels
from .channel_carry import escape


def columns(rotations, bones):
    """The quaternion columns (n, 4k) of bones (indices, ascending) in rotations (n, 4B): a view where they
    are consecutive, else a copy."""
    bones = list(bones)
    if bones == list(range(bones[0], bones[0] + len(bones))):
        return rotations[:, 4 * bones[0]:4 * (bones[-1] + 1)]
    return rotations[:, (4 * np.array(bones, dtype=np.int64)[:, None] + np.arange(4)).ravel()]


def bone_path(name: str) -> str:
    """The data path of a pose bone, for F-curves."""
    return f'pose.bones["{escape(name)}"]'


@dataclass(frozen=True, eq=False)
class Keyer:
    """The rotation channels of some bones (names), each in its mode (modes), continuous from the values
    it stands at (previous: per bone its mode's property, 3 or 4 values)."""
    names: tuple
    modes: tuple
    previous: tuple

    def __post_init__(self):
        if not len(self.names) == len(self.modes) == len(self.previous):
            raise ValueError("a Keyer needs one mode and one current value per bone")

    @classmethod
    def of(cls, rig, bones) -> "Keyer":
        """The keyer of a rig's bones (indices), from its channels as read (RigData.channels)."""
        channels = rig.channels
        if channels is None:
            raise ValueError(f"rig '{rig.name}' was not read from an armature's pose: no rotation modes to key")
        bones = list(bones)
        return cls(tuple(rig.names[b] for b in bones), tuple(channels.modes[b] for b in bones),
                   tuple(channels.rotation_values[b] for b in bones))

    @property
    def rows(self) -> int:
        """How many channels (values' rows) the bones key."""
        return sum(rotation_channels.channel_property(mode)[1] for mode in self.modes)

    def channels(self) -> list:
        """The (data path, index, group) of every channel, bone by bone in its mode's property."""
        return [(f"{bone_path(name)}.{prop}", k, name) for name, mode in zip(self.names, self.modes)
                for prop, size in [rotation_channels.channel_property(mode)] for k in range(size)]

    def __call__(self, q, *, placeholder: bool = False, out=None) -> tuple[list, np.ndarray]:
        """(channels, values (channels, n)) for quaternions q (n, 4k), bone j in columns 4j..4j+3, one native
        call per rotation mode; placeholder: zeros, the channels alone counting. out: a (channels, n) array
        to fill and return (a block of a larger one: nothing is copied after)."""
        sizes = [rotation_channels.channel_property(mode)[1] for mode in self.modes]
        rows = np.cumsum([0] + sizes)  # each bone's first row in the values
        q = np.asarray(q, dtype=np.float64)
        values = np.empty((rows[-1], len(q))) if out is None else out
        if placeholder or not self.names:
            values[:] = 0.0
            return self.channels(), values
        per_bone = q.reshape(len(q), len(self.names), 4)
        by_mode = {}
        for j, mode in enumerate(self.modes):
            by_mode.setdefault(mode, []).append(j)
        native = native_state.native()
        for mode, group in by_mode.items():
            previous = np.array([self.previous[j] for j in group])
            destination = np.concatenate([np.arange(rows[j], rows[j + 1]) for j in group])
            if mode == 'QUATERNION':  # straight into the curves' rows, continuous, in one native pass
                block = np.ascontiguousarray(columns(q, group))
                first, last = destination[0], destination[-1]
                if last - first == len(destination) - 1:  # consecutive rows: written in place
                    native.quaternion_channels(block, previous.ravel(), out=values[first:last + 1])
                else:
                    values[destination] = native.quaternion_channels(block, previous.ravel())
                continue
            converted = rotation_channels.from_quaternions(native, mode, per_bone[:, group], previous=previous)
            values[destination] = converted.transpose(1, 2, 0).reshape(len(destination), len(q))
        return self.channels(), values
