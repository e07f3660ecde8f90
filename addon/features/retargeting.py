"""Retarget motion from one armature (or a BVH file) onto another: motionkit.retarget.

The source's keyed motion is read in bulk and posed natively, the whole clip
is retargeted in one native call (see native/include/motionkit/retarget.hpp
for the mathematics), and the target gets a new action with one key per
source frame, in each bone's own rotation mode. Everything is computed and
checked before anything in the file changes, so an error leaves it as it was.
"""
from __future__ import annotations

import functools
import inspect
import os
from dataclasses import dataclass, field

import bpy
import numpy as np

from . import (contacts, control_rigs, resampling, retarget_body, retarget_channels, retarget_keys, retarget_props,
               retarget_sources)
from ..blender import animdata, object_channels, pose_channels, retarget_reads
from ..core import (bone_axes, bone_mapping, channel_carry, facing, floor_fit, native_state, reference_pose,
                    retarget_options, root_motion, rotation_channels, twist, worker_thread)
from ..core.retarget_inputs import SourceClip, TargetRig
from ..core.rig_data import Pose, RigData
from ..core.rotation_keys import Keyer, bone_path
from ..core.retarget_options import (FLOOR_FITS, ROOT_MOTION_ONTO, ROOT_MOTIONS, SOURCE_MATCHES,  # noqa: F401
                                     TARGET_MATCHES, RetargetOptions, check_frame_range, from_keywords)
from ..core.root_motion import FLOOR_ROOTS  # noqa: F401  (the panel's items, beside the other options')

CONTROLS = (
    ("auto", "Auto", "A recognised control rig's controls (legs IK, arms FK); the bones on any other rig"),
    ("fk", "FK", "Every limb of the control rig in FK"),
    ("ik", "IK", "Every limb of the control rig that has IK controls in IK"),
    ("none", "Bones", "Key the mapped bones themselves, even on a control rig"),
)
_IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


@dataclass(frozen=True)
class Retargeted:
    """What retarget_clip() made: the action keyed, the channels (channel_carry.LeftOut) it did not carry
    because the target has no bone, property or shape key to take them (empty when it carried everything),
    how each chain stood in the reference pose (reference_pose.ChainPose: kept or matched), the bone pairs
    retargeted, the target bones that kept their own posture (kept_bones() of the same call) and, where no
    map was given, what the automatic one left out (bone_mapping.MapReport), as decided on the way, so that
    nothing reads the rigs again to show or measure it."""
    action: bpy.types.Action
    channels_left_out: tuple = ()
    chains: tuple = ()
    pairs: tuple = ()
    kept_bones: tuple = ()
    map_report: bone_mapping.MapReport | None = None
    body: object = None  # core.body_clearance.Report: the arms kept out of the body, or why not


def _rig(obj, role: str) -> RigData:
    """The armature object's rig (core.rig_data), read once."""
    retarget_reads.check_armature(obj, role)
    return pose_channels.read_rig(obj)


def auto_map(source, target) -> list[tuple[str, str]]:
    """(source bone, target bone) pairs found from names and, where they say nothing, the skeletons. source,
    target: armature objects, or rigs (core.rig_data: a control rig's deform skeleton, control_rigs.deform_rig)."""
    rigs = [rig.mapping_rig() if isinstance(rig, RigData) else pose_channels.armature_mapping_rig(rig, upright=True)
            for rig in (source, target)]
    return bone_mapping.auto_map(*rigs)


def pointing(source, target, pairs) -> tuple[dict, dict]:
    """Where each bone of source and target points in its own rest frame, as the retarget matches them
    ({bone name: unit vector}, Y where a bone runs along its axis): what a measure of the result compares."""
    src, tgt = _rig(source, "source"), _rig(target, "target")
    bone_map = np.full(len(tgt), -1, dtype=np.int64)
    for a, t in pairs:
        if a in src and t in tgt:
            bone_map[tgt.index(t)] = src.index(a)
    out = []
    for rig, aims in zip((src, tgt), bone_axes.paired_aims(src, tgt, list(bone_map))):
        y = np.array([0.0, 1.0, 0.0])
        out.append({n: (y if aims is None else aims[i] / np.linalg.norm(aims[i])) for i, n in enumerate(rig.names)})
    return out[0], out[1]


@dataclass
class _PlantedFeet:
    """The feet's cleanup (contacts.staged_cleanup) started by plan(defer_solve=True): its targets prepared
    on the calling thread (numpy holds the GIL for most of that), then its native solve (without the GIL),
    its finish and the legs' channels on a worker thread, while the plan's other bones are converted and
    apply() writes their keys; complete() then gives the changed bones their values."""
    prepare: object   # () -> solve, () -> the native result (no Blender data touched)
    finish: object    # (result) -> (rotations, locations, report), the solved legs written into the plan's pose
    bones: set        # names of the bones whose channels the solve changes
    channels: object  # () -> (channels, values) of those bones from the plan's pose, reading no Blender data
    _worker: worker_thread.WorkerThread | None = None

    def start(self) -> None:
        solve = self.prepare()
        self._worker = worker_thread.WorkerThread(lambda: self._solved(solve), name="motionkit-feet").start()

    def _solved(self, solve):
        report = self.finish(solve())[2]
        return report, self.channels()

    def result(self):
        """(report, (channels, values)): from the worker thread, once it ends, or computed here if none runs."""
        if self._worker is None:
            return self._solved(self.prepare())
        return self._worker.result()

    def complete(self, plan_: "Plan") -> None:
        plan_.contact_report, (channels, values) = self.result()
        rows = {(path, index): row for row, (path, index, _) in enumerate(plan_.channels)}
        plan_.values[[rows[(path, index)] for path, index, _ in channels]] = values
        plan_.pending = None


