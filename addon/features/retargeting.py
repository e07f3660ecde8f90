"""Retarget motion from one armature (or a BVH file) onto another: motionkit.retarget.

The source's keyed motion is read in bulk and posed natively, the whole clip
is retargeted in one native call (see native/include/motionkit/retarget.hpp
for the mathematics), and the target gets a new action with one key per
source frame, in each bone's own rotation mode. Everything is computed and
checked before anything in the file changes, so an error leaves it as it was.
"""
from __future__ import annotations

import inspect
import os
from dataclasses import dataclass, field

import bpy
import numpy as np

from . import bvh, contacts, control_rigs, resampling
from ..blender import animdata, imports, pose_channels
from ..blender.imports import remove_armature
from ..core import (bone_mapping, native_state, reference_pose, retarget_options, root_motion, rotation_channels,
                    worker_thread)
from ..core.floor import clearance, clip_floor, feet_lifts, hips_lift, reach_drops, rest_floor, sole_height
from ..core.retarget_options import (FLOOR_FITS, ROOT_MOTIONS, SOURCE_MATCHES, TARGET_MATCHES,  # noqa: F401
                                     RetargetOptions, check_frame_range, from_keywords, is_number)
from ..core.root_motion import FLOOR_ROOTS  # noqa: F401  (the panel's items, beside the other options')

# What a file's imported armature (the source retarget() imports) becomes once the retarget is done.
IMPORTED_SOURCES = (
    ("keep", "Keep", "Leave the imported armature in the scene, scaled as asked"),
    ("hide", "Hide", "Keep the imported armature (and anything imported with it), hidden in the viewport and "
                     "in renders"),
    ("remove", "Remove", "Remove what was imported, its action included, once the target is keyed"),
)
BVH_SOURCES = IMPORTED_SOURCES  # the older name

CONTROLS = (
    ("auto", "Auto", "A recognised control rig's controls (legs IK, arms FK); the bones on any other rig"),
    ("fk", "FK", "Every limb of the control rig in FK"),
    ("ik", "IK", "Every limb of the control rig that has IK controls in IK"),
    ("none", "Bones", "Key the mapped bones themselves, even on a control rig"),
)
_IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


@dataclass
class _Side:
    """One armature, bones parents first, with its native Rig."""
    obj: bpy.types.Object
    bones: list
    rig: object

    def __post_init__(self):
        self.names = [b.name for b in self.bones]
        self._index = {name: i for i, name in enumerate(self.names)}

    def index(self, name: str) -> int:
        return self._index[name]

    def __contains__(self, name) -> bool:
        return name in self._index


def _check_editable(obj) -> None:
    """A target linked from another file without a library override cannot take keys: say so (its pose and
    action live on the object, so an overridden object whose armature stays linked takes them)."""
    library = getattr(obj, "library", None)
    if library is not None:
        raise ValueError(f"the target '{obj.name}' is linked from the library '{library.filepath}' and cannot be "
                         f"keyed here; make a library override (Object > Library Override > Make) and "
                         f"retarget onto that")


def _armature_object(obj):
    """The armature object itself, for a control rig's deform skeleton too."""
    return obj.obj if isinstance(obj, control_rigs.DeformSkeleton) else obj


def _side(obj, role: str) -> _Side:
    if obj is None:
        raise ValueError(f"no {role} armature given")
    # A control rig's deform skeleton (control_rigs.DeformSkeleton) reads as an armature object.
    if not isinstance(obj, (bpy.types.Object, control_rigs.DeformSkeleton)) or obj.type != 'ARMATURE':
        raise ValueError(f"the {role} '{getattr(obj, 'name', obj)}' is not an armature object")
    if not len(obj.data.bones):
        raise ValueError(f"the {role} armature '{obj.name}' has no bones")
    rig, bones = pose_channels.native_rig(obj.data)
    return _Side(obj, bones, rig)


def auto_map(source, target) -> list[tuple[str, str]]:
    """(source bone, target bone) pairs found from names and, where they say nothing, the skeletons."""
    return bone_mapping.auto_map(pose_channels.armature_mapping_rig(source, upright=True),
                                 pose_channels.armature_mapping_rig(target, upright=True))


def _pairs(bone_map, source: _Side, target: _Side) -> list[tuple[str, str]]:
    if bone_map is None:
        bone_map = auto_map(source.obj, target.obj)
    items = list(bone_map.items()) if isinstance(bone_map, dict) else [tuple(p) for p in bone_map]
    source_names, target_names = set(source.names), set(target.names)
    seen = set()
    pairs = []
    for pair in items:
        if len(pair) != 2:
            raise ValueError(f"bone map entries are (source bone, target bone) pairs, got {pair!r}")
        src, tgt = pair
        if not src or not tgt:
            continue
        if src not in source_names:
            raise ValueError(f"bone map: '{src}' is not a bone of the source '{source.obj.name}'")
        if tgt not in target_names:
            raise ValueError(f"bone map: '{tgt}' is not a bone of the target '{target.obj.name}'")
        if tgt in seen:
            raise ValueError(f"bone map: the target bone '{tgt}' is mapped twice")
        seen.add(tgt)
        pairs.append((src, tgt))
    if not pairs:
        raise ValueError(f"no common bones: nothing maps '{source.obj.name}' onto '{target.obj.name}'")
    return pairs


@dataclass
class _Pose:
    """A rig standing in its match pose, in its own armature space."""
    rotations: np.ndarray  # (bones, 4)
    heads: np.ndarray      # (bones, 3)
    lengths: np.ndarray    # (bones,)

    @property
    def points(self) -> np.ndarray:
        tails = self.heads + self.lengths[:, None] * rotation_channels.y_axes(self.rotations)
        return np.vstack([self.heads, tails])


def _lengths(side: _Side) -> np.ndarray:
    return np.array([b.length for b in side.bones], dtype=np.float64)


def _world_rotation_scale(obj) -> tuple[np.ndarray, float]:
    _, rotation, scale = obj.matrix_world.decompose()
    sigma = float(np.mean(scale))
    if not np.allclose(scale, sigma, rtol=1e-6):
        raise ValueError(f"'{obj.name}' has a non-uniform scale {tuple(scale)}; apply it first")
    return np.array(rotation, dtype=np.float64), sigma


def _facing(space, source_pose: _Pose, target_pose: _Pose, pairs_idx, source_root, target_root, up) -> np.ndarray:
    """The quarter turns about the target's up that best lay the source's mapped joints over the target's.

    A least-squares fit (2-D Kabsch) of the joints' offsets from the roots
    across up, rounded to a multiple of 90 degrees, so that a character facing
    +Y retargets onto one facing -Y walking forwards, not backwards.
    """
    src = rotation_channels.rotate(space, source_pose.heads[[a for a, _ in pairs_idx]] - source_pose.heads[source_root])
    tgt = target_pose.heads[[b for _, b in pairs_idx]] - target_pose.heads[target_root]
    across = np.cross(up, [1.0, 0.0, 0.0] if abs(up[0]) < 0.9 else [0.0, 1.0, 0.0])
    across /= np.linalg.norm(across)
    basis = np.stack([across, np.cross(up, across)])  # two axes across up, turning about up
    src, tgt = src @ basis.T, tgt @ basis.T
    cross = np.sum(src[:, 0] * tgt[:, 1] - src[:, 1] * tgt[:, 0])
    dot = np.sum(src[:, 0] * tgt[:, 0] + src[:, 1] * tgt[:, 1])
    angle = np.arctan2(cross, dot) if abs(cross) + abs(dot) > 0 else 0.0
    # Rigs face along their axes; a fit's few degrees of asymmetry are not a turn.
    angle = np.pi / 2 * np.round(angle / (np.pi / 2))
    return np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * np.asarray(up, dtype=np.float64)])


def _placement(source, target, pairs_idx, align_facing: bool):
    """(space, up, source_up): the rotation from source to target armature space (the objects' world
    rotations, and with align_facing the quarter turns about up that face the motion the target's way),
    Blender's up in the target's armature space, and in the source's. source: (side, body, match pose,
    clip rotations, clip heads, root); target: (side, body, match pose, root)."""
    src, src_body, source_pose, clip_rotations, clip_heads, source_root = source
    tgt, tgt_body, target_pose, target_root = target
    source_world, _ = _world_rotation_scale(src.obj)
    target_world, _ = _world_rotation_scale(tgt.obj)
    space = rotation_channels.multiply(rotation_channels.conjugate(target_world), source_world)
    up = _armature_up(tgt.obj)
    if align_facing:
        zero_pose = _faces_nowhere(src, source_pose, [a for a, _ in pairs_idx])
        turn = _facing_turn(space, (src, src_body, source_pose, zero_pose, clip_rotations, clip_heads),
                            (tgt, tgt_body, target_pose), up)
        if turn is None:
            turn = _facing(space, source_pose, target_pose, pairs_idx, source_root, target_root, up)
        space = rotation_channels.multiply(turn, space)
    return space, up, rotation_channels.rotate(rotation_channels.conjugate(space), up[None, :])[0]


