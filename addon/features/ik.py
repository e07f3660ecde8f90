"""Full-body IK in Blender: motionkit.ik.solve, and the live re-solve behind the panel.

The armature's input pose (its action, or its current pose) and every
effector's target on every frame are read in bulk, the whole frame range is
solved in one native call (native/include/motionkit/ik.hpp), and the result
goes either onto the pose (one frame) or into keys (a range), in each bone's
own rotation mode. Everything is computed and checked before anything in
the file changes.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field

import bpy
import numpy as np

from ..blender import animdata, pose_channels
from ..core import bone_mapping, ik_defaults, native_state, rotation_channels, worker_thread

METHODS = (
    ("dls", "Damped LS", "Damped least squares: robust near singular poses; regularised towards the previous "
                         "frame"),
    ("pinv", "Pseudo-inverse", "Gauss-Newton steps; fast, fragile near singular poses"),
    ("transpose", "Transpose", "Jacobian transpose: gradient steps, simple and slow"),
    ("ccd", "CCD", "Cyclic coordinate descent, joint by joint"),
)
# The posture prior's weight with natural defaults: strong enough that what no target needs (an upper
# arm's twist about a straight arm, say) stays near the input from frame to frame, instead of drifting
# and popping while a target is out of reach (measured on the sample characters, docs/ik.md).
NATURAL_REGULARIZATION = 1e-2
PLAIN_REGULARIZATION = 1e-4  # DLS's light pull towards the previous frame's solution otherwise


@dataclass
class Effector:
    """A bone whose tail should reach a target.

    target: an Object (its world location, and rotation with orientation=True),
    (armature Object, bone name) for a bone's head, a world position (3,), or
    per-frame world positions (frames, 3). pin=True holds the tail where the
    input pose has it on each frame (no target needed). chain_count limits the
    bones this effector moves, as Blender's IK constraint does; when any
    effector has one, bones on no effector's chain stay as they are.
    """
    bone: str
    target: object = None
    pin: bool = False
    weight: float = 1.0
    position: bool = True
    orientation: bool = False
    name: str = ""
    chain_count: int = 0  # as Blender's IK constraint: bones solved up from this one; 0 = up to the root

    def label(self) -> str:
        return self.name or f"effector on '{self.bone}'"


@dataclass
class Result:
    frames: np.ndarray
    errors: np.ndarray      # (frames, effectors), armature units
    iterations: np.ndarray  # (frames,)
    bones: list = field(default_factory=list)  # the bones the solve moved


def _frames(frame_range) -> np.ndarray:
    if frame_range is None:
        return np.array([float(bpy.context.scene.frame_current)])
    return pose_channels.frames_between(*frame_range)


def _world_placements(obj, frames) -> tuple[np.ndarray, np.ndarray]:
    """An object's world location (frames, 3) and rotation (frames, 4) on each frame, from its own keys,
    without frame_set."""
    action = animdata.assigned_action(obj)
    if action is None or frames.size == 1 and frames[0] == bpy.context.scene.frame_current:
        location, rotation, _ = obj.matrix_world.decompose()
        return (np.tile(np.array(location, dtype=np.float64), (frames.size, 1)),
                np.tile(np.array(rotation, dtype=np.float64), (frames.size, 1)))
    if obj.parent is not None or len(obj.constraints):
        raise ValueError(f"target '{obj.name}' is animated and parented or constrained: bake its motion first")
    native = native_state.native()
    mode = obj.rotation_mode
    prop, size = rotation_channels.channel_property(mode)
    channels = [("location", k) for k in range(3)] + [(prop, k) for k in range(size)]
    static = list(obj.location) + list(getattr(obj, prop))
    values, _ = animdata.sample(action, obj, channels, frames, static)
    q = rotation_channels.to_quaternions(native, mode, values[3:].T, f"target '{obj.name}' rotation", frames)
    return values[:3].T, q


def _bone_heads(obj, bone_name, frames) -> np.ndarray:
    """World heads of another armature's bone on each frame (frames, 3), posed natively."""
    rig, bones = pose_channels.native_rig(obj.data)
    _, heads = pose_channels.armature_motion(obj, animdata.assigned_action(obj), frames, rig, bones)
    index = [b.name for b in bones].index(bone_name)
    world = np.array(obj.matrix_world)
    return heads[:, 3 * index:3 * index + 3] @ world[:3, :3].T + world[:3, 3]