@dataclass
class Plan:
    """Everything the retarget computes, before anything is written (the feet's IK solve aside, while
    pending: see resolve)."""
    target: bpy.types.Object
    frames: np.ndarray
    channels: list
    values: np.ndarray  # (channels, frames)
    source_name: str
    pairs: list
    still_channels: list  # bones that keep the match pose: one key on the first frame
    still_values: np.ndarray  # (still_channels, 1)
    path_scale: float = 1.0  # the root path's scale: how high the target's hips stand / the source's (_Fit.scale)
    hips: tuple = (None, None)  # (source, target) bones that carry the body's translation
    floor_roots: tuple = (None, None)  # (source, target) floor roots above the hips, or None
    floor_root: str = "still"  # what the target's floor root did (FLOOR_ROOTS, "auto" resolved)
    feet: list | None = None  # the target's contacts.Foot per side, when its feet were planted
    contacts: np.ndarray | None = None  # (frames, 4) bool in contacts.POINTS order, detected on the source
    contact_report: object = None  # contacts.Report of the cleanup
    frame_rate: float = 0.0  # the source keys' frames per second (animdata.frame_rate), kept on the new action
    pending: _PlantedFeet | None = None  # the feet's IK solve, when plan(defer_solve=True) left it to apply()
    pose: tuple = ()  # (rotations (frames, 4B), locations (frames, 3B)): every target bone's basis, final once
    #                   resolved (the feet's solve writes into them)
    chains: list = field(default_factory=list)  # reference_pose.ChainPose per chain: kept posture or matched
    kept: list = field(default_factory=list)  # the target bones that kept their posture (names; kept_bones())
    map_report: bone_mapping.MapReport | None = None  # what the automatic map left out, where it made the pairs
    body: object = None  # core.body_clearance.Report: whether the arms were kept out of the body, and where
    options: RetargetOptions = field(default_factory=RetargetOptions)  # what made it: apply() writes by its into
    written: list = field(default_factory=list)  # the target bones whose keys it writes (names)
    partial: bool = False  # only some of the target's bones are written (RetargetOptions.parts, bones)
    # The bones' scale, custom properties and shape keys carried (RetargetOptions.channels), and those the
    # target has no place for: channel_carry.LeftOut (kind, name, reason), never written.
    carried: channel_carry.Carried | None = None
    channels_left_out: list = field(default_factory=list)
    object_base: object_channels.ObjectBase | None = None  # where root motion onto the object moves it from

    @property
    def leg_ratio(self) -> float:
        """path_scale's old name (it was never the legs' ratio, but how high each rig's hips stand)."""
        return self.path_scale

    def resolve(self) -> None:
        """Runs a pending feet's IK solve here and now: values, contact_report and all are then final."""
        if self.pending is not None:
            self.pending.complete(self)


def _prepare(source, target, bone_map, frame_range, o: RetargetOptions, target_rig: RigData | None = None,
             whole: bool = True):
    """plan()'s reading and fitting: (inputs, rigs, fit, chains), the options checked first. Both rigs are
    read here once (blender/retarget_reads.read: core.retarget_inputs.RetargetInputs); everything after
    computes on what was read."""
    o.validate()
    check_frame_range(frame_range)
    inputs = retarget_reads.read(source, target, bone_map, frame_range, o, target_rig, whole)
    rigs = _read_rigs((source, inputs.clip.rig), (target, inputs.target), inputs.pairs, inputs.clip.posed(), o)
    fit = _fit(rigs, inputs.clip, o)
    return inputs, rigs, fit, _chain_poses(rigs, fit, o.chain_modes)


def _reference(source, target, bone_map, options, target_rig=None) -> tuple:
    """_prepare() with the options the reference pose depends on, the others the defaults, on the clip's first
    frame alone: the chains are decided from the two match poses (the clip's own facing counts only for a
    zero pose, against which every chain is matched anyway), so a whole clip is read once, by plan()."""
    return _prepare(source, target, bone_map, None, options.reference(), target_rig, whole=False)


def reference_chains(source, target, bone_map=None, options: RetargetOptions | None = None, **keywords) -> list:
    """How each chain of the target stands in the reference pose (reference_pose.ChainPose: kept posture or
    the source's direction, decided or the user's), as plan() would decide it, without retargeting.
    options, keywords: plan()'s; only the reference pose's (retarget_options.REFERENCE) count."""
    return _reference(source, target, bone_map, from_keywords(options, **keywords))[-1]


def plan(source, target, bone_map=None, frame_range=None, options: RetargetOptions | None = None, *,
         defer_solve: bool = False, target_rig: RigData | None = None, **keywords) -> Plan:
    """Compute the retargeted keys without touching the file (see retarget). options: a RetargetOptions,
    its fields replaced by keywords of the same names (plan(s, t, plant_feet=False) alone is as good).
    defer_solve: leave the feet's IK solve pending for apply(), which runs it beside writing the other
    bones' keys (Plan.resolve runs it at once); the contacts, feet and every other bone's values are final
    either way. target_rig: the target's bones as a rig of their own where they are not its armature's
    (a control rig's deform skeleton, control_rigs.deform_rig)."""
    o = from_keywords(options, **keywords)
    inputs, rigs, fit, chains = _prepare(source, target, bone_map, frame_range, o, target_rig)
    clip, pairs = inputs.clip, inputs.pairs
    root, ground, contact_settings = o.root, o.floor_fit == "first_frame", o.contact_settings
    written = inputs.written
    _check_onto(rigs, o, written)
    # The feet's solve moves the hips and the legs: it runs only where both are written.
    lower_body = written is None or {rigs.roots[1], *_leg_bones(rigs.tgt)} <= written
    plant_feet = _planting(o.plant_feet if lower_body else False, rigs.src, rigs.tgt)
    # The source's contacts, needed to plant feet or to put them on the floor, need only the source's pose.
    # "first_frame" keeps the motion's own heights, the whole clip moved once so that its first frame touches
    # the floor: no frame's feet are fitted apart.
    feet_fit = "off" if ground else o.floor_fit
    wants_feet = plant_feet or (feet_fit != "off" and root != "none")
    feet = (_feet(rigs.src), _feet(rigs.tgt)) if wants_feet else (None, None)
    # The source's contacts count only where both rigs have feet.
    retargeted, stances = _retarget_clip(rigs, clip, fit, (root, chains), None if None in feet else feet[0],
                                         contact_settings)
    rotations, root_locations = retargeted.rotations, retargeted.root_locations
    if ground and rigs.roots[1] >= 0:
        root_locations += _first_frame_lift(rigs, fit, rotations, root_locations)
    found = stances.contacts if stances is not None else None  # the source's stances (contacts.Stances)
    twist.share_twist(rigs.tgt, rigs.tgt.body, rotations, {b for _, b in rigs.pairs_idx})
    locations, located, mode = _place_roots(rigs, clip, fit, rotations, root_locations, o)
    feet_lift = None
    if found is not None and root != "none" and feet_fit != "off" and (written is None or rigs.roots[1] in written):
        # The hips come down where a leg cannot reach; "legs" also has the legs' solve put the feet down.
        feet_lift = _stand_on_floor(rigs, clip, fit, rotations, locations, found, root)
        feet_lift = feet_lift if feet_fit == "legs" else None
    # The arms out of the body, on the upper body as it is final (the feet's solve after it moves only the hips
    # and the legs, on a thread of its own when deferred: it must not run beside this).
    body_report = retarget_body.keep_out(rigs, clip, fit, rotations, locations, o, written)
    # The legs' solve plants the feet, and puts right what the hips' lift leaves (floor_fit.feet_left_off).
    legs_solve = found is not None and lower_body and (plant_feet or (
        feet_lift is not None and floor_fit.feet_left_off(feet_lift, fit.target_scale * fit.legs[1])))
    planted = _plant_feet(rigs.tgt, feet[1], stances if plant_feet else _unplanted(stances), clip.frames, rotations,
                          locations, rigs.roots[1], contact_settings, clip.fps, beside=defer_solve, heights=feet_lift,
                          hips_move=plant_feet) if legs_solve else None
    # Root motion on the object is read from the hips' final path: after the feet's solve.
    onto_object = o.root_motion_onto == "object"
    plan_ = _plan_keys(rigs, clip, pairs, fit.scale, (rotations, locations), located, mode, planted, plant_feet,
                       defer_solve and not onto_object, written)
    if onto_object:
        _onto_object(plan_, rigs, o.root_smoothing * clip.fps, fit.up)
    if o.two_hands:
        retarget_props.two_hands_hold(rigs, clip, fit, plan_, written)
    if o.prop_space != "bone":
        retarget_props.move_props(rigs, clip, fit, plan_, written, o.prop_space)
    retarget_props.follow_bones(rigs, plan_, written)
    plan_.chains, plan_.options = chains, o
    plan_.kept = [rigs.tgt.names[b] for b in retargeted.kept_posture]
    plan_.map_report = inputs.map_report
    plan_.body = body_report
    plan_.written = [rigs.tgt.names[b] for b in sorted(written)] if written is not None else list(rigs.tgt.names)
    plan_.partial = written is not None
    plan_.carried = inputs.carried
    if target_rig is not None:  # a control rig's controls are keyed (control_rigs.apply), not its bones
        plan_.carried = channel_carry.on_controls(plan_.carried)
    plan_.channels_left_out = plan_.carried.left_out + retarget_props.props_left_out(rigs, clip)
    if not (np.all(np.isfinite(plan_.values)) and np.all(np.isfinite(plan_.still_values))
            and channel_carry.finite(plan_.carried)):
        raise ValueError("the retargeted motion is not finite; check the rigs' rest poses")
    return plan_  # a pending feet's solve is checked when it completes (contacts.cleanup and write_keys)


