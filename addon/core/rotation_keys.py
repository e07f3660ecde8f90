"""Pose bones' rotation channels from quaternions, each bone in its own rotation mode (no bpy): what a plan
keys. The modes and the values each bone stands at come from the rig as read (core.rig_data.PoseChannels),
so that making the keys touches no Blender data and may run on a worker thread."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import native_state, rotation_channels
from .channel_carry import escape


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

    def __call__(self, q, *, placeholder: bool = False) -> tuple[list, np.ndarray]:
        """(channels, values (channels, n)) for quaternions q (n, 4k), bone j in columns 4j..4j+3, one native
        call per rotation mode; placeholder: zeros, the channels alone counting."""
        properties = [rotation_channels.channel_property(mode) for mode in self.modes]
        channels = [(f"{bone_path(name)}.{prop}", k, name) for name, (prop, size) in zip(self.names, properties)
                    for k in range(size)]
        rows = np.cumsum([0] + [size for _, size in properties])  # each bone's first row in the values
        q = np.asarray(q, dtype=np.float64)
        values = np.zeros((rows[-1], len(q)))
        if placeholder or not self.names:
            return channels, values
        per_bone = q.reshape(len(q), len(self.names), 4)
        by_mode = {}
        for j, mode in enumerate(self.modes):
            by_mode.setdefault(mode, []).append(j)
        for mode, group in by_mode.items():
            converted = rotation_channels.from_quaternions(native_state.native(), mode, per_bone[:, group],
                                                           previous=np.array([self.previous[j] for j in group]))
            for column, j in enumerate(group):
                values[rows[j]:rows[j + 1]] = converted[:, column].T
        return channels, values