def _targets(obj, effectors, frames):
    """Per-frame targets in the armature's space: positions (frames, 3E), orientations (frames, 4E)."""
    to_armature = np.linalg.inv(np.array(obj.matrix_world))
    arm_rotation = np.array(obj.matrix_world.to_quaternion(), dtype=np.float64)
    positions = np.zeros((frames.size, 3 * len(effectors)))
    orientations = np.tile([1.0, 0.0, 0.0, 0.0], (frames.size, len(effectors)))
    for e, effector in enumerate(effectors):
        target = effector.target
        if effector.pin:
            continue
        if target is None:
            raise ValueError(f"{effector.label()} has no target (give one, or pin it)")
        rotation = None
        if isinstance(target, bpy.types.Object):
            world, rotation = _world_placements(target, frames)
        elif isinstance(target, tuple) and len(target) == 2 and isinstance(target[0], bpy.types.Object):
            armature, bone_name = target
            if armature.type != 'ARMATURE' or bone_name not in armature.data.bones:
                raise ValueError(f"{effector.label()}: '{bone_name}' is not a bone of '{armature.name}'")
            world = _bone_heads(armature, bone_name, frames)
        else:
            world = np.asarray(target, dtype=np.float64)
            if world.shape == (3,):
                world = np.tile(world, (frames.size, 1))
            if world.shape != (frames.size, 3):
                raise ValueError(f"{effector.label()}: target positions must be (3,) or ({frames.size}, 3)")
        if not np.all(np.isfinite(world)):
            bad = np.flatnonzero(~np.isfinite(np.asarray(world).reshape(frames.size, -1)).all(axis=1))[0]
            raise ValueError(f"{effector.label()}: the target is not finite at frame {frames[bad]:g}")
        positions[:, 3 * e:3 * e + 3] = world @ to_armature[:3, :3].T + to_armature[:3, 3]
        if effector.orientation:
            if rotation is None:
                raise ValueError(f"{effector.label()}: an orientation target needs an object target")
            orientations[:, 4 * e:4 * e + 4] = rotation_channels.multiply(rotation_channels.conjugate(arm_rotation),
                                                                          rotation)
    return positions, orientations


@dataclass
class Plan:
    obj: bpy.types.Object
    bones: list                 # the B bones solved over: the effectors' bones, their ancestors and the root
    frames: np.ndarray
    rotations: np.ndarray       # (frames, 4B) solved pose rotations
    root_locations: np.ndarray  # (frames, 3)
    moved: np.ndarray           # (B,) bool: bones whose rotation the solve changed
    result: Result
    joints: dict | None = None  # the per-bone settings the solver took (natural defaults merged), over bones
    balance: bool = False       # the centre of mass was kept over the pinned feet