def _faces_nowhere(side: _Side, pose: _Pose, bones) -> bool:
    """Whether a match pose is a zero pose (nearly every joint straight on from its parent's along one axis):
    it shows no facing. Read from the joints, not the bones' axes, which an FBX or glTF import may leave all
    pointing one way in a pose that faces somewhere."""
    parent = pose_channels.parent_indices(side.bones)
    parents = [(b, parent[b]) for b in bones if parent[b] >= 0]
    offsets = np.array([pose.heads[b] - pose.heads[p] for b, p in parents]).reshape(-1, 3)
    lengths = np.linalg.norm(offsets, axis=1)
    axes = offsets[lengths > 1e-9 * max(lengths.max(initial=0.0), 1e-30)]
    if len(axes) < 3:
        return False
    axes = axes / np.linalg.norm(axes, axis=1, keepdims=True)
    _, vectors = np.linalg.eigh(axes.T @ axes)
    along = np.abs(axes @ vectors[:, -1]) > np.cos(np.radians(10.0))
    return bool(np.mean(along) >= 0.9)


def _forward(left, right, up) -> np.ndarray:
    """Where a body faces, across up, from its left and right hip joints (..., 3): left x up."""
    forward = np.cross(left - right, up)
    return forward - (forward @ up)[..., None] * up


def _turn_to(direction, onto, up) -> np.ndarray:
    """The quarter turns about up (a quaternion) that best carry one direction across up onto another."""
    angle = np.arctan2(np.cross(direction, onto) @ up, direction @ onto)
    angle = np.pi / 2 * np.round(angle / (np.pi / 2))
    return np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * np.asarray(up, dtype=np.float64)])


def _mid_thighs(side: _Side, body, rotations, heads) -> tuple | None:
    """The middle of the left and right thighs (..., 3) in a pose (rotations (..., 4B), heads (..., 3B)), or
    None without two labelled thighs: across the body, whatever the arms do. Between hip and knee joint where
    the shin is labelled (a bone's axis may not run along it), else half the thigh along its Y axis."""
    found = [(body.limbs.get(f"thigh.{s}"), body.limbs.get(f"shin.{s}")) for s in bone_mapping.SIDES]
    if not all(thigh in side for thigh, _ in found):
        return None
    out = []
    for thigh, shin in found:
        b = side.index(thigh)
        if shin in side:
            k = side.index(shin)
            out.append(0.5 * (heads[..., 3 * b:3 * b + 3] + heads[..., 3 * k:3 * k + 3]))
            continue
        axis = rotation_channels.y_axes(rotations[..., 4 * b:4 * b + 4])
        out.append(heads[..., 3 * b:3 * b + 3] + 0.5 * side.bones[b].length * axis)
    return tuple(out)


def _hip_joints(side: _Side, body, heads) -> tuple | None:
    """The left and right thighs' heads (3,) in a pose's heads (B, 3), or None without two labelled thighs."""
    found = [body.limbs.get(f"thigh.{s}") for s in bone_mapping.SIDES]
    return tuple(heads[side.index(n)] for n in found) if all(n in side for n in found) else None


def _facing_turn(space, source, target, up) -> np.ndarray | None:
    """The quarter turns about up that carry the way the source's body faces onto the way the target's match
    pose faces, from their hips' left-right line (the thighs): the source's match pose's, or, for a match
    pose that shows no facing (a zero pose, the thighs on one line), the clip's mean. None without thighs.
    source: (side, body, match pose, pose's zero-ness, clip rotations, clip heads); target: (side, body,
    match pose)."""
    src, src_body, source_pose, faces_nowhere, clip_rotations, clip_heads = source
    tgt, tgt_body, target_pose = target
    # A match pose's hip joints: the pelvis carries them, whatever stance the legs take (a fighter's guard).
    onto = _hip_joints(tgt, tgt_body, target_pose.heads)
    match = _hip_joints(src, src_body, source_pose.heads)
    if onto is None or match is None:
        return None
    turn = lambda points: rotation_channels.rotate(space, np.asarray(points))  # noqa: E731
    direction = _forward(turn(match[0]), turn(match[1]), up)
    if faces_nowhere or np.linalg.norm(direction) < 1e-3 * max(np.ptp(target_pose.heads, axis=0).max(), 1e-9):
        if not len(clip_heads):
            return None
        left, right = _mid_thighs(src, src_body, clip_rotations, clip_heads)
        faces = _forward(turn(left), turn(right), up)
        mean = (faces / np.maximum(np.linalg.norm(faces, axis=1, keepdims=True), 1e-30)).mean(axis=0)
        # A clip that turns all the way round has no mean facing: its first frame's then.
        direction = mean if np.linalg.norm(mean) > 0.3 else faces[0]
    return _turn_to(direction, _forward(onto[0], onto[1], up), up)


def _hip_height(pose: _Pose, root: int, up: np.ndarray) -> float:
    """How high the root stands above the rig's lowest point, along up."""
    heights = pose.points @ up
    return float(pose.heads[root] @ up - heights.min())


def _legs(side: _Side, body: bone_mapping.Body) -> list:
    """The labelled legs (thigh and shin at least) as root_motion.Leg, by bone index."""
    legs = []
    for s in bone_mapping.SIDES:
        thigh, shin, foot = (body.limbs.get(f"{k}.{s}") for k in ("thigh", "shin", "foot"))
        if thigh in side and shin in side:
            f = side.index(foot) if foot in side else -1
            below = () if f < 0 else tuple(i for i, b in enumerate(side.bones)
                                           if pose_channels.is_below(b, side.bones[f]))
            legs.append(root_motion.Leg(side.index(thigh), side.index(shin), f, below))
    return legs


def _leg_length(side: _Side, body, pose: _Pose, up, hips: int, heads_over_clip=None, floor: float = 0.0) -> float:
    """The rig's leg length in its own armature units.

    thigh + shin + the ankle's height above the sole (the legs' mean), so
    that the same skeleton in any rest pose measures the same: the stride and
    the hips' rise scale with the legs, not with how far the hips bone's head
    stands above the hip joints (a rig's own choice: Mixamo's own retargets
    scale the root's path between Aj and Kaya by 0.88, their legs' ratio,
    where their hips' heads stand 0.86 apart); the hips' height above the
    lowest point only for a rig without labelled legs.
    heads_over_clip (frames, 3B): the rig's motion, for a zero pose's feet above the floor's height.
    """
    legs = _legs(side, body)
    if not legs:
        return _hip_height(pose, hips, up)
    tails = pose.heads + pose.lengths[:, None] * rotation_channels.y_axes(pose.rotations)
    lengths = []
    for leg in legs:
        lowest = None
        if heads_over_clip is not None and leg.foot >= 0:
            lowest = float(np.min(heads_over_clip[:, 3 * leg.foot:3 * leg.foot + 3] @ up)) - floor
            lowest = lowest if lowest > 0 else None
        lengths.append(root_motion.leg_length(leg, pose.heads, tails, lowest))
    return float(np.mean(lengths))


def _bone_aims(src: _Side, tgt: _Side, bone_map: list[int]) -> tuple[np.ndarray | None, np.ndarray | None]:
    """core.bone_axes.aims of each side's rest pose (None where every bone runs along its Y axis), a bone's
    direction meaning the same on both: a target bone points at the child mapped to the source's continuing
    child (a hand at the same finger, whatever each rest pose's wrist does), and where one of a pair has
    nothing to point at (a hand without fingers) both keep their own axes."""
    source_next = pose_channels.continuing_children(src.bones)
    target_next = pose_channels.continuing_children(tgt.bones)
    for t, a in enumerate(bone_map):
        if a >= 0 and (source_next[a] < 0 or target_next[t] < 0):
            source_next[a] = target_next[t] = -1
    for child, parent in enumerate(pose_channels.parent_indices(tgt.bones)):
        if parent >= 0 and bone_map[parent] >= 0 and bone_map[child] >= 0 \
                and source_next[bone_map[parent]] == bone_map[child]:
            target_next[parent] = child
    found = (pose_channels.bone_aims(src.obj.data, src.bones, source_next),
             pose_channels.bone_aims(tgt.obj.data, tgt.bones, target_next))
    return tuple(None if aims is None else aims[0] for aims in found)