def _check_onto(rigs: _Rigs, o: RetargetOptions, written) -> None:
    """root_motion_onto's needs, before the clip is retargeted: a root bone above the hips for "root", and
    the bones that carry the motion among those written."""
    tgt, hips, floor_bone = rigs.tgt, rigs.roots[1], rigs.floor_bones[1]
    if o.root_motion_onto == "root" and floor_bone is None:
        raise ValueError(f"root_motion_onto='root': the target '{tgt.name}' has no root bone above its hips "
                         f"'{tgt.names[hips]}' to carry the motion; choose 'hips' or 'object'")
    carriers = {"root": (hips, floor_bone), "object": (hips,)}.get(o.root_motion_onto, ())
    missing = [b for b in carriers if written is not None and b not in written]
    if missing:
        raise ValueError(f"root_motion_onto={o.root_motion_onto!r} moves the target's '{tgt.names[missing[0]]}', "
                         f"which the parts or bones chosen leave out; retarget it too, or choose 'auto'")


def _onto_object(plan_: Plan, rigs: _Rigs, sigma_frames: float, up) -> None:
    """Root motion on the target object (root_motion_onto="object"): the hips' ground path and heading keyed
    on the object, and the hips' keys re-expressed so that the world pose stays (root_motion.onto_object)."""
    plan_.resolve()
    rotations, locations = plan_.pose
    hips = rigs.roots[1]
    name = rigs.tgt.names[hips]
    track = root_motion.onto_object(rigs.tgt, rigs.target_pose, rotations, locations, hips, sigma_frames, up)
    channels, values = Keyer.of(rigs.tgt, [hips])(rotations[:, 4 * hips:4 * hips + 4])
    channels += [(f"{bone_path(name)}.location", k, name) for k in range(3)]
    values = np.vstack([values, locations[:, 3 * hips:3 * hips + 3].T])
    rows = {(path, index): row for row, (path, index, _) in enumerate(plan_.channels)}
    plan_.values[[rows[(path, index)] for path, index, _ in channels]] = values
    base = rigs.target_read.object_base
    keys = rigs.target_read.object_rotation.keys(*base.keys(track))
    plan_.object_base = base
    plan_.channels = plan_.channels + keys[0]
    plan_.values = np.vstack([plan_.values, keys[1]])


def _leg_bones(rig: RigData) -> set:
    return {b for leg in floor_fit.legs(rig, rig.body) for b in (leg.thigh, leg.shin, leg.foot) if b >= 0}


def _first_frame_lift(rigs: _Rigs, fit: _Fit, rotations, root_locations) -> np.ndarray:
    """core.floor_fit.first_frame_lift for the native retarget's hips channel: the change to it (frames, 3)."""
    hips = rigs.roots[1]
    locations = np.zeros((len(rotations), 3 * len(rigs.tgt)))
    locations[:, 3 * hips:3 * hips + 3] = root_locations
    return floor_fit.first_frame_lift(rigs.tgt, fit.up, fit.floors[1], rotations, locations, hips)


def _stand_on_floor(rigs, clip, fit, rotations, locations, found, root) -> np.ndarray:
    """core.floor_fit.stand_on_floor for this fit: the hips lifted where a leg cannot reach its floor (in
    place), and how far each foot is still to rise, in world units."""
    height_scale = fit.unit_scale if root == "offset" else fit.scale
    lifts = floor_fit.stand_on_floor(
        floor_fit.Ground(rigs.src, rigs.src.body, fit.source_up, fit.floors[0] + fit.joints[0], fit.legs[0]),
        (clip.rotations, clip.heads),
        floor_fit.Ground(rigs.tgt, rigs.tgt.body, fit.up, fit.floors[1] + fit.joints[1], fit.legs[1]),
        rotations, locations, rigs.roots[1], found, height_scale, clip.fps)
    return fit.target_scale * lifts


@dataclass
class _Rigs:
    """The two rigs as the retarget pairs them: their objects (the target's, to write to), rig data (with
    their bodies' labels), match poses and roots; the target as read (core.retarget_inputs.TargetRig)."""
    source: bpy.types.Object
    target: bpy.types.Object
    src: RigData
    tgt: RigData
    target_read: TargetRig
    source_pose: Pose
    target_pose: Pose
    target_basis: np.ndarray      # (B, 4) the target's match pose's basis rotations
    target_locations: np.ndarray  # (B, 3) and location channels
    bone_map: np.ndarray          # per target bone its source bone, -1 for none
    pairs_idx: list               # (source bone, target bone) by index, a floor root left out
    roots: tuple                  # (source, target) hips
    floor_bones: tuple            # (source, target) floor roots above the hips, or None