def plan(obj, effectors, frame_range=None, method: str = "dls", *, root_translation: bool = True,
         root_rotation: bool = True, max_iterations: int = 64, tolerance: float | None = None,
         damping: float = 0.0, regularization: float | None = None, use_limits: bool = True,
         reference: str | None = None, priorities: bool = True, natural="auto", balance=None,
         defaults=None, alongside=None) -> Plan:
    """Solve without touching the file (see solve). alongside: a callable run on this thread while the
    native solve runs on another (Blender's data may only be touched from this one)."""
    native = native_state.native()
    effectors = _checked_effectors(obj, effectors, method)
    all_bones = pose_channels.depth_first(obj.data)
    all_names = [b.name for b in all_bones]
    for effector in effectors:
        if effector.bone not in all_names:
            raise ValueError(f"{effector.label()}: '{effector.bone}' is not a bone of '{obj.name}'")
        if not (np.isfinite(effector.weight) and effector.weight > 0):
            raise ValueError(f"{effector.label()}: the weight must be positive")
    rest = pose_channels.rest_points(obj.data)
    natural_joints = _natural(obj, all_names, rest, natural, defaults)
    # A humanoid solved whole (recruitment stages; no chain_count) has its posture prior towards its own
    # input pose, strong enough to hold what no target needs (a twist); otherwise the previous frame's
    # solution, and DLS's light regulariser.
    whole_body = natural_joints is not None and not any(e.chain_count > 0 for e in effectors)
    if reference is None:
        reference = "input" if whole_body else "previous"
    if not regularization:  # 0 or None: the default
        regularization = NATURAL_REGULARIZATION if whole_body else PLAIN_REGULARIZATION
    if balance is None:  # on when a humanoid's feet are pinned
        balance = natural_joints is not None and any(
            e.pin and natural_joints.part[all_names.index(e.bone)] in ("foot", "shin") for e in effectors)
    balance = bool(balance) and priorities and method == "dls" and any(e.pin for e in effectors)
    rig, bones, above = _solved_rig(obj, all_bones, all_names, effectors, rest, balance)
    _refuse_constraints(obj, bones + above)
    names = [b.name for b in bones]
    frames = _frames(frame_range)
    action = animdata.assigned_action(obj) if frame_range is not None else None
    input_rotations, input_locations = _input_pose(obj, action, bones, frames)
    positions, orientations = _targets(obj, effectors, frames)
    up = np.linalg.inv(np.array(obj.matrix_world)[:3, :3]) @ np.array([0.0, 0.0, 1.0])
    if above:  # into the hips' parent's frame (its turn about up, a floor root's facing, keeps up)
        positions, orientations = _into_parent_frame(obj, above, frames, action, positions, orientations)
        up = rotation_channels.rotate(rotation_channels.conjugate(_parent_rest(obj, above)), up)
    tables = pose_channels.ik_settings(obj, bones) if use_limits else {}
    if natural_joints is not None:
        tables = _with_defaults(tables, natural_joints, [all_names.index(n) for n in names], len(names))
    if any(e.chain_count > 0 for e in effectors):
        tables["excluded"] = _outside_chains(bones, names, effectors)
    arguments = (rig, np.ascontiguousarray(input_rotations), np.ascontiguousarray(input_locations),
                 np.ascontiguousarray(positions), np.ascontiguousarray(orientations),
                 [native.IkEffector(names.index(e.bone), name=e.label(), weight=float(e.weight), position=e.position,
                                    orientation=e.orientation, pin=e.pin) for e in effectors])
    joints = native.IkJoints(**tables)
    options = native.IkOptions(
        method=method, max_iterations=max_iterations, tolerance=float(tolerance or 0.0), damping=damping,
        regularization=regularization, reference=reference, root_translation=root_translation,
        root_rotation=root_rotation, size=float(np.linalg.norm(np.ptp(rest, axis=0))), priorities=priorities,
        balance=balance, up=tuple(float(v) for v in up / np.linalg.norm(up)))

    def run():
        with native_state.blender_frames(frames):
            return native.ik_solve(*arguments, joints=joints, options=options)

    solved = run() if alongside is None else worker_thread.beside(run, alongside)[0]
    return _plan_of(obj, bones, frames, input_rotations, solved, root_translation,
                    tables if natural_joints is not None or balance else None, balance)


def _refuse_constraints(obj, bones) -> None:
    """The solve poses bones by their pose channels alone: a bone it reads or keys that a working constraint
    also moves would show Blender's evaluation something else than the solve reached (the constraint
    applied on top of the keys). Such a bone is refused by name; muted constraints and constraints at zero
    influence, and constraints on bones the solve does not see (fingers, say), are left alone."""
    for bone in bones:
        for constraint in obj.pose.bones[bone.name].constraints:
            working = constraint.enabled if hasattr(constraint, "enabled") else not constraint.mute
            if working and constraint.influence > 0.0:
                raise ValueError(f"bone '{bone.name}' of '{obj.name}' has the constraint '{constraint.name}' "
                                 f"({constraint.type}): the IK solve does not evaluate constraints; mute it or "
                                 "apply it first")


def _checked_effectors(obj, effectors, method) -> list:
    """The effectors as Effector objects, the armature and method checked (the bones and weights by plan)."""
    if obj is None or not isinstance(obj, bpy.types.Object) or obj.type != 'ARMATURE':
        raise ValueError(f"'{getattr(obj, 'name', obj)}' is not an armature object")
    if method not in [m[0] for m in METHODS]:
        raise ValueError(f"unknown IK method {method!r}; expected one of {[m[0] for m in METHODS]}")
    effectors = [e if isinstance(e, Effector) else Effector(**e) for e in effectors]
    if not effectors:
        raise ValueError("no effectors: give at least one bone and target")
    return effectors