def pointing(source, target, pairs) -> tuple[dict, dict]:
    """Where each bone of source and target points in its own rest frame, as the retarget matches them
    ({bone name: unit vector}, Y where a bone runs along its axis): what a measure of the result compares."""
    src, tgt = _side(source, "source"), _side(target, "target")
    bone_map = np.full(len(tgt.bones), -1, dtype=np.int64)
    for a, t in pairs:
        if a in src and t in tgt:
            bone_map[tgt.index(t)] = src.index(a)
    out = []
    for side, aims in zip((src, tgt), _bone_aims(src, tgt, list(bone_map))):
        y = np.array([0.0, 1.0, 0.0])
        out.append({b.name: (y if aims is None else aims[i] / np.linalg.norm(aims[i])) for i, b in enumerate(side.bones)})
    return out[0], out[1]


def _armature_up(obj) -> np.ndarray:
    """World up (Z) in obj's armature space: an FBX import turned 90 degrees about X has it along Y."""
    rotation, _ = _world_rotation_scale(obj)
    return rotation_channels.rotate(rotation_channels.conjugate(rotation), np.array([[0.0, 0.0, 1.0]]))[0]


def _world_height_to_armature(obj, height: float) -> float:
    """A world Z height as a height along up in obj's armature space (its units)."""
    _, sigma = _world_rotation_scale(obj)
    return (float(height) - float(np.array(obj.matrix_world)[2, 3])) / sigma


def _armature_height_to_world(obj, height: float) -> float:
    _, sigma = _world_rotation_scale(obj)
    return float(np.array(obj.matrix_world)[2, 3]) + sigma * float(height)


def _sole_points(side: _Side, body, heads, tails) -> np.ndarray | None:
    """The heads and tails of both feet's bones (and everything below them) in a pose, or None without feet."""
    below = [b for leg in _legs(side, body) for b in leg.below_ankle]
    return np.vstack([heads[below], tails[below]]) if below else None


def _floor_height(side: _Side, body, up, given=None, heads_over_clip=None) -> tuple[float, float]:
    """(floor, clearance): the rig's floor along up in its armature space, given (a world Z height) if set,
    else the floor its importer recorded (bvh.FLOOR), else its rest soles or the origin just below them
    (core.floor.rest_floor); a source clip (heads_over_clip) whose feet never come down to its rest soles
    walks on the floor core.floor.clip_floor finds. clearance: how high the lower of its ankle and ball rides
    above that floor when it stands, as at rest (core.floor.clearance)."""
    heads, tails = pose_channels.heads(side.bones), pose_channels.tails(side.bones)
    soles = _sole_points(side, body, heads, tails)
    legs = [np.linalg.norm(heads[leg.shin] - heads[leg.thigh]) + np.linalg.norm(tails[leg.shin] - heads[leg.shin])
            for leg in _legs(side, body)]
    rest = sole_height(soles, up) if soles is not None else None
    floor = _floor_of(side, body, up, given, heads_over_clip, rest, legs)
    if rest is None or not legs:
        return floor, 0.0
    # The points a standing foot is put down by (its ankle and ball, _foot_heights), at rest: Blender's metarig
    # stands its ball 1.7 cm above the heel bone on its floor.
    feet = _foot_heights(side, body, _rest_rotations(side).reshape(1, -1), heads.reshape(1, -1), up)
    return floor, clearance(float(feet.min()), floor, float(np.mean(legs)))


def _floor_of(side: _Side, body, up, given, heads_over_clip, soles, legs) -> float:
    if given is not None:
        return _world_height_to_armature(side.obj, given)
    recorded = side.obj.data.get(bvh.FLOOR) if hasattr(side.obj.data, "get") else None  # as its importer knew it
    if isinstance(recorded, (int, float)) and np.isfinite(recorded):
        return float(recorded)
    if soles is None:
        return 0.0  # no feet: the armature's origin, as a capture's floor
    rest = rest_floor(soles, float(np.mean(legs))) if legs else soles
    feet = [leg.foot for leg in _legs(side, body) if leg.foot >= 0]
    if heads_over_clip is None or not feet:
        return rest
    lowest = np.min(np.stack([heads_over_clip[:, 3 * f:3 * f + 3] @ up for f in feet], axis=1), axis=1)
    return clip_floor(rest, lowest, float(np.mean(legs)))


def _top(side: _Side, bone: int) -> int:
    above = pose_channels.ancestors(side.bones[bone])
    return side.index(above[-1].name) if above else bone


def _body_roots(side: _Side, body, mapped, depth) -> tuple[int | None, int | None]:
    """(hips, floor root) by index: the hips found by the bone map among the mapped bones (else the highest
    mapped bone other than a floor root), and the top bone above them, if any."""
    hips = side.index(body.hips) if body.hips in side and side.index(body.hips) in mapped else None
    if hips is None:
        floor = side.index(body.root) if body.root in side else None
        candidates = [b for b in mapped if b != floor]
        if not candidates:
            return None, None
        hips = min(candidates, key=lambda b: (depth[b], b))
    top = _top(side, hips)
    return hips, (top if top != hips else None)


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
    leg_ratio: float = 1.0  # target leg length / source leg length, each along its legs
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

    def resolve(self) -> None:
        """Runs a pending feet's IK solve here and now: values, contact_report and all are then final."""
        if self.pending is not None:
            self.pending.complete(self)


def _prepare(source, target, bone_map, frame_range, o: RetargetOptions):
    """plan()'s reading and fitting: (source side, target side, pairs, clip, rigs, fit, chains), the options
    checked first."""
    src, tgt = _side(source, "source"), _side(target, "target")
    if isinstance(tgt.obj, bpy.types.Object):
        _check_editable(tgt.obj)
    if _armature_object(src.obj) == _armature_object(tgt.obj):
        raise ValueError(f"the source and the target are the same armature '{src.obj.name}' (a cycle)")
    o.validate()
    check_frame_range(frame_range)
    _check_scale(src.obj, "source")
    _check_scale(tgt.obj, "target")
    action = animdata.assigned_action(src.obj)
    if action is None:
        raise ValueError(f"the source '{src.obj.name}' has no action to retarget")
    _check_frames(action, frame_range)
    pairs = _pairs(bone_map, src, tgt)
    clip = _read_clip(src, action, pose_channels.action_frames(action, frame_range))
    rigs = _read_rigs(src, tgt, pairs, clip, o)
    fit = _fit(rigs, clip, o)
    return src, tgt, pairs, clip, rigs, fit, _chain_poses(rigs, fit, o.chain_modes)


def _reference(source, target, bone_map, options) -> tuple:
    """_prepare() with the options the reference pose depends on, the others the defaults, on the clip's first
    frame alone: the chains are decided from the two match poses (the clip's own facing counts only for a
    zero pose, against which every chain is matched anyway), so a whole clip is read once, by plan()."""
    action = animdata.assigned_action(_side(source, "source").obj)
    first = int(pose_channels.action_frames(action, None)[0]) if action is not None else None
    return _prepare(source, target, bone_map, None if first is None else (first, first), options.reference())


def reference_chains(source, target, bone_map=None, options: RetargetOptions | None = None, **keywords) -> list:
    """How each chain of the target stands in the reference pose (reference_pose.ChainPose: kept posture or
    the source's direction, decided or the user's), as plan() would decide it, without retargeting.
    options, keywords: plan()'s; only the reference pose's (retarget_options.REFERENCE) count."""
    return _reference(source, target, bone_map, from_keywords(options, **keywords))[-1]