def _match_poses(src: RigData, tgt: RigData, clip: SourceClip, o: RetargetOptions) -> tuple:
    """(source match pose, target match pose, its basis rotations, its location channels): the source at rest
    or on a frame of its clip, the target at rest or as it stands."""
    native = native_state.native()
    if o.source_match == 'FRAME':  # match_frame given: RetargetOptions.validate; read with the clip
        with native_state.blender_frames(np.array([float(o.match_frame)])):
            match_rot, match_heads = native.armature_pose(src.native, *clip.match)
        source_pose = Pose(match_rot.reshape(-1, 4), match_heads.reshape(-1, 3), src.lengths)
    else:
        source_pose = Pose.rest(src)
    if o.target_match == 'CURRENT':
        target_basis, target_locations = tgt.channels.basis, tgt.channels.locations
    else:
        target_basis = np.tile(_IDENTITY, (len(tgt), 1))
        target_locations = np.zeros((len(tgt), 3))
    match_rotations, match_heads = native.armature_pose(
        tgt.native, np.ascontiguousarray(target_basis.reshape(1, -1)),
        np.ascontiguousarray(target_locations.reshape(1, -1)))
    return source_pose, Pose(match_rotations.reshape(-1, 4), match_heads.reshape(-1, 3), tgt.lengths), \
        target_basis, target_locations


def _read_rigs(source, target, pairs, clip: SourceClip, o: RetargetOptions) -> _Rigs:
    """source: (object, RigData), target: (object, TargetRig)."""
    src, tgt = source[1], target[1].rig
    source_pose, target_pose, target_basis, target_locations = _match_poses(src, tgt, clip, o)
    bone_map_idx = np.full(len(tgt), -1, dtype=np.int64)
    pairs_idx = [(src.index(a), tgt.index(b)) for a, b in pairs]
    for a, b in pairs_idx:
        bone_map_idx[b] = a
    # The hips are the body's root for proportions and height; a game rig's floor root above them is
    # carried apart (floor_root=), never mapped like a body bone.
    target_root, target_floor_bone = root_motion.body_roots(tgt, tgt.body, {b for _, b in pairs_idx})
    if target_root is None:
        raise ValueError(f"the bone map drives only the floor root of '{tgt.name}'; map its hips too")
    source_root = int(bone_map_idx[target_root])
    source_floor_bone = src.top(source_root)
    source_floor_bone = source_floor_bone if source_floor_bone != source_root else None
    if src.body.root is not None and src.names[source_root] == src.body.root:
        raise ValueError(f"the bone map pairs the source's floor root '{src.body.root}' with the target's hips "
                         f"'{tgt.names[target_root]}'; map the source's hips '{src.body.hips}' to it instead")
    if target_floor_bone is not None:
        bone_map_idx[target_floor_bone] = -1
    pairs_idx = [(a, b) for a, b in pairs_idx if b != target_floor_bone]
    return _Rigs(source[0], target[0], src, tgt, target[1], source_pose, target_pose, target_basis, target_locations,
                 bone_map_idx, pairs_idx, (source_root, target_root), (source_floor_bone, target_floor_bone))


@dataclass
class _Fit:
    """How the source's motion is laid on the target: the turn between their armature spaces, Blender's up
    in each, each rig's floor and leg length (its own units), and the scales between them."""
    space: np.ndarray
    up: np.ndarray
    source_up: np.ndarray
    floors: tuple        # (source, target) heights along up
    clearances: tuple    # (source, target) how high each one's rest soles (its feet's lowest points) ride above it
    joints: tuple        # (source, target) how high the foot joints a standing foot is put down by ride above it
    legs: tuple          # (source, target) leg lengths (floor_fit.leg_length), each in its own armature's units
    scale: float         # the root path's: target standing height / source's (floor_fit.standing_height)
    unit_scale: float    # source object scale / target object scale
    target_scale: float  # the target object's scale
    scale_horizontal: float = 1.0  # the travel across the floor: times this on top of scale (the option's)


def _fit(rigs: _Rigs, clip: SourceClip, o: RetargetOptions) -> _Fit:
    src, tgt = rigs.src, rigs.tgt
    source_root, target_root = rigs.roots
    placed = facing.placement(facing.Standing(src, src.body, rigs.source_pose, clip.rotations, clip.heads),
                              facing.Standing(tgt, tgt.body, rigs.target_pose), rigs.pairs_idx, rigs.roots,
                              o.align_facing)
    source_floor, source_clearance = floor_fit.floor_height(src, src.body, placed.source_up, o.source_floor,
                                                            clip.heads)
    own = rigs.target_read.own_heads if o.target_floor is None else None
    target_floor, target_clearance = floor_fit.floor_height(tgt, tgt.body, placed.up, o.target_floor, own,
                                                            own=True)
    source_height = floor_fit.leg_length(src, src.body, rigs.source_pose, placed.source_up, source_root, clip.heads,
                                         floor=source_floor)
    # The target's own action (whatever is assigned now) never sets its proportions: a zero pose's feet
    # take a tenth of thigh + shin there (root_motion.leg_length).
    target_height = floor_fit.leg_length(tgt, tgt.body, rigs.target_pose, placed.up, target_root)
    if not (source_height > 1e-9 and target_height > 1e-9):
        raise ValueError("the root stands at the lowest point of a rig: no leg length to scale the motion by")
    # The root's path scales with how high each rig's hips stand (Mixamo's own retargets do), the legs' own
    # measures (heights) with their lengths.
    standing = (floor_fit.standing_height(src, src.body, rigs.source_pose, placed.source_up, source_root,
                                          source_height, source_clearance),
                floor_fit.standing_height(tgt, tgt.body, rigs.target_pose, placed.up, target_root, target_height,
                                          target_clearance))
    joints = (floor_fit.joint_clearance(src, src.body, placed.source_up, source_floor),
              floor_fit.joint_clearance(tgt, tgt.body, placed.up, target_floor, own, own=True))
    return _Fit(placed.space, placed.up, placed.source_up, (source_floor, target_floor),
                (source_clearance, target_clearance), joints, (source_height, target_height), standing[1] / standing[0],
                src.scale / tgt.scale, tgt.scale, o.scale_horizontal)