def _solved_rig(obj, all_bones, all_names, effectors, rest, balance):
    """(native Rig, its bones, the bones above the hips or []): the part of the armature the solve sees.

    Only the effectors' bones and their ancestors place the effectors: the solve sees that part of the rig
    (with the root, whose location channel it reads), sized as the whole rig so that it is solved as the
    whole would be; the other bones are neither read, solved nor keyed. Under a game rig's floor root the
    hips' subtree is solved in the hips' parent's posed frame (the bones above it returned)."""
    part = sorted(_ancestors(all_bones, all_names, [e.bone for e in effectors]) | {0})
    body = _body_root(obj, all_bones, all_names, part, rest)
    if balance:  # the centre of mass weighs every bone of the body
        part = sorted(set(part) | {i for i, b in enumerate(all_bones) if pose_channels.is_below(b, all_bones[body])})
    above = [all_bones[i] for i in part if i < body and all_bones[i] in pose_channels.ancestors(all_bones[body])]
    if above:
        part = [i for i in part if i >= body and pose_channels.is_below(all_bones[i], all_bones[body])]
        rig, bones = _rig_below(obj, [all_bones[i] for i in part])
    else:
        rig, bones = pose_channels.native_rig(obj.data, [all_bones[i] for i in part])
    return rig, bones, above


def _input_pose(obj, action, bones, frames) -> tuple[np.ndarray, np.ndarray]:
    """The input pose: rotations (frames or 1, 4B) and the root's location (frames or 1, 3), from the action
    on frames, or the pose as it stands (one frame) without one."""
    if action is None:
        rotations, locations = pose_channels.current_pose(obj, bones)
        return rotations.reshape(1, -1), np.ascontiguousarray(locations[:1])
    _refuse_non_finite_keys(obj, action, bones)
    locations, _ = pose_channels.locations(obj, action, bones[:1], frames)
    return pose_channels.rotations(obj, action, bones, frames), np.ascontiguousarray(locations)


def _refuse_non_finite_keys(obj, action, bones) -> None:
    """A key that is not finite on a channel the solve reads (the bones' rotations, the root's location) is
    named by bone, channel and frame, before anything is sampled."""
    read = {f"{pose_channels.bone_path(bone.name)}.{prop}": bone.name
            for bone in bones for prop in ("rotation_quaternion", "rotation_euler", "rotation_axis_angle")}
    read[f"{pose_channels.bone_path(bones[0].name)}.location"] = bones[0].name
    bad = animdata.first_non_finite(fc for fc in animdata.fcurves(action, obj) if fc.data_path in read)
    if bad is not None:
        channel = bad.fcurve.data_path.rsplit(".", 1)[1]
        raise ValueError(f"bone '{read[bad.fcurve.data_path]}' has a {bad.what} that is not finite on "
                         f"{channel}[{bad.fcurve.array_index}] at frame {bad.frame:g} of action '{action.name}'")


def _plan_of(obj, bones, frames, input_rotations, solved, root_translation, joints, balance) -> Plan:
    count = len(bones)
    out = solved.rotations.reshape(frames.size, count, 4)
    base = np.broadcast_to(np.asarray(input_rotations).reshape(-1, count, 4), out.shape)
    moved = np.any(np.abs(np.einsum("fbk,fbk->fb", out, base)) < 1.0 - 1e-12, axis=0)
    if root_translation:
        moved[0] = True
    result = Result(frames, solved.errors, solved.iterations, [bones[i].name for i in np.flatnonzero(moved)])
    return Plan(obj, bones, frames, solved.rotations, solved.root_locations, moved, result, joints, balance)


def _ancestors(bones, names, starts) -> set:
    """Indices of the named bones and everything above them."""
    index = {name: i for i, name in enumerate(names)}
    out = set()
    for name in starts:
        out.add(index[name])
        out.update(index[b.name] for b in pose_channels.ancestors(bones[index[name]]))
    return out


_LABELS: dict = {}  # rest signature -> the bone map's labels
_NATURAL: dict = {}  # rest signature and settings -> the natural defaults (core.ik_defaults.Joints)