def plan(source, target, bone_map=None, frame_range=None, options: RetargetOptions | None = None, *,
         defer_solve: bool = False, **keywords) -> Plan:
    """Compute the retargeted keys without touching the file (see retarget). options: a RetargetOptions,
    its fields replaced by keywords of the same names (plan(s, t, plant_feet=False) alone is as good).
    defer_solve: leave the feet's IK solve pending for apply(), which runs it beside writing the other
    bones' keys (Plan.resolve runs it at once); the contacts, feet and every other bone's values are final
    either way."""
    o = from_keywords(options, **keywords)
    src, tgt, pairs, clip, rigs, fit, chains = _prepare(source, target, bone_map, frame_range, o)
    root, ground, contact_settings = o.root, o.ground, o.contact_settings
    plant_feet = _planting(o.plant_feet, (src, rigs.src_body), (tgt, rigs.tgt_body))
    # The source's contacts, needed to plant feet or to put them on the floor, need only the source's pose.
    # ground keeps the motion's own heights, the whole clip moved once so that its first frame touches the
    # floor: no frame's feet are fitted apart.
    floor_fit = "off" if ground else o.floor_fit
    wants_feet = plant_feet or (floor_fit != "off" and root != "none")
    feet = (_feet(src, rigs.src_body), _feet(tgt, rigs.tgt_body)) if wants_feet else (None, None)
    # The source's contacts count only where both rigs have feet.
    rotations, root_locations, found = _retarget_clip(rigs, clip, fit, (root, ground, chains),
                                                      None if None in feet else feet[0], contact_settings)
    found, holds = found if found is not None else (None, None)  # the source's stances, and those held
    _share_twist(tgt, rigs.tgt_body, rotations, {b for _, b in rigs.pairs_idx})
    locations, located, mode = _place_roots(rigs, clip, fit, rotations, root_locations, o)
    feet_lift = None
    if found is not None and root != "none" and floor_fit != "off":
        height_scale = fit.unit_scale if root == "offset" else fit.scale
        feet_lift = fit.target_scale * _stand_on_floor(
            native_state.native(), (src, rigs.src_body, clip.rotations, clip.heads, fit.source_up,
                                    fit.floors[0] + fit.clearances[0]),
            (tgt, rigs.tgt_body, fit.up, fit.floors[1] + fit.clearances[1]), rotations, locations, rigs.roots[1],
            found, height_scale,
            fit.heights[1], clip.fps)
    # The legs' solve plants the feet, and puts right what the hips' lift leaves (feet the legs' proportions
    # keep off the floor); without planting it runs only where that is more than a twentieth of a percent of
    # the leg, so that a retarget between alike legs keeps every bone's direction exactly.
    if floor_fit != "legs":
        feet_lift = None
    legs_solve = found is not None and (plant_feet or (
        feet_lift is not None and np.abs(feet_lift).max(initial=0.0) > 5e-4 * fit.target_scale * fit.heights[1]))
    planted = _plant_feet(tgt, feet[1], (found, holds) if plant_feet else (np.zeros_like(found),) * 2, clip.frames,
                          rotations, locations, rigs.roots[1], contact_settings, clip.fps, beside=defer_solve,
                          heights=feet_lift, hips_move=plant_feet) if legs_solve else None
    plan_ = _plan_keys(rigs, clip, pairs, fit.scale, (rotations, locations), located, mode, planted, plant_feet,
                       defer_solve)
    plan_.chains = chains
    if not (np.all(np.isfinite(plan_.values)) and np.all(np.isfinite(plan_.still_values))):
        raise ValueError("the retargeted motion is not finite; check the rigs' rest poses")
    return plan_  # a pending feet's solve is checked when it completes (contacts.cleanup and write_keys)


def _check_frames(action, frame_range) -> None:
    """A frame range that holds none of the action's frames is a mistake, not an extrapolation."""
    if frame_range is None:
        return
    start, end = action.frame_range
    first, last = (int(f) for f in frame_range)
    if first <= last and (last < start or first > end):
        raise ValueError(f"frame range {first}..{last} is outside the source's action '{action.name}' "
                         f"({start:g}..{end:g})")


def _check_scale(obj, role: str) -> None:
    """A non-uniform scale (the object's or a parent's) has no single ratio to scale the motion by."""
    if isinstance(obj, bpy.types.Object):
        scale = obj.matrix_world.to_scale()
        if not np.allclose(scale, float(np.mean(scale)), rtol=1e-6):
            raise ValueError(f"the {role} '{obj.name}' has a non-uniform scale {tuple(round(v, 6) for v in scale)} "
                             f"(its own or a parent's); apply it first (Object > Apply > Scale)")


@dataclass
class _Clip:
    """The source's action over the frames retargeted, its channels read once: posed here, and kept for its
    foot contacts."""
    action: object
    frames: np.ndarray
    fps: float            # its keys' frames per second (animdata.frame_rate)
    basis: np.ndarray     # (frames, 4B) pose-basis rotations
    locations: np.ndarray  # (frames, 3B) location channels
    rotations: np.ndarray  # (frames, 4B) armature-space orientations
    heads: np.ndarray     # (frames, 3B) armature-space heads


def _read_clip(src: _Side, action, frames) -> _Clip:
    basis = pose_channels.rotations(src.obj, action, src.bones, frames)
    locations = np.ascontiguousarray(pose_channels.locations(src.obj, action, src.bones, frames)[0])
    with native_state.blender_frames(frames):
        rotations, heads = native_state.native().armature_pose(src.rig, basis, locations)
    return _Clip(action, frames, animdata.frame_rate(action), basis, locations, rotations, heads)


@dataclass
class _Rigs:
    """The two rigs as the retarget pairs them: their bodies (bone maps), match poses and roots."""
    src: _Side
    tgt: _Side
    src_body: object
    tgt_body: object
    source_pose: _Pose
    target_pose: _Pose
    target_basis: np.ndarray      # (B, 4) the target's match pose's basis rotations
    target_locations: np.ndarray  # (B, 3) and location channels
    bone_map: np.ndarray          # per target bone its source bone, -1 for none
    pairs_idx: list               # (source bone, target bone) by index, a floor root left out
    roots: tuple                  # (source, target) hips
    floor_bones: tuple            # (source, target) floor roots above the hips, or None


def _read_rigs(src: _Side, tgt: _Side, pairs, clip: _Clip, o: RetargetOptions) -> _Rigs:
    native = native_state.native()
    if o.source_match == 'FRAME':  # match_frame given: RetargetOptions.validate
        match_rot, match_heads = pose_channels.armature_motion(src.obj, clip.action, np.array([float(o.match_frame)]),
                                                               src.rig, src.bones)
        source_pose = _Pose(match_rot.reshape(-1, 4), match_heads.reshape(-1, 3), _lengths(src))
    else:
        source_pose = _Pose(_rest_rotations(src), pose_channels.heads(src.bones), _lengths(src))
    if o.target_match == 'CURRENT':
        target_basis, target_locations = pose_channels.current_pose(tgt.obj, tgt.bones)
    else:
        target_basis = np.tile(_IDENTITY, (len(tgt.bones), 1))
        target_locations = np.zeros((len(tgt.bones), 3))
    match_rotations, match_heads = native.armature_pose(tgt.rig, np.ascontiguousarray(target_basis.reshape(1, -1)),
                                                        np.ascontiguousarray(target_locations.reshape(1, -1)))
    target_pose = _Pose(match_rotations.reshape(-1, 4), match_heads.reshape(-1, 3), _lengths(tgt))
    bone_map_idx = np.full(len(tgt.bones), -1, dtype=np.int64)
    pairs_idx = [(src.index(a), tgt.index(b)) for a, b in pairs]
    for a, b in pairs_idx:
        bone_map_idx[b] = a
    src_body = bone_mapping.classify(pose_channels.armature_mapping_rig(src.obj, upright=True))
    tgt_body = bone_mapping.classify(pose_channels.armature_mapping_rig(tgt.obj, upright=True))
    # The hips are the body's root for proportions and height; a game rig's floor root above them is
    # carried apart (floor_root=), never mapped like a body bone.
    target_root, target_floor_bone = _body_roots(tgt, tgt_body, {b for _, b in pairs_idx}, _depths(tgt))
    if target_root is None:
        raise ValueError(f"the bone map drives only the floor root of '{tgt.obj.name}'; map its hips too")
    source_root = int(bone_map_idx[target_root])
    source_floor_bone = _top(src, source_root)
    source_floor_bone = source_floor_bone if source_floor_bone != source_root else None
    if src_body.root is not None and src.names[source_root] == src_body.root:
        raise ValueError(f"the bone map pairs the source's floor root '{src_body.root}' with the target's hips "
                         f"'{tgt.names[target_root]}'; map the source's hips '{src_body.hips}' to it instead")
    if target_floor_bone is not None:
        bone_map_idx[target_floor_bone] = -1
    pairs_idx = [(a, b) for a, b in pairs_idx if b != target_floor_bone]
    return _Rigs(src, tgt, src_body, tgt_body, source_pose, target_pose, target_basis, target_locations,
                 bone_map_idx, pairs_idx, (source_root, target_root), (source_floor_bone, target_floor_bone))