def _chain_poses(rigs: _Rigs, fit: _Fit, chain_modes) -> list:
    """Each chain's reference_pose.ChainPose: the target keeps its own posture or takes the source's
    direction, from the two match poses (the source's carried into the target's armature space)."""
    source_heads = rotation_channels.rotate(fit.space, rigs.source_pose.heads)
    bones = [[a for a, _ in rigs.pairs_idx], [b for _, b in rigs.pairs_idx]]
    source = reference_pose.Limbs(rigs.src.body, dict(zip(rigs.src.names, source_heads)),
                                  facing.faces_nowhere(rigs.src, rigs.source_pose, bones[0]))
    target = reference_pose.Limbs(rigs.tgt.body, dict(zip(rigs.tgt.names, rigs.target_pose.heads)),
                                  facing.faces_nowhere(rigs.tgt, rigs.target_pose, bones[1]))
    return reference_pose.decide(source, target, chain_modes)


def _posture_bones(rigs: _Rigs, chains, by_user: bool) -> list[int]:
    """The target bones on the chains the user (by_user) or Auto kept (reference_pose.kept_bones): Auto's
    for the native retarget to keep where their parents carry them within 45 degrees of the source's, the
    user's whatever the angle."""
    return reference_pose.kept_bones(rigs.tgt.names, list(rigs.tgt.parents), rigs.tgt.body, chains, by_user)


def _posture_lists(rigs: _Rigs, chains) -> tuple[list[int], list[int]]:
    """(posture_bones, posture_always) for the native retarget: Auto's kept bones, kept where their parents
    carry them within 45 degrees of the source's, and the user's whatever the angle. A kept bone without a
    direction of its own on either rig (bone_axes.without_direction) is kept whatever the angle too: an
    angle to an axis the importer chose says nothing of a pose, and turning the bone would turn all it
    carries (a spine under a `*_split` joint at its head)."""
    src, tgt = rigs.src, rigs.tgt
    aimless = bone_axes.without_direction(tgt.heads, list(tgt.parents))
    source_aimless = bone_axes.without_direction(src.heads, list(src.parents))
    aimless |= (rigs.bone_map >= 0) & source_aimless[np.maximum(rigs.bone_map, 0)]
    auto, user = _posture_bones(rigs, chains, False), _posture_bones(rigs, chains, True)
    return [b for b in auto if not aimless[b]], sorted(user + [b for b in auto if aimless[b]])


def kept_bones(source, target, bone_map=None, options: RetargetOptions | None = None, **keywords) -> list[str]:
    """The target bones that keep their own posture in the reference pose (the others point where the
    source's do), as plan() decides them: the native retarget's kept_posture on the clip's first frame.
    options, keywords: plan()'s; only the reference pose's (retarget_options.REFERENCE) count."""
    inputs, rigs, fit, chains = _reference(source, target, bone_map, from_keywords(options, **keywords))
    return [rigs.tgt.names[b] for b in _native_retarget(rigs, inputs.clip, fit, "none", chains).kept_posture]


def _native_options(native, rigs: _Rigs, fit: _Fit, root, chains):
    """The native retarget's options (_native.RetargetOptions) for this fit."""
    options = native.RetargetOptions()
    options.root_motion, options.scale, options.unit_scale = root, fit.scale, fit.unit_scale
    options.vertical_offset = fit.legs[1] - fit.unit_scale * fit.legs[0]
    options.scale_horizontal = fit.scale_horizontal
    options.space, options.up = fit.space, fit.up
    options.source_floor, options.target_floor = fit.floors
    options.posture_bones, options.posture_always = _posture_lists(rigs, chains)
    options.helper_bones = bone_axes.helpers_between(rigs.tgt, [int(v) >= 0 for v in rigs.bone_map])
    return options


def _native_retarget(rigs: _Rigs, clip: SourceClip, fit: _Fit, root, chains):
    """The native retarget of the clip (a _native.RetargetResult); it releases the GIL."""
    native = native_state.native()
    src, tgt = rigs.src, rigs.tgt
    source_root, target_root = rigs.roots
    source_aims, target_aims = bone_axes.paired_aims(src, tgt, [int(v) for v in rigs.bone_map])
    with native_state.blender_frames(clip.frames):
        return native.retarget(
            src.native, tgt.native, clip.rotations,
            np.ascontiguousarray(clip.heads[:, 3 * source_root:3 * source_root + 3]),
            [int(v) for v in rigs.bone_map], source_match=np.ascontiguousarray(rigs.source_pose.rotations),
            source_match_root=rigs.source_pose.heads[source_root],
            target_match_basis=np.ascontiguousarray(rigs.target_basis),
            target_match_location=rigs.target_locations[target_root], source_root=source_root,
            target_root=target_root, options=_native_options(native, rigs, fit, root, chains),
            source_aims=source_aims, target_aims=target_aims)


def _retarget_clip(rigs: _Rigs, clip: SourceClip, fit: _Fit, how, source_feet, contact_settings):
    """(the native retarget's RetargetResult, the source's contacts or None): the native retarget of the whole clip,
    on a worker thread (it releases the GIL) while the source's contacts are found here. how: (root motion,
    the chains' reference_pose.ChainPose)."""
    root, chains = how
    src = rigs.src

    def source_contacts():
        return None if source_feet is None else contacts.find_contacts(
            src, clip.basis, clip.locations, source_feet, contact_settings, fps=clip.fps,
            posed=(clip.rotations, clip.heads), floor=src.armature_height_to_world(fit.floors[0]), holds=True)

    result, found = worker_thread.beside(lambda: _native_retarget(rigs, clip, fit, root, chains),
                                         source_contacts)
    return result, found


def _place_roots(rigs: _Rigs, clip: SourceClip, fit: _Fit, rotations, root_locations, o: RetargetOptions):
    """The target's location channels (frames, 3B): the hips' from the retarget, and a floor root's motion
    (o.floor_root: FLOOR_ROOTS); returns them, the located bones and what the floor root did."""
    source_floor_bone, target_floor_bone = rigs.floor_bones
    target_root = rigs.roots[1]
    locations = np.zeros((rotations.shape[0], 3 * len(rigs.tgt)))
    locations[:, 3 * target_root:3 * target_root + 3] = root_locations
    located = [target_root]
    mode = o.floor_root if o.floor_root != "auto" else ("copy" if source_floor_bone is not None else "still")
    mode = {"root": "extract", "hips": "still", "object": "still"}.get(o.root_motion_onto, mode)
    # Root motion on the root bone (an engine's): on the target's floor, wherever the bone stands at rest.
    height = fit.floors[1] if o.root_motion_onto == "root" else None
    if target_floor_bone is not None and mode in ("copy", "extract"):
        if mode == "copy" and source_floor_bone is None:
            mode = "still"  # nothing to copy: the hips carry the motion
        else:
            b = source_floor_bone
            source_motion = (clip.rotations[:, 4 * b:4 * b + 4], clip.heads[:, 3 * b:3 * b + 3],
                             rigs.source_pose.rotations[b], rigs.source_pose.heads[b]) if b is not None else None
            root_motion.move_floor_root(rigs.tgt, rigs.target_pose, rotations, locations, target_floor_bone,
                                        target_root, root_motion.FloorRootMotion(
                                            mode, source_motion, fit.space, fit.scale, o.root,
                                            o.root_smoothing * clip.fps, height, fit.up, fit.scale_horizontal))
            located.append(target_floor_bone)
    return locations, located, mode


