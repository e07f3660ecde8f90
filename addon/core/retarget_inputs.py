"""What a retarget reads of Blender, as plain data (no bpy): the source's rig and clip, the target's rig and
what it plays, each read once (blender/retarget_reads) and then only computed on."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import bone_mapping, native_state, object_motion, retarget_parts, rotation_channels
from .retarget_options import RetargetOptions
from .rig_data import RigData
from .skinned_mesh import SkinnedMesh


@dataclass(eq=False)
class SourceClip:
    """The source's action over the frames retargeted: its rig at rest (placed where its object stands on
    the clip's first frame when the object's own transform is keyed), its channels and, once posed, the
    bones' armature-space orientations and heads."""
    rig: RigData
    action: str            # the action's name, for messages
    frames: np.ndarray
    fps: float             # its keys' frames per second
    basis: np.ndarray      # (frames, 4B) pose-basis rotations
    locations: np.ndarray  # (frames, 3B) location channels
    match: tuple | None = None  # (basis (1, 4B), locations (1, 3B)) on the match frame, when one is asked for
    moving: bool = False   # the object's own motion is composed into its top bones' channels
    rotations: np.ndarray | None = None  # (frames, 4B) armature-space orientations, once posed
    heads: np.ndarray | None = None      # (frames, 3B) armature-space heads, once posed
    mesh: SkinnedMesh | None = None      # the meshes its armature deforms, where the body stage reads them

    def posed(self) -> "SourceClip":
        """The clip with its bones posed natively (rotations, heads)."""
        with native_state.blender_frames(self.frames):
            self.rotations, self.heads = native_state.native().armature_pose(self.rig.native, self.basis,
                                                                             self.locations)
        return self


@dataclass(frozen=True, eq=False)
class ObjectRotation:
    """An object's rotation channels as they stand: its mode and that mode's values (what keys continue
    from)."""
    mode: str
    values: np.ndarray

    def keys(self, locations, rotations) -> tuple[list, np.ndarray]:
        """Channels and values (channels, n) keying the object's location and rotation (quaternions (n, 4)),
        the rotation in its own mode, continuous from where it stands."""
        prop, size = rotation_channels.channel_property(self.mode)
        values = rotation_channels.from_quaternions(native_state.native(), self.mode, rotations, self.values)
        channels = [("location", k, object_motion.GROUP) for k in range(3)] + \
            [(prop, k, object_motion.GROUP) for k in range(size)]
        return channels, np.vstack([np.asarray(locations, dtype=np.float64).T, values.T])


@dataclass(eq=False)
class TargetRig:
    """The target as read: its rig (where it stood before the root motion its action keys, channels as
    they stand), the heads of the clip it plays (frames, 3B) for its own floor, or None, and where its
    object stands (blender/object_channels.ObjectBase and its rotation's mode) for root motion onto it; the
    meshes its armature deforms, where the body stage reads them (None: none, or not read)."""
    rig: RigData
    own_heads: np.ndarray | None
    object_base: object
    object_rotation: ObjectRotation
    mesh: SkinnedMesh | None = None


@dataclass(eq=False)
class RetargetInputs:
    """Everything a retarget reads of Blender, read once (blender/retarget_reads.read): the source's clip, the
    target as read, the bone pairs, the target bones written (indices; None: all), the channels carried
    beside the bones (core.channel_carry.Carried; None when not read) and, where the pairs are the automatic
    map's, what that map leaves out (bone_mapping.MapReport: to show, never to act on)."""
    clip: SourceClip
    target: TargetRig
    pairs: list
    written: set | None
    carried: object = None
    map_report: bone_mapping.MapReport | None = None


def bone_pairs(bone_map, source: RigData, target: RigData) -> list[tuple[str, str]]:
    """The (source bone, target bone) pairs a retarget drives: bone_map's ({source: target}, or pairs; None
    for bone_mapping.auto_map's), each bone checked to be its rig's and no target bone mapped twice."""
    if bone_map is None:
        bone_map = bone_mapping.auto_map(source.mapping_rig(), target.mapping_rig())
    items = list(bone_map.items()) if isinstance(bone_map, dict) else [tuple(p) for p in bone_map]
    seen = set()
    pairs = []
    for pair in items:
        if len(pair) != 2:
            raise ValueError(f"bone map entries are (source bone, target bone) pairs, got {pair!r}")
        src, tgt = pair
        if not src or not tgt:
            continue
        if src not in source:
            raise ValueError(f"bone map: '{src}' is not a bone of the source '{source.name}'")
        if tgt not in target:
            raise ValueError(f"bone map: '{tgt}' is not a bone of the target '{target.name}'")
        if tgt in seen:
            raise ValueError(f"bone map: the target bone '{tgt}' is mapped twice")
        seen.add(tgt)
        pairs.append((src, tgt))
    if not pairs:
        raise ValueError(f"no common bones: nothing maps '{source.name}' onto '{target.name}'")
    return pairs


def written_bones(rig: RigData, o: RetargetOptions) -> set | None:
    """The target bones the plan writes (indices; None: every one), from o.bones or o.parts."""
    if o.bones is not None:
        missing = [b for b in o.bones if b not in rig]
        if missing:
            raise ValueError(f"bones: '{missing[0]}' is not a bone of the target '{rig.name}'")
        return {rig.index(b) for b in o.bones}
    if retarget_parts.check_parts(o.parts) == retarget_parts.PARTS:
        return None
    return set(retarget_parts.chosen_bones(o.parts, rig.names, rig.parents, rig.body))