@dataclass
class _Fit:
    """How the source's motion is laid on the target: the turn between their armature spaces, Blender's up
    in each, each rig's floor and leg length (its own units), and the scales between them."""
    space: np.ndarray
    up: np.ndarray
    source_up: np.ndarray
    floors: tuple        # (source, target) heights along up
    clearances: tuple    # (source, target) how high each one's lowest foot joint rides above its floor
    heights: tuple       # (source, target) leg lengths
    scale: float         # target leg length / source leg length
    unit_scale: float    # source object scale / target object scale
    target_scale: float  # the target object's scale


def _fit(rigs: _Rigs, clip: _Clip, o: RetargetOptions) -> _Fit:
    src, tgt = rigs.src, rigs.tgt
    source_root, target_root = rigs.roots
    _, source_scale = _world_rotation_scale(src.obj)
    _, target_scale = _world_rotation_scale(tgt.obj)
    space, up, source_up = _placement(
        (src, rigs.src_body, rigs.source_pose, clip.rotations, clip.heads, source_root),
        (tgt, rigs.tgt_body, rigs.target_pose, target_root), rigs.pairs_idx, o.align_facing)
    source_floor_height, source_clearance = _floor_height(src, rigs.src_body, source_up, o.source_floor, clip.heads)
    target_floor_height, target_clearance = _floor_height(tgt, rigs.tgt_body, up, o.target_floor)
    source_height = _leg_length(src, rigs.src_body, rigs.source_pose, source_up, source_root, clip.heads,
                                floor=source_floor_height)
    # The target's own action (whatever is assigned now) never sets its proportions: a zero pose's feet
    # take a tenth of thigh + shin there (root_motion.leg_length).
    target_height = _leg_length(tgt, rigs.tgt_body, rigs.target_pose, up, target_root)
    if not (source_height > 1e-9 and target_height > 1e-9):
        raise ValueError("the root stands at the lowest point of a rig: no leg length to scale the motion by")
    return _Fit(space, up, source_up, (source_floor_height, target_floor_height),
                (source_clearance, target_clearance), (source_height, target_height), target_height / source_height,
                source_scale / target_scale, target_scale)


def _chain_poses(rigs: _Rigs, fit: _Fit, chain_modes) -> list:
    """Each chain's reference_pose.ChainPose: the target keeps its own posture or takes the source's
    direction, from the two match poses (the source's carried into the target's armature space)."""
    source_heads = rotation_channels.rotate(fit.space, rigs.source_pose.heads)
    bones = [[a for a, _ in rigs.pairs_idx], [b for _, b in rigs.pairs_idx]]
    source = reference_pose.Limbs(rigs.src_body, dict(zip(rigs.src.names, source_heads)),
                                  _faces_nowhere(rigs.src, rigs.source_pose, bones[0]))
    target = reference_pose.Limbs(rigs.tgt_body, dict(zip(rigs.tgt.names, rigs.target_pose.heads)),
                                  _faces_nowhere(rigs.tgt, rigs.target_pose, bones[1]))
    return reference_pose.decide(source, target, chain_modes)


def _posture_bones(rigs: _Rigs, chains, by_user: bool) -> list[int]:
    """The target bones on the chains the user (by_user) or Auto kept (reference_pose.kept_bones): Auto's
    for the native retarget to keep where their parents carry them within 45 degrees of the source's, the
    user's whatever the angle."""
    return reference_pose.kept_bones(rigs.tgt.names, pose_channels.parent_indices(rigs.tgt.bones), rigs.tgt_body,
                                     chains, by_user)


def kept_bones(source, target, bone_map=None, options: RetargetOptions | None = None, **keywords) -> list[str]:
    """The target bones that keep their own posture in the reference pose (the others point where the
    source's do), as plan() decides them: the native retarget's kept_posture on the clip's first frame.
    options, keywords: plan()'s; only the reference pose's (retarget_options.REFERENCE) count."""
    _, tgt, _, clip, rigs, fit, chains = _reference(source, target, bone_map, from_keywords(options, **keywords))
    return [tgt.names[b] for b in _native_retarget(rigs, clip, fit, "none", False, chains).kept_posture]


def _native_options(native, rigs: _Rigs, fit: _Fit, root, ground, chains):
    """The native retarget's options (_native.RetargetOptions) for this fit."""
    options = native.RetargetOptions()
    options.root_motion, options.scale, options.unit_scale = root, fit.scale, fit.unit_scale
    options.vertical_offset = fit.heights[1] - fit.unit_scale * fit.heights[0]
    options.space, options.up = fit.space, fit.up
    options.source_floor, options.target_floor = fit.floors
    options.ground_bones = list(range(len(rigs.tgt.bones))) if ground else []
    options.posture_bones = _posture_bones(rigs, chains, False)
    options.posture_always = _posture_bones(rigs, chains, True)
    return options


def _native_retarget(rigs: _Rigs, clip: _Clip, fit: _Fit, root, ground, chains):
    """The native retarget of the clip (a _native.RetargetResult); it releases the GIL."""
    native = native_state.native()
    src, tgt = rigs.src, rigs.tgt
    source_root, target_root = rigs.roots
    source_aims, target_aims = _bone_aims(src, tgt, [int(v) for v in rigs.bone_map])
    with native_state.blender_frames(clip.frames):
        return native.retarget(
            src.rig, tgt.rig, clip.rotations, np.ascontiguousarray(clip.heads[:, 3 * source_root:3 * source_root + 3]),
            [int(v) for v in rigs.bone_map], source_match=np.ascontiguousarray(rigs.source_pose.rotations),
            source_match_root=rigs.source_pose.heads[source_root],
            target_match_basis=np.ascontiguousarray(rigs.target_basis),
            target_match_location=rigs.target_locations[target_root], source_root=source_root,
            target_root=target_root, options=_native_options(native, rigs, fit, root, ground, chains),
            source_aims=source_aims, target_aims=target_aims)


def _retarget_clip(rigs: _Rigs, clip: _Clip, fit: _Fit, how, source_feet, contact_settings):
    """(rotations, root locations, the source's contacts or None): the native retarget of the whole clip,
    on a worker thread (it releases the GIL) while the source's contacts are found here. how: (root motion,
    ground, the chains' reference_pose.ChainPose)."""
    root, ground, chains = how
    src = rigs.src

    def source_contacts():
        return None if source_feet is None else contacts.find_contacts(
            src.obj, src.bones, src.rig, clip.basis, clip.locations, source_feet, contact_settings, fps=clip.fps,
            posed=(clip.rotations, clip.heads), floor=_armature_height_to_world(src.obj, fit.floors[0]), holds=True)

    result, found = worker_thread.beside(lambda: _native_retarget(rigs, clip, fit, root, ground, chains),
                                         source_contacts)
    return result.rotations, result.root_locations, found


def _place_roots(rigs: _Rigs, clip: _Clip, fit: _Fit, rotations, root_locations, o: RetargetOptions):
    """The target's location channels (frames, 3B): the hips' from the retarget, and a floor root's motion
    (o.floor_root: FLOOR_ROOTS); returns them, the located bones and what the floor root did."""
    tgt = rigs.tgt
    source_floor_bone, target_floor_bone = rigs.floor_bones
    target_root = rigs.roots[1]
    locations = np.zeros((rotations.shape[0], 3 * len(tgt.bones)))
    locations[:, 3 * target_root:3 * target_root + 3] = root_locations
    located = [target_root]
    mode = o.floor_root if o.floor_root != "auto" else ("copy" if source_floor_bone is not None else "still")
    if target_floor_bone is not None and mode in ("copy", "extract"):
        if mode == "copy" and source_floor_bone is None:
            mode = "still"  # nothing to copy: the hips carry the motion
        else:
            source_motion = (clip.rotations[:, 4 * source_floor_bone:4 * source_floor_bone + 4],
                             clip.heads[:, 3 * source_floor_bone:3 * source_floor_bone + 3],
                             rigs.source_pose.rotations[source_floor_bone],
                             rigs.source_pose.heads[source_floor_bone]) if source_floor_bone is not None else None
            _move_floor_root(native_state.native(), tgt, rigs.target_pose, rotations, locations, target_floor_bone,
                             target_root, mode, source_motion, fit.space, fit.scale, o.root,
                             o.root_smoothing * clip.fps)
            located.append(target_floor_bone)
    return locations, located, mode


