"""What a retarget reads of Blender, read once per rig (core.retarget_inputs): the source's rig and the
channels of its action over the frames retargeted (its object's own motion composed in), and the target's rig
with the clip it plays. Everything is checked here, before anything is computed, with the object named."""
from __future__ import annotations

import bpy
import numpy as np

from . import animdata, body_reads, carried_reads, object_channels, pose_channels
from ..core import bone_mapping
from ..core.retarget_inputs import RetargetInputs, SourceClip, TargetRig, bone_pairs, written_bones
from ..core.retarget_options import RetargetOptions
from ..core.rig_data import RigData

# The target's own clip is read at no more frames than this (its floor needs where its feet come down, not
# every frame of a long take).
OWN_FRAMES = 600


def check_armature(obj, role: str) -> None:
    if obj is None:
        raise ValueError(f"no {role} armature given")
    if not isinstance(obj, bpy.types.Object) or obj.type != 'ARMATURE':
        raise ValueError(f"the {role} '{getattr(obj, 'name', obj)}' is not an armature object")
    if not len(obj.data.bones):
        raise ValueError(f"the {role} armature '{obj.name}' has no bones")


def check_scale(obj, role: str) -> None:
    """A non-uniform scale (the object's or a parent's) has no single ratio to scale the motion by."""
    if isinstance(obj, bpy.types.Object):
        scale = obj.matrix_world.to_scale()
        if not np.allclose(scale, float(np.mean(scale)), rtol=1e-6):
            raise ValueError(f"the {role} '{obj.name}' has a non-uniform scale {tuple(round(v, 6) for v in scale)} "
                             f"(its own or a parent's); apply it first (Object > Apply > Scale)")


def check_editable(obj) -> None:
    """A target linked from another file without a library override cannot take keys: say so (its pose and
    action live on the object, so an overridden object whose armature stays linked takes them)."""
    library = getattr(obj, "library", None)
    if library is not None:
        raise ValueError(f"the target '{obj.name}' is linked from the library '{library.filepath}' and cannot be "
                         f"keyed here; make a library override (Object > Library Override > Make) and "
                         f"retarget onto that")


def _check_frames(action, frame_range) -> None:
    """A frame range that holds none of the action's frames is a mistake, not an extrapolation."""
    if frame_range is None:
        return
    start, end = action.frame_range
    first, last = (int(f) for f in frame_range)
    if first <= last and (last < start or first > end):
        raise ValueError(f"frame range {first}..{last} is outside the source's action '{action.name}' "
                         f"({start:g}..{end:g})")


def source_action(obj):
    """The action the source plays; a ValueError when it plays none."""
    check_armature(obj, "source")
    action = animdata.assigned_action(obj)
    if action is None:
        raise ValueError(f"the source '{obj.name}' has no action to retarget")
    return action


def _channels(obj, rig: RigData, action, frames, moving) -> tuple[np.ndarray, np.ndarray]:
    """The source's basis rotations (frames, 4B) and location channels (frames, 3B), its object's motion
    (moving, or None) composed into its top bones'."""
    basis = pose_channels.rotations(obj, action, rig.names, frames)
    locations = pose_channels.locations(obj, action, rig.names, frames)[0]
    if moving is not None:
        return moving.composed(rig, frames, basis, locations)
    return np.ascontiguousarray(basis), np.ascontiguousarray(locations)


def read_source(obj, frame_range=None, match_frame=None, whole: bool = True) -> SourceClip:
    """The source armature's rig and its action's channels over frame_range (default the action's; whole=False:
    its first frame alone), and on match_frame too when given (a match pose on a frame of the clip), not yet
    posed."""
    action = source_action(obj)
    check_scale(obj, "source")
    _check_frames(action, frame_range)
    rig = pose_channels.read_rig(obj)
    # An object whose own transform (or a parent's) is keyed carries its motion in its bones instead, from
    # its placement on the action's first frame, which is then where its armature space stands.
    moving = object_channels.ObjectMotion.of_action(obj, action)
    if moving is not None:
        rig = moving.placed(rig)
    frames = pose_channels.action_frames(action, frame_range)
    frames = frames if whole else frames[:1]
    basis, locations = _channels(obj, rig, action, frames, moving)
    match = None
    if match_frame is not None:
        match = _channels(obj, rig, action, np.array([float(match_frame)]), moving)
    return SourceClip(rig, action.name, frames, animdata.frame_rate(action), basis, locations, match,
                      moving is not None)


def _own_heads(obj, rig: RigData) -> np.ndarray | None:
    """(frames, 3B) the target's heads over the action it plays (its own clip, core.floor.own_clip_floor),
    or None when it plays none."""
    action = animdata.assigned_action(obj)
    if action is None:
        return None
    start, end = (float(f) for f in action.frame_range)
    frames = np.linspace(start, end, int(min(end - start + 1, OWN_FRAMES)))
    return pose_channels.armature_motion(obj, action, frames, rig.native, rig.names)[1]


def read_target(obj, target_rig: RigData | None = None, own_clip: bool = True) -> TargetRig:
    """The target armature as a retarget reads it: its rig (or target_rig, its bones as a rig of their own,
    control_rigs.deform_rig) where it stood before the root motion its action keys, the heads of the clip it
    plays when own_clip (and it plays one), and where its object stands."""
    check_armature(obj, "target")
    check_editable(obj)
    check_scale(obj, "target")
    rig = object_channels.at_base(obj, target_rig if target_rig is not None else pose_channels.read_rig(obj))
    own = _own_heads(obj, rig) if own_clip and rig.floor is None else None
    return TargetRig(rig, own, object_channels.ObjectBase.of(obj), object_channels.rotation_of(obj))


def read(source, target, bone_map, frame_range, o: RetargetOptions, target_rig: RigData | None = None,
         whole: bool = True) -> RetargetInputs:
    """Everything a retarget of source onto target reads (core.retarget_inputs.RetargetInputs), each rig
    once: the source's clip over frame_range (and on o.match_frame), the target as read (target_rig: its
    bones as a rig of their own), the pairs of bone_map (None: auto_map's), the bones o writes and the
    channels carried beside the bones (o.channels). whole=False: the clip's first frame alone and no carried
    channels (what the reference pose is decided from)."""
    clip = read_source(source, frame_range, o.match_frame if o.source_match == 'FRAME' else None, whole)
    read_ = read_target(target, target_rig, own_clip=o.target_floor is None)
    if source == target:
        raise ValueError(f"the source and the target are the same armature '{source.name}' (a cycle)")
    # No map given: the automatic one, with what it leaves out, from the rigs as read here.
    report = bone_mapping.auto_map_report(clip.rig.mapping_rig(), read_.rig.mapping_rig()) if bone_map is None \
        else None
    pairs = bone_pairs(report.pairs if report is not None else bone_map, clip.rig, read_.rig)
    written = written_bones(read_.rig, o)
    names = {read_.rig.names[b] for b in written} if written is not None else None
    channels = carried_reads.read(source, target, animdata.assigned_action(source), clip.frames, pairs, names, o) \
        if whole else None
    if whole and o.body != "off":  # the body stage's: each rig's skin, read once with the rest
        clip.mesh, read_.mesh = body_reads.read(source, clip.rig), body_reads.read(target, read_.rig)
    return RetargetInputs(clip, read_, pairs, written, channels, report)