def _labels(obj, all_names, rest) -> bone_mapping.Body:
    """MotionKit's bone map of the armature. Classifying takes milliseconds on a large rig: the answer
    is kept per rest pose, so that the live re-solve does not pay it on every update."""
    key = (tuple(all_names), rest.tobytes())
    if key not in _LABELS:
        if len(_LABELS) > 64:
            _LABELS.clear()
        _LABELS[key] = bone_mapping.classify(pose_channels.armature_mapping_rig(obj, upright=True))
    return _LABELS[key]


def _floor_rooted_hips(obj, all_names, rest) -> str | None:
    """The hips' name when the top bone is a game rig's floor root (MotionKit's bone map), else None."""
    labels = _labels(obj, all_names, rest)
    found = labels.root is not None and labels.root == all_names[0] and labels.hips in all_names
    return labels.hips if found else None


def _rest_of(obj) -> tuple[list, np.ndarray]:
    """The bones' names (depth first) and every head, then every tail, at rest."""
    return [b.name for b in pose_channels.depth_first(obj.data)], pose_channels.rest_points(obj.data)


def natural_defaults(obj, settings=None):
    """The natural defaults MotionKit would use on this armature (core.ik_defaults.Joints, over its bones
    in depth-first order), or None when the bone map does not recognise a humanoid. settings: a
    core.ik_defaults.NaturalDefaults or a dict of its fields, to see what edited settings give."""
    joints = _natural(obj, *_rest_of(obj), "auto", settings)
    return None if joints is None else copy.deepcopy(joints)  # the cache's own stays as it is


def is_humanoid(obj) -> bool:
    """Whether the bone map recognises a humanoid (the natural defaults apply); cached per rest pose."""
    return ik_defaults.is_humanoid(_labels(obj, *_rest_of(obj)))


def _natural(obj, all_names, rest, natural, settings):
    """The natural defaults for a humanoid (natural "auto" or True), or None."""
    if natural not in ("auto", True, False):
        raise ValueError(f"natural must be 'auto', True or False, not {natural!r}")
    if natural is False:
        return None
    labels = _labels(obj, all_names, rest)
    if not ik_defaults.is_humanoid(labels):
        if natural is True:
            raise ValueError(f"'{obj.name}' is not recognised as a humanoid (hips, spine, arms and legs): "
                             "natural defaults need one")
        return None
    if isinstance(settings, dict):
        settings = ik_defaults.NaturalDefaults.from_dict(settings)
    # Kept per rest pose (heads, tails and each bone's rest frame, so its roll) and settings: the live
    # re-solve runs this on every update.
    key = (tuple(all_names), rest.tobytes(), pose_channels.rest_matrices(obj.data).tobytes(),
           tuple(sorted((settings or ik_defaults.NaturalDefaults()).to_dict().items())))
    if key not in _NATURAL:
        if len(_NATURAL) > 64:
            _NATURAL.clear()
        quats = pose_channels.rest_quaternions(obj.data)
        axes = np.stack([_axes(quats[name]) for name in all_names])
        root = _floor_rooted_hips(obj, all_names, rest) or labels.hips
        _NATURAL[key] = ik_defaults.natural_joints(pose_channels.armature_mapping_rig(obj), labels, axes, settings,
                                                   body_root=root)
    return _NATURAL[key]


def _axes(q) -> np.ndarray:
    """The rotation matrix (columns: X, Y, Z) of a w x y z quaternion."""
    return rotation_channels.rotate(q / np.linalg.norm(q), np.eye(3)).T


def _with_defaults(tables, joints, index, count) -> dict:
    """The solver's per-bone tables (IkJoints' fields) with the natural defaults where the rig sets nothing of
    its own (no IK limit, lock or stiffness on that bone); stages and masses from the defaults."""
    out = dict(tables)
    own_limits = np.zeros(count, dtype=bool)
    if "limit_min" in tables:
        own_limits = (np.isfinite(tables["limit_min"]).any(axis=1) | np.isfinite(tables["limit_max"]).any(axis=1)
                      | tables["locked"].any(axis=1))
    lo, hi = joints.limit_min[index], joints.limit_max[index]
    out["limit_min"] = np.where(own_limits[:, None], tables.get("limit_min", lo), lo)
    out["limit_max"] = np.where(own_limits[:, None], tables.get("limit_max", hi), hi)
    out["soft"] = np.where(own_limits[:, None], False, joints.soft[index])
    stiffness = joints.stiffness[index]
    if "stiffness" in tables:
        own = tables["stiffness"].any(axis=1)
        stiffness = np.where(own[:, None], tables["stiffness"], stiffness)
    out["stiffness"] = np.ascontiguousarray(stiffness)
    out["stage"] = np.ascontiguousarray(joints.stage[index])
    out["mass"] = np.ascontiguousarray(joints.mass[index])
    for key in ("limit_min", "limit_max", "soft"):
        out[key] = np.ascontiguousarray(out[key])
    return out


