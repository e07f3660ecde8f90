"""The channels a retarget carries beside the bones' rotations and the root's path (RetargetOptions.channels):
bone scale, custom properties and shape-key values, each by name, with a map for names that differ
(RetargetOptions.channel_map). Plain data, no Blender: the options' checks, the F-curve data paths read and
written, and the names that say what was left out and why (LeftOut).
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

# Blender EnumProperty items (id, name, description): the panel shows these, RetargetOptions.channels holds the ids.
CHANNELS = (
    ("scale", "Scale",
     "Each mapped bone's scale (squash and stretch), as the source's bone has it: a ratio of the bone's own "
     "rest length"),
    ("properties", "Properties",
     "The source's animated custom properties, on its mapped bones and on its object, onto the target's of the "
     "same name (or the channel map's)"),
    ("shape_keys", "Shape Keys",
     "The shape-key values of the source's meshes onto the target's meshes' shape keys of the same name (or the "
     "channel map's)"),
)
IDS = tuple(c[0] for c in CHANNELS)

# MotionKit's own foot-contact curves (features/contacts.PROPERTIES) are the retarget's output, not the
# source's properties to carry.
OWN_PREFIX = "motionkit_contact_"


class LeftOut(NamedTuple):
    """A source channel not written on the target: its kind ("scale", "property", "shape_key", or "bone" for
    a prop bone that moves and that no pair takes), its name as the source has it (bone["prop"], ["prop"]
    for the object's, the shape key's name, the bone's) and why."""
    kind: str
    name: str
    reason: str

    def __str__(self) -> str:
        return f"{self.name} ({self.reason})"


def check_channels(channels) -> tuple:
    """channels: a list of CHANNELS ids (empty: none carried); returns them as a tuple, else a ValueError."""
    if isinstance(channels, str) or not isinstance(channels, (tuple, list, set, frozenset)):
        raise ValueError(f"channels must be a list of {list(IDS)}, not {channels!r}")
    unknown = [c for c in channels if c not in IDS]
    if unknown:
        raise ValueError(f"unknown channel {unknown[0]!r}; expected some of {list(IDS)}")
    return tuple(channels)


def check_channel_map(channel_map) -> None:
    """None, or {source name: target name} of non-empty strings (properties' and shape keys' names)."""
    if channel_map is None:
        return
    if not isinstance(channel_map, dict):
        raise ValueError(f"channel_map must be a {{source name: target name}} dict or None, not {channel_map!r}")
    for source, target in channel_map.items():
        if not (isinstance(source, str) and source and isinstance(target, str) and target):
            raise ValueError(f"channel_map: {source!r}: {target!r} is not a pair of non-empty names")


def target_name(name: str, channel_map: dict | None) -> str:
    """The name a source property or shape key has on the target."""
    return channel_map.get(name, name) if channel_map else name


# What bpy.utils.escape_identifier (Blender's BLI_str_escape) writes for each character it escapes.
_ESCAPES = {"\\": "\\", '"': '"', "\t": "t", "\n": "n", "\r": "r", "\a": "a", "\b": "b", "\f": "f",
            "\v": "v"}
_UNESCAPES = {code: char for char, code in _ESCAPES.items()}


def escape(name: str) -> str:
    """name quoted into a data path as bpy.utils.escape_identifier quotes it."""
    return "".join("\\" + _ESCAPES[c] if c in _ESCAPES else c for c in name)


def _unescape(quoted: str) -> str:
    return re.sub(r'\\(.)', lambda found: _UNESCAPES.get(found[1], found[1]), quoted)


_QUOTED = r'"((?:[^"\\]|\\.)*)"'
_BONE_PROPERTY = re.compile(rf'^pose\.bones\[{_QUOTED}\]\[{_QUOTED}\]$')
_OBJECT_PROPERTY = re.compile(rf'^\[{_QUOTED}\]$')
_SHAPE_VALUE = re.compile(rf'^key_blocks\[{_QUOTED}\]\.value$')


def bone_property(data_path: str) -> tuple[str, str] | None:
    """(bone, property) of a pose bone's custom property's path, pose.bones["bone"]["property"], else None."""
    found = _BONE_PROPERTY.match(data_path)
    return (_unescape(found[1]), _unescape(found[2])) if found else None


def object_property(data_path: str) -> str | None:
    """The property of an ID's own custom property's path, ["property"], else None."""
    found = _OBJECT_PROPERTY.match(data_path)
    return _unescape(found[1]) if found else None


def shape_key(data_path: str) -> str | None:
    """The shape key's name of a Key's value path, key_blocks["name"].value, else None."""
    found = _SHAPE_VALUE.match(data_path)
    return _unescape(found[1]) if found else None


def bone_property_path(bone: str, prop: str) -> str:
    return f'pose.bones["{escape(bone)}"]["{escape(prop)}"]'


def object_property_path(prop: str) -> str:
    return f'["{escape(prop)}"]'


def shape_key_path(name: str) -> str:
    return f'key_blocks["{escape(name)}"].value'


def is_own(prop: str) -> bool:
    """MotionKit's own curves (foot contacts), never carried."""
    return prop.startswith(OWN_PREFIX)


def summary(left_out: list, limit: int = 6) -> str:
    """One line for a report: how many channels were not carried, and the first few with why."""
    if not left_out:
        return ""
    shown = "; ".join(str(item) for item in left_out[:limit])
    more = f"; and {len(left_out) - limit} more" if len(left_out) > limit else ""
    return f"{len(left_out)} channel{'s' if len(left_out) != 1 else ''} not carried: {shown}{more}"


@dataclass
class Carried:
    """What a plan carries beside the bones' rotations and the root's path, sampled on its frames."""
    channels: list = field(default_factory=list)  # animdata.Channel of the target object (scale, properties)
    values: np.ndarray | None = None               # (channels, frames)
    shapes: list = field(default_factory=list)    # (target Key, its channels, (channels, frames) values): the Key
    #                                                is where they are written, never read from
    left_out: list = field(default_factory=list)  # channel_carry.LeftOut, in the order found


def on_controls(carried: Carried) -> Carried:
    """carried where the target is a control rig: the object's own properties and the meshes' shape keys go
    as onto any armature (no control stands for them); a bone's scale or property is left out (the controls
    are keyed, and nothing maps a deform bone's channel onto a control yet)."""
    reason = "the target is a control rig: its controls are keyed, and none takes a deform bone's channel yet"
    on_bones = [c.data_path.startswith("pose.bones") for c in carried.channels]
    left = list(carried.left_out)
    left += [LeftOut("scale" if c.data_path.endswith(".scale") else "property", str(c), reason)
             for c, bone in zip(carried.channels, on_bones) if bone]
    kept = [row for row, bone in enumerate(on_bones) if not bone]
    return Carried(channels=[carried.channels[row] for row in kept], values=carried.values[kept],
                   shapes=carried.shapes, left_out=left)


def finite(carried: Carried) -> bool:
    arrays = [carried.values] + [values for _, _, values in carried.shapes]
    return all(np.all(np.isfinite(a)) for a in arrays if a is not None)