def _plan_keys(rigs: _Rigs, clip: _Clip, pairs, scale, pose, located, mode, planted, plant_feet,
               defer_solve) -> Plan:
    """The Plan of the target's keys; with planted feet, their solve pending (started beside, defer_solve)
    or resolved here. pose: the target's (rotations, locations), which the feet's solve writes into."""
    tgt = rigs.tgt
    source_root, target_root = rigs.roots
    rotations, locations = pose
    keyed, pending = set(), None
    if planted is not None:
        keyed = {tgt.index(b) for f in planted[2] for b in (f.thigh, f.shin, f.foot)} | {target_root}
        keyer = pose_channels.rotation_keyer(tgt.obj, [tgt.names[b] for b in sorted(keyed)])
        pending = _PlantedFeet(planted[0], planted[1], {tgt.names[b] for b in keyed}, lambda: _target_channels(
            tgt, rotations, rigs.target_basis, rigs.bone_map, located, locations, keyed, keyed, keyer=keyer)[0])
        if defer_solve:
            pending.start()  # beside the rest of the plan and apply()'s writing
    # Bones the feet's solve may change get a key per frame even where the plain retarget keeps them still.
    moving, still = _target_channels(tgt, rotations, rigs.target_basis, rigs.bone_map, located, locations,
                                     keyed=keyed, placeholders=True)
    floor_bones = tuple(side.names[b] if b is not None else None for side, b in zip((rigs.src, tgt), rigs.floor_bones))
    plan_ = Plan(tgt.obj, clip.frames, *moving, rigs.src.obj.name, pairs, *still, leg_ratio=scale,
                 hips=(rigs.src.names[source_root], tgt.names[target_root]), floor_roots=floor_bones,
                 floor_root=mode, feet=planted[2] if planted and plant_feet else None,
                 contacts=planted[3] if planted and plant_feet else None, frame_rate=clip.fps)
    plan_.pending = pending
    plan_.pose = (rotations, locations)
    if not defer_solve:
        plan_.resolve()
    return plan_


def _foot_heights(side: _Side, body, rotations, heads, up, column=None) -> np.ndarray:
    """(frames, legs) the lowest of each foot's ankle (its head) and ball (the toe's head, else the foot's tail)
    along up. column: bone index -> its column in rotations and heads (default: the same)."""
    column = column or (lambda b: b)
    out = []
    for leg, s in zip(_legs(side, body), bone_mapping.SIDES):
        foot = column(leg.foot)
        ankle = heads[:, 3 * foot:3 * foot + 3]
        toe = body.limbs.get(f"toe.{s}")
        # The toe's head is the ball wherever the rig has one (the foot's tail need not lie there).
        ball = heads[:, 3 * column(side.index(toe)):3 * column(side.index(toe)) + 3] if toe in side else ankle + \
            side.bones[leg.foot].length * rotation_channels.y_axes(rotations[:, 4 * foot:4 * foot + 4])
        out.append(np.minimum(ankle @ up, ball @ up))
    return np.stack(out, axis=1)


def _pose_legs(native, side: _Side, body, rotations, locations, hips: int):
    """The armature pose of the legs, the hips and the bones above them only (the rest place no foot):
    (rotations, heads) of those bones and their column by bone index."""
    legs = [b for leg, s in zip(_legs(side, body), bone_mapping.SIDES)
            for b in (leg.thigh, leg.shin, leg.foot) + ((side.index(body.limbs[f"toe.{s}"]),)
                                                          if body.limbs.get(f"toe.{s}") in side else ())]
    sub = sorted(set(legs + [hips]).union(*(
        (side.index(a.name) for a in pose_channels.ancestors(side.bones[b])) for b in legs + [hips])))
    rig, _ = pose_channels.native_rig(side.obj.data, [side.bones[b] for b in sub])
    where = {b: i for i, b in enumerate(sub)}
    columns4 = (4 * np.array(sub)[:, None] + np.arange(4)).ravel()
    columns3 = (3 * np.array(sub)[:, None] + np.arange(3)).ravel()
    posed = native.armature_pose(rig, np.ascontiguousarray(rotations[:, columns4]),
                                 np.ascontiguousarray(locations[:, columns3]))
    return posed[0], posed[1], where.__getitem__


def _stand_on_floor(native, source, target, rotations, locations, hips: int, contacts_, height_scale,
                    leg_length: float, fps: float) -> np.ndarray:
    """Where each foot standing in the source should stand on the target: as high above the target's floor
    as the source's does above its own, scaled. The legs bend or stretch to put it there (the feet's IK
    solve), as Mixamo's own retargets adjust the legs; the hips come down only where a leg would have to
    stretch beyond straight (core.floor.reach_drops, hips_lift).

    source: (side, body, armature rotations, heads, up, floor height); target: (side, body, up, floor
    height); contacts_: (frames, 4) the source's contacts (contacts.POINTS); leg_length: the target's (its
    armature units); fps: the clip's frames per second. Writes the hips' location
    channel in place; returns how far each foot is still to rise (frames, legs), core.floor.feet_lifts."""
    src, src_body, source_rotations, source_heads, source_up, source_floor = source
    tgt, tgt_body, up, target_floor = target
    wanted = target_floor + height_scale * (
        _foot_heights(src, src_body, source_rotations, source_heads, source_up) - source_floor)
    posed_rotations, posed_heads, column = _pose_legs(native, tgt, tgt_body, rotations, locations, hips)
    heights = _foot_heights(tgt, tgt_body, posed_rotations, posed_heads, up, column)
    stance = contacts_[:, 0::2] | contacts_[:, 1::2]  # per leg: its ankle or its ball stands
    joint = lambda b: posed_heads[:, 3 * column(b):3 * column(b) + 3]  # noqa: E731
    legs = _legs(tgt, tgt_body)
    ends = [(joint(leg.thigh), joint(leg.shin), joint(leg.foot) if leg.foot >= 0 else None) for leg in legs]
    if all(ankle is not None for _, _, ankle in ends):
        # A leg straightened to a thousandth short of its joints' reach: the solve stays well-conditioned.
        reach = 0.999 * np.array([np.linalg.norm(k[0] - h[0]) + np.linalg.norm(a[0] - k[0]) for h, k, a in ends])
        drops = reach_drops(np.stack([h for h, _, _ in ends], axis=1), np.stack([a for _, _, a in ends], axis=1),
                            wanted - heights, up, reach)
        lift = hips_lift(drops, stance, slope=0.5 * leg_length / fps)
    else:
        lift = np.zeros(len(heights))
    # The location channel moves the head in the bone's posed frame less its own rotation.
    orient = posed_rotations[:, 4 * column(hips):4 * column(hips) + 4]
    basis = rotations[:, 4 * hips:4 * hips + 4]
    frame = rotation_channels.multiply(orient, rotation_channels.conjugate(basis / np.linalg.norm(basis, axis=1,
                                                                                                    keepdims=True)))
    locations[:, 3 * hips:3 * hips + 3] += rotation_channels.rotate_each(rotation_channels.conjugate(frame),
                                                                           lift[:, None] * up)
    return feet_lifts(wanted, heights + lift[:, None], stance, target_floor, blend_frames=0.1 * fps)


# Each twist bone's limb and the bone below the joint whose twist it takes (docs/retargeting.md, Twist bones).
_TWIST_BELOW = {"upper_arm": "forearm", "forearm": "hand", "thigh": "shin", "shin": "foot"}


def _share_twist(tgt: _Side, body, rotations, mapped) -> None:
    """Gives each leaf twist bone beside a limb (bone_mapping's Body.twists) its share of the limb's twist
    about the limb's axis, by where it lies along the limb: on an upper limb (upper arm, thigh), whose
    twist turns at the joint above it, the bone counters the limb's own twist fully at the joint and not at
    all at the far end; on a lower limb (forearm, shin), whose twist runs along it to the hand or foot, it
    takes none of the hand's or foot's twist at the near end and all of it at the far end. Writes the twist
    bones' basis rotations in place; mapped twist bones keep what the map gave them."""
    rest = pose_channels.rest_quaternions(tgt.obj.data)
    for name, limb_key in body.twists.items():
        limb_name, (part, side) = body.limbs.get(limb_key), limb_key.split(".")
        if name not in tgt or limb_name not in tgt or tgt.index(name) in mapped:
            continue
        twist, limb = tgt.index(name), tgt.index(limb_name)
        bone, limb_bone = tgt.bones[twist], tgt.bones[limb]
        axis = limb_bone.tail_local - limb_bone.head_local
        along = float(np.clip(np.dot(bone.head_local - limb_bone.head_local, axis) / max(axis.length ** 2, 1e-30),
                              0.0, 1.0))
        if part in ("upper_arm", "thigh"):
            angle = -(1.0 - along) * rotation_channels.twist_angles(rotations[:, 4 * limb:4 * limb + 4], [0, 1, 0])
        else:
            below = body.limbs.get(f"{_TWIST_BELOW[part]}.{side}")
            if below not in tgt:
                continue
            b = tgt.index(below)
            angle = along * rotation_channels.twist_angles(rotations[:, 4 * b:4 * b + 4], [0, 1, 0])
        # The limb's axis (its Y) in the twist bone's own rest frame.
        local_axis = rotation_channels.rotate(
            rotation_channels.multiply(rotation_channels.conjugate(rest[name]), rest[limb_name]),
            np.array([0.0, 1.0, 0.0]))
        rotations[:, 4 * twist:4 * twist + 4] = np.concatenate(
            [np.cos(angle / 2)[:, None], np.sin(angle / 2)[:, None] * local_axis], axis=1)