def _parent_rest(obj, above) -> np.ndarray:
    """The rest orientation of the hips' parent (the last of `above`), w x y z."""
    q = pose_channels.rest_quaternions(obj.data)[above[-1].name]
    return q / np.linalg.norm(q)


def _body_root(obj, all_bones, all_names, part, rest) -> int:
    """The bone whose location carries the body: the hips under a game rig's floor root (Unreal's root
    above pelvis) when every solved bone but the floor root hangs below them, else the top bone."""
    hips_name = _floor_rooted_hips(obj, all_names, rest)
    if hips_name is None:
        return 0
    hips = all_names.index(hips_name)
    above = set(pose_channels.ancestors(all_bones[hips]))
    if all(all_bones[i] in above or pose_channels.is_below(all_bones[i], all_bones[hips]) for i in part):
        return hips
    return 0


def _rig_below(obj, bones):
    """A native Rig of bones (the hips first, then bones below them) at rest in the hips' parent's rest
    frame: posed with the hips' own channels it gives their pose in that parent's posed frame."""
    parent = bones[0].parent
    rest = pose_channels.rest_quaternions(obj.data)
    frame = rotation_channels.conjugate(rest[parent.name] / np.linalg.norm(rest[parent.name]))
    origin = np.array(parent.head_local, dtype=np.float64)
    quats = np.array([rotation_channels.multiply(frame, rest[b.name] / np.linalg.norm(rest[b.name]))
                      for b in bones])
    heads = rotation_channels.rotate(frame, pose_channels.heads(bones) - origin)
    parents = [-1] + pose_channels.parent_indices(bones)[1:]
    return pose_channels.build_rig([b.name for b in bones], parents, quats, heads, [b.length for b in bones]), bones


def _into_parent_frame(obj, above, frames, action, positions, orientations):
    """Armature-space targets (frames, 3E) and (frames, 4E) carried into the posed frame of the hips'
    parent (the last of `above`, the bones from the top down to it) on each frame."""
    native = native_state.native()
    rig, bones = pose_channels.native_rig(obj.data, above)
    if action is None:
        rotations, locations = pose_channels.current_pose(obj, bones)
        rotations, locations = rotations.reshape(1, -1), locations.reshape(1, -1)
    else:
        rotations = pose_channels.rotations(obj, action, bones, frames)
        locations, _ = pose_channels.locations(obj, action, bones, frames)
    posed, heads = native.armature_pose(rig, np.ascontiguousarray(rotations), np.ascontiguousarray(locations))
    q = np.broadcast_to(posed[:, -4:], (frames.size, 4))
    h = np.broadcast_to(heads[:, -3:], (frames.size, 3))
    inverse = rotation_channels.conjugate(q)
    count = positions.shape[1] // 3
    positions = rotation_channels.rotate_each(inverse[:, None, :], positions.reshape(frames.size, count, 3)
                                              - h[:, None, :])
    orientations = rotation_channels.multiply(inverse[:, None, :], orientations.reshape(frames.size, count, 4))
    return positions.reshape(frames.size, -1), orientations.reshape(frames.size, -1)


def _outside_chains(bones, names, effectors) -> np.ndarray:
    """Bones that no effector's chain reaches (True = not solved)."""
    index = {name: i for i, name in enumerate(names)}
    reached = np.zeros(len(bones), dtype=bool)
    for effector in effectors:
        bone, count = bones[index[effector.bone]], 0
        while bone is not None and bone.name in index and (effector.chain_count <= 0 or count < effector.chain_count):
            reached[index[bone.name]] = True
            bone, count = bone.parent, count + 1
    return ~reached