def _plan_keys(rigs: _Rigs, clip: SourceClip, pairs, scale, pose, located, mode, planted, plant_feet,
               defer_solve, written=None) -> Plan:
    """The Plan of the target's keys (of the written bones: indices, None for all); with planted feet, their
    solve pending (started beside, defer_solve) or resolved here. pose: the target's (rotations,
    locations), which the feet's solve writes into."""
    tgt = rigs.tgt
    source_root, target_root = rigs.roots
    rotations, locations = pose
    keyed, pending = set(), None
    if planted is not None:
        keyed = {tgt.index(b) for f in planted[2] for b in (f.thigh, f.shin, f.foot)} | {target_root}
        keyer = Keyer.of(tgt, sorted(keyed))
        pending = _PlantedFeet(planted[0], planted[1], {tgt.names[b] for b in keyed}, lambda: retarget_keys.target_channels(
            rigs, rotations, located, locations, keyed, keyed, keyer=keyer)[0])
        if defer_solve:
            pending.start()  # beside the rest of the plan and apply()'s writing
    # Bones the feet's solve may change get a key per frame even where the plain retarget keeps them still.
    moving, still = retarget_keys.target_channels(rigs, rotations, located, locations, only=written, keyed=keyed,
                                     placeholders=True)
    floor_bones = tuple(rig.names[b] if b is not None else None for rig, b in zip((rigs.src, tgt), rigs.floor_bones))
    plan_ = Plan(rigs.target, clip.frames, *moving, rigs.src.name, pairs, *still, path_scale=scale,
                 hips=(rigs.src.names[source_root], tgt.names[target_root]), floor_roots=floor_bones,
                 floor_root=mode, feet=planted[2] if planted and plant_feet else None,
                 contacts=planted[3] if planted and plant_feet else None, frame_rate=clip.fps)
    plan_.pending = pending
    plan_.pose = (rotations, locations)
    if not defer_solve:
        plan_.resolve()
    return plan_


def _planting(plant_feet, source: RigData, target: RigData) -> bool:
    """Whether to plant feet: plant_feet None plants where both rigs have two labelled legs; True requires
    them (a ValueError names the rig and what it lacks); False never."""
    if plant_feet is not None and not plant_feet:
        return False
    for rig, role in ((source, "source"), (target, "target")):
        try:
            contacts.feet_of(rig.body, rig.name)
        except ValueError as error:
            if plant_feet:
                raise ValueError(f"plant_feet: the {role} has no feet to plant ({error}); retarget with "
                                 f"plant_feet=False, or map its legs") from None
            return False
    return True


def _feet(rig: RigData) -> list | None:
    """Both legs' contacts.Foot from the labels, or None when a leg is not labelled (no feet to plant)."""
    try:
        return contacts.feet_of(rig.body, rig.name)
    except ValueError:
        return None


def _unplanted(stances):
    """The source's stances with no contact to keep (not planting: the legs' solve only puts the feet on the
    floor)."""
    none = np.zeros_like(stances.contacts)
    return contacts.Stances(none, none)


def _plant_feet(tgt: RigData, tgt_feet, found, frames, rotations, locations, target_root, settings, fps,
                beside: bool = False, heights=None, hips_move: bool = True):
    """The source's contacts (found: contacts.Stances, those held still read on the source's motion, a pivot
    being the source's whatever the target's feet) to be held by the target's feet (contacts.staged_cleanup,
    which writes the solved legs into rotations and locations): (prepare, finish, target feet, contacts).
    heights: (frames, legs) world lifts of the standing feet (the floor's), or None to hold the plants' own
    heights; hips_move: the hips' translation is solved for too (planting), else only the legs move."""
    # Beside the rest of the retarget (beside=True), which keeps one core busy, the solve takes the others.
    prepare, finish = contacts.staged_cleanup(tgt, frames, rotations, locations, tgt_feet, found.contacts, settings,
                                              hips=tgt.names[target_root], fps=fps, in_place=True,
                                              threads=max(1, (os.cpu_count() or 1) - 1) if beside else 0,
                                              follow_heights=heights, hips_move=hips_move, holds=found.holds)
    return prepare, finish, tgt_feet, found.contacts


def apply(plan_: Plan, *, action_name: str | None = None, overwrite: bool = False) -> bpy.types.Action:
    """Write a plan's keys where its options say (RetargetOptions.into, retarget_parts.INTO): a new action
    on the target (for a part of the body, a copy of its own action with the written bones' curves
    replaced, so that the others keep every key); its own action over the clip's frames ("current": each
    written curve's keys before and after kept); or a new action on an NLA track above its own ("nla").
    overwrite: the target's own action, the written bones' curves replaced whole. Returns the action keyed.
    The carried shape keys go into the target meshes' Keys' actions the same way (retarget_channels)."""
    action = _apply_armature(plan_, action_name, overwrite)
    apply_shapes(plan_, action_name, overwrite)
    return action


def apply_shapes(plan_: Plan, action_name: str | None, overwrite: bool) -> None:
    """The carried shape keys into the target meshes' Keys' actions, as apply() put the armature's keys (a
    control rig's too: its meshes' shapes are no control's)."""
    carried = plan_.carried
    if carried is not None and carried.shapes:
        retarget_channels.write_shapes(carried, plan_.frames, plan_.options,
                                       action_name or f"{plan_.source_name} -> {plan_.target.name}", overwrite,
                                       plan_.partial)