def _planting(plant_feet, source, target) -> bool:
    """Whether to plant feet: plant_feet None plants where both rigs have two labelled legs; True requires
    them (a ValueError names the rig and what it lacks); False never."""
    if plant_feet is not None and not plant_feet:
        return False
    for (side, body), role in ((source, "source"), (target, "target")):
        try:
            contacts.feet_of(body, side.obj.name)
        except ValueError as error:
            if plant_feet:
                raise ValueError(f"plant_feet: the {role} has no feet to plant ({error}); retarget with "
                                 f"plant_feet=False, or map its legs") from None
            return False
    return True


def _feet(side: _Side, body) -> list | None:
    """Both legs' contacts.Foot from the labels, or None when a leg is not labelled (no feet to plant)."""
    try:
        return contacts.feet_of(body, side.obj.name)
    except ValueError:
        return None


def _plant_feet(tgt: _Side, tgt_feet, found, frames, rotations, locations, target_root, settings, fps,
                beside: bool = False, heights=None, hips_move: bool = True):
    """The source's contacts (found: its stances, and those held still as read on the source's motion, a pivot
    being the source's whatever the target's feet) to be held by the target's feet (contacts.staged_cleanup,
    which writes the solved legs into rotations and locations): (prepare, finish, target feet, contacts). heights: (frames,
    legs) world lifts of the standing feet (the floor's), or None to hold the plants' own heights; hips_move:
    the hips' translation is solved for too (planting), else only the legs move."""
    # Beside the rest of the retarget (beside=True), which keeps one core busy, the solve takes the others.
    stances, holds = found
    prepare, finish = contacts.staged_cleanup(tgt.obj, tgt.bones, tgt.rig, frames, rotations, locations, tgt_feet,
                                              stances, settings, hips=tgt.names[target_root], fps=fps, in_place=True,
                                              threads=max(1, (os.cpu_count() or 1) - 1) if beside else 0,
                                              follow_heights=heights, hips_move=hips_move, holds=holds)
    return prepare, finish, tgt_feet, stances


def _depths(side: _Side) -> list[int]:
    depth = [0] * len(side.bones)
    for i, parent in enumerate(pose_channels.parent_indices(side.bones)):
        depth[i] = depth[parent] + 1 if parent >= 0 else 0
    return depth


def _rest_rotations(side: _Side) -> np.ndarray:
    rest = pose_channels.rest_quaternions(side.obj.data)
    return np.array([rest[n] for n in side.names])


def _move_floor_root(native, tgt: _Side, target_pose: _Pose, rotations, locations, floor, hips, mode,
                     source_motion, space, scale, root, sigma_frames) -> None:
    """Gives the target's floor root its motion (copy or extract) and re-expresses the hips under it so that
    every bone keeps its armature-space pose. Writes rotations and locations in place."""
    posed_rotations, posed_heads = native.armature_pose(tgt.rig, rotations, locations)
    block = lambda a, b, n: a[:, n * b:n * b + n]  # noqa: E731
    if mode == "extract":
        track = root_motion.extract_track(block(posed_rotations, hips, 4), block(posed_heads, hips, 3),
                                          target_pose.rotations[hips], target_pose.heads[hips],
                                          target_pose.rotations[floor], target_pose.heads[floor], sigma_frames)
    else:
        track = root_motion.copy_track(*source_motion, space, target_pose.rotations[floor],
                                       target_pose.heads[floor], scale, horizontal=root in ("scaled", "offset"),
                                       vertical=root != "none")
    parent = pose_channels.parent_indices(tgt.bones)
    rest = root_motion.FloorRootRest(floor, parent[floor], hips, parent[hips], _rest_rotations(tgt),
                                     pose_channels.heads(tgt.bones))
    root_parent = parent[floor]
    parent_pose = None if root_parent < 0 else (block(posed_rotations, root_parent, 4),
                                                block(posed_heads, root_parent, 3))

    def hips_parent_pose(root_basis, root_location):
        if rest.hips_parent == floor:  # the usual game rig: the hips hang from the floor root itself
            return track
        trial_rotations, trial_locations = rotations.copy(), locations.copy()
        trial_rotations[:, 4 * floor:4 * floor + 4] = root_basis
        trial_locations[:, 3 * floor:3 * floor + 3] = root_location
        r, h = native.armature_pose(tgt.rig, trial_rotations, trial_locations)
        return block(r, rest.hips_parent, 4), block(h, rest.hips_parent, 3)

    root_basis, root_location, hips_basis, hips_location = root_motion.carry(
        rest, *track, parent_pose, hips_parent_pose, block(posed_rotations, hips, 4), block(posed_heads, hips, 3))
    rotations[:, 4 * floor:4 * floor + 4] = root_basis
    locations[:, 3 * floor:3 * floor + 3] = root_location
    rotations[:, 4 * hips:4 * hips + 4] = hips_basis
    locations[:, 3 * hips:3 * hips + 3] = hips_location


def _target_channels(tgt: _Side, rotations, target_basis, bone_map_idx, located, locations, only=None,
                     keyed=frozenset(), placeholders=False, keyer=None):
    """The F-curves to key, in each bone's own rotation mode: (channels, values) for the bones the retarget
    moves (and those in keyed) and the root's location, one key per frame; (channels, values) for the bones
    that keep the match pose, one key. only: the bone indices to give (default all). placeholders: the
    keyed bones' values left at zero (the feet's solve fills them in). keyer: pose_channels.rotation_keyer
    of the moving bones in only, in bone order, so that this reads no Blender data (for a worker thread)."""
    frames = rotations.shape[0]
    scope = [b for b in range(len(tgt.names)) if only is None or b in only]
    moving = [b for b in scope if bone_map_idx[b] >= 0 or b in located or b in keyed
              or bool(np.any(np.abs(rotations[:, 4 * b:4 * b + 4] @ target_basis[b]) < 1.0 - 1e-12))]
    still = sorted(set(scope) - set(moving))
    later = [b for b in moving if placeholders and b in keyed]  # zeros until the feet's solve
    now = [b for b in moving if b not in later]
    columns = lambda bones: (4 * np.array(bones, dtype=np.int64)[:, None] + np.arange(4)).ravel()  # noqa: E731
    names = lambda bones: [tgt.names[b] for b in bones]  # noqa: E731
    channels = [(f"{pose_channels.bone_path(tgt.names[b])}.location", k, tgt.names[b]) for b in moving if b in located
                for k in range(3)]
    rows = [locations[:, 3 * b:3 * b + 3].T for b in moving if b in located]
    for bones, placeholder in ((now, False), (later, True)):
        if bones:
            keys = keyer if keyer is not None and not placeholder else pose_channels.rotation_keyer(tgt.obj, names(bones))
            more, values = keys(rotations[:, columns(bones)], placeholder=placeholder)
            channels += more
            rows.append(values)
    still_channels, still_values = pose_channels.rotation_keys(tgt.obj, names(still), rotations[:1, columns(still)]) \
        if still else ([], np.empty((0, 1)))
    return (channels, np.vstack(rows) if rows else np.empty((0, frames))), (still_channels, still_values)


def apply(plan_: Plan, *, action_name: str | None = None, overwrite: bool = False) -> bpy.types.Action:
    """Write a plan's keys: a new action on the target, or its own one with overwrite."""
    target = plan_.target
    previous = animdata.assigned_action(target)
    if overwrite and previous is not None:
        plan_.resolve()  # everything computed before the user's own action changes
        _write(target, previous, plan_)
        return previous
    return animdata.install_action(target, animdata.new_action(action_name or f"{plan_.source_name} -> {target.name}"),
                                   lambda action: _write(target, action, plan_))