def _channels(plan_: Plan) -> tuple[list, np.ndarray]:
    channels, rows = [], []
    frames = plan_.frames.size
    moved = np.flatnonzero(plan_.moved)
    if moved.size and moved[0] == 0:
        root = plan_.bones[0].name
        channels += [(f"{pose_channels.bone_path(root)}.location", k, root) for k in range(3)]
        rows.append(plan_.root_locations.T)
    if moved.size:
        columns = (4 * moved[:, None] + np.arange(4)).ravel()
        bone_channels, values = pose_channels.rotation_keys(plan_.obj, [plan_.bones[b].name for b in moved],
                                                            plan_.rotations[:, columns])
        channels += bone_channels
        rows.append(values)
    values = np.vstack(rows) if rows else np.empty((0, frames))
    if not np.all(np.isfinite(values)):
        raise ValueError("the IK solution is not finite")
    return channels, values


def apply_pose(plan_: Plan) -> None:
    """Put the plan's first frame on the pose (no keys)."""
    channels, values = _channels(plan_)
    obj = plan_.obj
    for (path, index, _), value in zip(channels, values[:, 0]):
        owner, prop = path.rsplit(".", 1)
        getattr(obj.path_resolve(owner), prop)[index] = value


def apply_keys(plan_: Plan, *, new_action: bool = True, action_name: str | None = None,
               copy: bpy.types.Action | None = None) -> bpy.types.Action:
    """Key the plan's frames on the solved bones: in a new action (a copy of the current one, so that
    the other bones keep their motion: `copy` if the caller made it already) or in the current action.
    A copy made here is removed again on failure; the caller's is the caller's."""
    channels, values = _channels(plan_)
    obj = plan_.obj
    current = animdata.assigned_action(obj)
    if new_action or current is None:
        action = copy
        if action is None:
            action = current.copy() if current is not None else animdata.new_action(action_name or f"{obj.name} IK")
        action.name = action_name or f"{current.name if current else obj.name} IK"
        return animdata.install_action(obj, action,
                                       lambda action: animdata.write_keys(obj, action, channels, plan_.frames, values),
                                       owned=copy is None)
    animdata.write_keys(obj, current, channels, plan_.frames, values)
    return current


def solve(armature, effectors, frame_range=None, method: str = "dls", *, new_action: bool = True, **options):
    """Solve full-body IK; returns a Result (errors per frame and effector, iterations).

    effectors: Effector objects or dicts with their fields. frame_range None
    solves the current frame and poses the armature; (start, end) solves every
    frame (each warm-started from the one before, the armature's action as the
    input pose) and keys the solved bones, in a new action (a copy of the
    current one: the other bones keep their motion) or, with new_action=False,
    in the current action. method: "dls", "pinv", "transpose" or "ccd".
    options: root_translation, root_rotation (default True: the hips may
    move), max_iterations, tolerance (default 3e-7 of the rig's size),
    damping, regularization, use_limits (the bones' IK limits, default True),
    reference ("previous" or "input"), priorities (default True), natural
    ("auto", True or False: a humanoid's natural defaults), balance (None:
    on when a humanoid's feet are pinned), defaults (the natural defaults'
    settings). With natural defaults a frame range is solved twice: the
    second pass starts every frame from the first's corrections low-passed
    over time, so that a target passing in and out of reach does not pop
    (docs/ik.md). A ValueError changes nothing.
    """
    if frame_range is None:
        plan_ = plan(armature, effectors, frame_range, method, **options)
        apply_pose(plan_)
        return plan_.result
    return bake(armature, effectors, frame_range, method, new_action=new_action, **options)[0]


def bake(armature, effectors, frame_range, method: str = "dls", *, new_action: bool = True,
         **options) -> tuple[Result, bpy.types.Action]:
    """Solve every frame of frame_range and key the solved bones (see solve); returns the Result and
    the action keyed. A ValueError changes nothing."""
    current = animdata.assigned_action(armature) if isinstance(armature, bpy.types.Object) else None
    copies = []

    def copy_current():
        # Blender's own copy of the clip, made while the native solve runs.
        copies.append(current.copy())

    try:
        plan_ = plan(armature, effectors, frame_range, method,
                     alongside=copy_current if new_action and current is not None else None, **options)
        action = apply_keys(plan_, new_action=new_action, copy=copies[0] if copies else None)
    except BaseException:
        for made in copies:
            bpy.data.actions.remove(made)
        raise
    return plan_.result, action