def _apply_armature(plan_: Plan, action_name, overwrite) -> bpy.types.Action:
    """apply()'s keys on the armature object: the bones' and the carried channels of the object."""
    target, o = plan_.target, plan_.options
    previous = animdata.assigned_action(target)
    if overwrite and previous is not None:
        plan_.resolve()  # everything computed before the user's own action changes
        _write(target, previous, plan_)
        return previous
    name = action_name or f"{plan_.source_name} -> {target.name}"
    if o.into == "current":
        if previous is None:
            raise ValueError(f"into='current': the target '{target.name}' has no action to retarget into")
        plan_.resolve()
        _write(target, previous, plan_, merge=True)
        return previous
    if o.into == "nla":
        action = animdata.new_action(name)
        try:
            _write(target, action, plan_)
            animdata.push_track(target, action, plan_.frames[0], o.blend, o.influence)
        except BaseException:
            bpy.data.actions.remove(action)
            raise
        return action
    if plan_.partial and previous is not None:
        action = animdata.copy_action(previous, name)
        animdata.remove_curves(action, target, [pose_channels.bone_path(n) for n in plan_.written])
    else:
        action = animdata.new_action(name)
    return animdata.install_action(target, action, lambda keyed: _write(target, keyed, plan_))


def new_action_for(plan_: Plan, name: str, base: bpy.types.Action | None) -> bpy.types.Action:
    """A new action holding the plan's keys, not assigned (apply()'s "new", for a preview): for a part of the
    body a copy of base (the target's own action) with the written bones' curves replaced."""
    if plan_.partial and base is not None:
        action = animdata.copy_action(base, name)
        animdata.remove_curves(action, plan_.target, [pose_channels.bone_path(n) for n in plan_.written])
    else:
        action = animdata.new_action(name)
    try:
        _write(plan_.target, action, plan_)
    except BaseException:
        bpy.data.actions.remove(action)
        raise
    return action


def _write(target, action, plan_: Plan, merge: bool = False) -> None:
    """The plan's keys into action; merge: over the clip's frames only (animdata.merge_keys)."""
    write = animdata.merge_keys if merge else animdata.write_keys
    pending = plan_.pending
    if pending is not None and plan_.channels:
        # The solve releases the GIL: the other bones' keys are written meanwhile (a failure of either
        # leaves the new action to apply(), which removes it).
        changed = [bone in pending.bones for _, _, bone in plan_.channels]
        later = [row for row, change in enumerate(changed) if change]
        now = [row for row, change in enumerate(changed) if not change]
        write(target, action, [plan_.channels[r] for r in now], plan_.frames, plan_.values[now])
        _write_unsolved(target, action, plan_, merge)
        pending.complete(plan_)  # waits for the solve, if it still runs
        write(target, action, [plan_.channels[r] for r in later], plan_.frames, plan_.values[later])
    else:
        if plan_.channels:
            plan_.resolve()
            write(target, action, plan_.channels, plan_.frames, plan_.values)
        _write_unsolved(target, action, plan_, merge)
    carried = plan_.carried
    if carried is not None and carried.channels:
        write(target, action, carried.channels, plan_.frames, carried.values)
    if not merge:  # the target's own action keeps its own rate
        animdata.record_frame_rate(action, plan_.frame_rate)
    if plan_.object_base is not None:
        plan_.object_base.record(action)


def _write_unsolved(target, action, plan_: Plan, merge: bool = False) -> None:
    """The keys that do not wait for the feet's solve: the bones that keep the match pose, and the contacts.
    merge: the match pose held over the clip's frames (a key at each end) within the target's own keys."""
    if plan_.still_channels and merge:
        ends = np.unique(plan_.frames[[0, -1]])
        animdata.merge_keys(target, action, plan_.still_channels, ends,
                            np.repeat(plan_.still_values, len(ends), axis=1))
    elif plan_.still_channels:
        animdata.write_keys(target, action, plan_.still_channels, plan_.frames[:1], plan_.still_values)
    if plan_.contacts is not None:  # where the animator sees and edits them; "Fix foot sliding" reads them
        contacts.write_contacts(target, action, plan_.feet, plan_.frames, plan_.contacts)


def retarget_clip(source, target, bone_map=None, frame_range=None, options: RetargetOptions | None = None, *,
                  action_name: str | None = None, overwrite: bool = False, bvh_scale: float | str = "auto",
                  imported_source: str | None = None, bvh_source: str | None = None, controls: str = "auto",
                  limbs: dict | None = None, control_map=None, keys: str = "every", reduce: bool = False,
                  progress=None, **keywords) -> Retargeted:
    """Retarget the source's action onto the target; returns a Retargeted: the target's new action, and the
    channels left out.

    source: an armature object with an action, or a file path: BVH (imported
    with motionkit.bvh.load), FBX, glTF or GLB (Blender's own importers; the
    file's animated armature is the source). For a BVH file, bvh_scale sizes
    the imported armature: "auto" stands it as tall as the target (a
    centimetre file would otherwise stand 100 times too tall), or a number
    multiplies the file's distances; the retarget itself does not depend on it
    (the motion is scaled by the legs' ratio). imported_source: "keep",
    "hide" or "remove" what was imported afterwards (retarget_sources.IMPORTED_SOURCES;
    bvh_source is its older name).
    controls: on a control rig (Rigify's, recognised from its bones, or one
    control_map describes: a motionkit-control-rig JSON file, a parsed map or a
    preset id) "auto" keys its controls with legs in IK and arms in FK, "fk"
    or "ik" puts every limb in that mode, "none" keys the mapped bones
    themselves; limbs {"leg.L": "fk", ...} overrides per limb; bone_map then
    pairs source bones with the rig's deform bones (see control_rigs). keys:
    "every" frame or only where the "source" has keys; reduce: afterwards,
    the fewest keys that stay within resampling.reduce_keys' tolerances.
    bone_map: (source bone, target bone) pairs or a {source: target} dict;
    None maps automatically (motionkit.bone_mapping). frame_range: inclusive
    source frames (default: the action's), one key per frame on the same
    frames.
    options: a RetargetOptions (core/retarget_options.py says what each field
    does), its fields replaced by keywords of the same names: root (ROOT_MOTIONS)
    and scale_horizontal (the travel across the floor times this besides),
    source_match, match_frame and target_match (the poses in which the two rigs
    stand alike), chain_modes (per chain, keep the target's posture or take the
    source's direction; by default the trunk keeps, a limb whose rest line lies
    farther than 15 degrees from the source's matches, the others keep, and
    fingers match: Plan.chains), align_facing, source_floor and
    target_floor, floor_fit (FLOOR_FITS), floor_root and root_smoothing
    (FLOOR_ROOTS), plant_feet and contact_settings (planted feet are stored on
    the new action as 0/1 contact curves), channels and channel_map (bone
    scale, custom properties and shape keys carried by name; what the target
    has no place for is left out: Retargeted.channels_left_out), body and
    body_strength (BODY_MODES: where the target deforms a mesh, a forearm or
    hand that would go into its own body swung out; Retargeted.body says what
    was done, docs/body.md). The hips are the body's root on both
    sides and the translation is scaled by the ratio of how high each rig's
    hips stand (core.floor_fit.standing_height). The new action is assigned to the target (its previous
    action keeps a fake user rather than being lost); with overwrite the keys
    replace the target's own action's curves instead. A ValueError leaves the
    file as it was (a BVH source is removed again).
    """
    imported_source = retarget_sources.imported_source_option(imported_source, bvh_source)
    if target is not None and getattr(target, "type", None) == 'ARMATURE':
        retarget_reads.check_editable(target)
    options = from_keywords(options, **keywords)
    # Before a file is imported for nothing: every option's value, and the target's scale.
    _check_values(options, frame_range, keys, controls, reduce)
    retarget_reads.check_scale(target, "target")
    call = (bone_map, frame_range, options)
    imported = retarget_sources.import_source(source, target, bvh_scale) if isinstance(source, (str, os.PathLike)) else None
    try:
        made = _retarget_controls(imported.obj if imported else source, target, controls, limbs, control_map, keys,
                                  reduce, action_name, overwrite, progress, call)
        if made is None:
            made = _retarget_bones(imported.obj if imported else source, target, keys, reduce, action_name,
                                   overwrite, call)
    except BaseException:
        if imported is not None:
            imported.remove()
        raise
    if imported is not None:
        imported.finish(imported_source)
    return made