def _write(target, action, plan_: Plan) -> None:
    pending = plan_.pending
    if pending is not None and plan_.channels:
        # The solve releases the GIL: the other bones' keys are written meanwhile (a failure of either
        # leaves the new action to apply(), which removes it).
        changed = [bone in pending.bones for _, _, bone in plan_.channels]
        later = [row for row, change in enumerate(changed) if change]
        now = [row for row, change in enumerate(changed) if not change]
        animdata.write_keys(target, action, [plan_.channels[r] for r in now], plan_.frames, plan_.values[now])
        _write_unsolved(target, action, plan_)
        pending.complete(plan_)  # waits for the solve, if it still runs
        animdata.write_keys(target, action, [plan_.channels[r] for r in later], plan_.frames,
                            plan_.values[later])
    else:
        if plan_.channels:
            plan_.resolve()
            animdata.write_keys(target, action, plan_.channels, plan_.frames, plan_.values)
        _write_unsolved(target, action, plan_)
    animdata.record_frame_rate(action, plan_.frame_rate)


def _write_unsolved(target, action, plan_: Plan) -> None:
    """The keys that do not wait for the feet's solve: the bones that keep the match pose, and the contacts."""
    if plan_.still_channels:
        animdata.write_keys(target, action, plan_.still_channels, plan_.frames[:1], plan_.still_values)
    if plan_.contacts is not None:  # where the animator sees and edits them; "Fix foot sliding" reads them
        contacts.write_contacts(target, action, plan_.feet, plan_.frames, plan_.contacts)


def retarget(source, target, bone_map=None, frame_range=None, options: RetargetOptions | None = None, *,
             action_name: str | None = None, overwrite: bool = False, bvh_scale: float | str = "auto",
             imported_source: str | None = None, bvh_source: str | None = None, controls: str = "auto",
             limbs: dict | None = None, control_map=None, keys: str = "every", reduce: bool = False, progress=None,
             **keywords):
    """Retarget the source's action onto the target; returns the target's new action.

    source: an armature object with an action, or a file path: BVH (imported
    with motionkit.bvh.load), FBX, glTF or GLB (Blender's own importers; the
    file's animated armature is the source). For a BVH file, bvh_scale sizes
    the imported armature: "auto" stands it as tall as the target (a
    centimetre file would otherwise stand 100 times too tall), or a number
    multiplies the file's distances; the retarget itself does not depend on it
    (the motion is scaled by the legs' ratio). imported_source: "keep",
    "hide" or "remove" what was imported afterwards (IMPORTED_SOURCES;
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
    does), its fields replaced by keywords of the same names: root (ROOT_MOTIONS),
    source_match, match_frame and target_match (the poses in which the two rigs
    stand alike), chain_modes (per chain, keep the target's posture or take the
    source's direction; by default the trunk keeps, a limb whose rest line lies
    farther than 15 degrees from the source's matches, the others keep, and
    fingers match: Plan.chains), ground, align_facing, source_floor and
    target_floor, floor_fit (FLOOR_FITS), floor_root and root_smoothing
    (FLOOR_ROOTS), plant_feet and contact_settings (planted feet are stored on
    the new action as 0/1 contact curves). The hips are the body's root on both
    sides and the translation is scaled by the ratio of leg lengths measured
    along the legs. The new action is assigned to the target (its previous
    action keeps a fake user rather than being lost); with overwrite the keys
    replace the target's own action's curves instead. A ValueError leaves the
    file as it was (a BVH source is removed again).
    """
    imported_source = _imported_source_option(imported_source, bvh_source)
    if target is not None and getattr(target, "type", None) == 'ARMATURE':
        _check_editable(target)
    options = from_keywords(options, **keywords)
    # Before a file is imported for nothing: every option's value, and the target's scale.
    _check_values(options, frame_range, keys, controls, reduce)
    _check_scale(target, "target")
    call = (bone_map, frame_range, options)
    imported = _import_source(source, target, bvh_scale) if isinstance(source, (str, os.PathLike)) else None
    try:
        action = _retarget_controls(imported.obj if imported else source, target, controls, limbs, control_map, keys,
                                    reduce, action_name, overwrite, progress, call)
        if action is None:
            action = _retarget_bones(imported.obj if imported else source, target, keys, reduce, action_name,
                                     overwrite, call)
    except BaseException:
        if imported is not None:
            imported.remove()
        raise
    if imported is not None:
        imported.finish(imported_source)
    return action


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
    known = [*parameters, *retarget_options.NAMES]
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
        _bvh_scale(options["bvh_scale"])
    _imported_source_option(options.get("imported_source"), options.get("bvh_source"))


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
    action = apply(plan(source, target, *call, defer_solve=True), action_name=action_name, overwrite=overwrite)
    if reduce:
        resampling.reduce_keys(target)
    return action


def _imported_source_option(imported_source, bvh_source) -> str:
    if imported_source is not None and bvh_source is not None and imported_source != bvh_source:
        raise ValueError("imported_source and its older name bvh_source say different things; give one")
    chosen = imported_source or bvh_source or "keep"
    if chosen not in [b[0] for b in IMPORTED_SOURCES]:
        raise ValueError(f"unknown imported_source (bvh_source) {chosen!r}; expected one of {[b[0] for b in IMPORTED_SOURCES]}")
    return chosen


@dataclass
class _Imported:
    """A source armature retarget() imported from a file, and what the import added."""
    obj: bpy.types.Object
    added: dict | None = None  # Blender's importers: everything they added (imports.remove)

    def remove(self) -> None:
        if self.added is None:
            remove_armature(self.obj)
        else:
            imports.remove(self.added)

    def finish(self, what: str) -> None:
        """What becomes of the import once the target is keyed: IMPORTED_SOURCES."""
        if what == "remove":
            self.remove()
            return
        if what == "hide":
            shown = [self.obj] + ([o for o in self.added["objects"] if o != self.obj] if self.added else [])
            for obj in shown:
                obj.hide_set(True)
                obj.hide_render = True


def _bvh_scale(bvh_scale) -> None:
    if not (bvh_scale == "auto" or (is_number(bvh_scale) and np.isfinite(bvh_scale) and bvh_scale > 0)):
        raise ValueError(f"bvh_scale must be 'auto' or a positive number, not {bvh_scale!r}")


def _import_source(path, target, bvh_scale) -> _Imported:
    """A file path's armature: BVH through MotionKit's reader, FBX and glTF through Blender's importers."""
    path = os.fspath(path)
    if os.path.splitext(path)[1].lower() in imports.FORMATS:
        obj, added = imports.import_animated_armature(path)
        return _Imported(obj, added)
    _bvh_scale(bvh_scale)
    obj, _ = bvh.load(path, scale=1.0 if bvh_scale == "auto" else float(bvh_scale))
    if bvh_scale == "auto":
        try:
            _stand_as_tall_as(obj, target)
        except BaseException:
            remove_armature(obj)
            raise
    return _Imported(obj)


def _retarget_controls(source, target, controls, limbs, control_map, keys, reduce, action_name, overwrite,
                       progress, call):
    """The action keyed on target's controls, or None when it is to be keyed bone by bone. call: (bone map,
    frame range, RetargetOptions)."""
    if controls not in [c[0] for c in CONTROLS]:
        raise ValueError(f"unknown controls {controls!r}; expected one of {[c[0] for c in CONTROLS]}")
    if controls == "none":
        return None
    # The deform skeleton's retarget is this module's plan(), handed over: control_rigs builds on it.
    result = control_rigs.plan(source, target, lambda skeleton: plan(source, skeleton, *call),
                               controls=controls, limbs=limbs, control_map=control_map, keys=keys,
                               progress=progress)
    if result is None:
        return None
    action = control_rigs.apply(result, action_name=action_name, overwrite=overwrite)
    if reduce:
        resampling.reduce_keys(target, bones=result.keyed)
    return action


def _stand_as_tall_as(obj, other) -> None:
    """Scale obj (uniformly, as an object) so that its rest pose stands as tall as other's."""
    def height(o):
        world = np.array(o.matrix_world)
        z = (pose_channels.rest_points(o.data) @ world[:3, :3].T + world[:3, 3])[:, 2]
        return float(np.ptp(z))

    mine, theirs = height(obj), height(other)
    if mine > 0 and theirs > 0:
        obj.scale = obj.scale * (theirs / mine)
        bpy.context.view_layer.update()