@functools.wraps(retarget_clip)
def retarget(*args, **keywords) -> bpy.types.Action:
    return retarget_clip(*args, **keywords).action


retarget.__doc__ = """retarget_clip()'s action alone: the target's new action (the same arguments)."""


def _check_values(options: RetargetOptions, frame_range, keys, controls, reduce) -> None:
    """retarget()'s option values: the RetargetOptions', the frame range's form, keys, controls and reduce."""
    options.validate()
    check_frame_range(frame_range)
    if keys not in ("every", "source"):
        raise ValueError(f"unknown keys {keys!r}; expected 'every' or 'source'")
    if controls not in [c[0] for c in CONTROLS]:
        raise ValueError(f"unknown controls {controls!r}; expected one of {[c[0] for c in CONTROLS]}")
    if not isinstance(reduce, (bool, np.bool_)):
        raise ValueError(f"reduce must be True or False, not {reduce!r}")


def check_options(**options) -> None:
    """retarget()'s keyword options as a batch passes them on (a RetargetOptions as options= among them, or
    its fields one by one): an unknown name or a bad value is a ValueError naming it, before any file is
    read."""
    parameters = {n: p for n, p in inspect.signature(retarget).parameters.items()
                  if n not in ("source", "target") and p.kind is not inspect.Parameter.VAR_KEYWORD}
    known = [*parameters, *retarget_options.NAMES, "ground"]  # ground=: floor_fit's old name, still taken
    unknown = sorted(set(options) - set(known))
    if unknown:
        raise ValueError(f"unknown retarget option {unknown[0]!r}; expected one of {known}")
    values = {n: p.default for n, p in parameters.items() if p.default is not inspect.Parameter.empty}
    values.update((n, v) for n, v in options.items() if n in parameters)
    try:
        fields = from_keywords(values["options"], **{n: v for n, v in options.items() if n not in parameters})
    except TypeError as error:  # options= that is no RetargetOptions
        raise ValueError(str(error)) from None
    _check_values(fields, values["frame_range"], values["keys"], values["controls"], values["reduce"])
    if "bvh_scale" in options:
        retarget_sources.check_bvh_scale(options["bvh_scale"])
    retarget_sources.imported_source_option(options.get("imported_source"), options.get("bvh_source"))


def check_root_bone(target, options: RetargetOptions) -> None:
    """root_motion_onto='root' needs a root bone above the target's hips (as its labels find them): a
    ValueError naming the rig, before any clip is read (plan() says the same of the hips the map drives)."""
    if options.root_motion_onto != "root":
        return
    rig = _rig(target, "target")
    hips = rig.body.hips
    if hips in rig and rig.top(rig.index(hips)) == rig.index(hips):
        raise ValueError(f"root_motion_onto='root': the target '{rig.name}' has no root bone above its hips "
                         f"'{hips}' to carry the motion; choose 'hips' or 'object'")


def split_options(options: dict) -> tuple[RetargetOptions, dict]:
    """A batch's keyword options (check_options') as (the RetargetOptions they make, the others: bone_map,
    frame_range and retarget()'s own)."""
    fields = {n: v for n, v in options.items() if n in retarget_options.NAMES}
    rest = {n: v for n, v in options.items() if n not in retarget_options.NAMES and n != "options"}
    return from_keywords(options.get("options"), **fields), rest


def _retarget_bones(source, target, keys, reduce, action_name, overwrite, call):
    """The action keyed on target's mapped bones themselves. call: (bone map, frame range, RetargetOptions)."""
    if keys != "every":
        raise ValueError("keys='source' is for control rigs; a plain retarget keys every frame")
    plan_ = plan(source, target, *call, defer_solve=True)
    action = apply(plan_, action_name=action_name, overwrite=overwrite)
    if reduce:
        resampling.reduce_keys(target)
    return Retargeted(action, tuple(plan_.channels_left_out), tuple(plan_.chains), tuple(plan_.pairs),
                      tuple(plan_.kept), plan_.map_report, plan_.body)


def _retarget_controls(source, target, controls, limbs, control_map, keys, reduce, action_name, overwrite,
                       progress, call):
    """The action keyed on target's controls, or None when it is to be keyed bone by bone. call: (bone map,
    frame range, RetargetOptions)."""
    if controls not in [c[0] for c in CONTROLS]:
        raise ValueError(f"unknown controls {controls!r}; expected one of {[c[0] for c in CONTROLS]}")
    if controls == "none":
        return None
    # The deform skeleton's retarget is this module's plan(), handed over: control_rigs builds on it.
    planned = []
    result = control_rigs.plan(source, target, lambda skeleton: planned.append(
                               plan(source, target, *call, target_rig=skeleton)) or planned[-1],
                               controls=controls, limbs=limbs, control_map=control_map, keys=keys,
                               progress=progress)
    if result is None:
        return None
    action = control_rigs.apply(result, action_name=action_name, overwrite=overwrite)
    apply_shapes(planned[-1], action_name, overwrite)
    if reduce:
        resampling.reduce_keys(target, bones=result.keyed)
    done = planned[-1]
    return Retargeted(action, tuple(done.channels_left_out), tuple(done.chains), tuple(done.pairs), tuple(done.kept),
                      done.map_report, done.body)
