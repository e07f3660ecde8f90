"""Retarget onto a control rig's controls (Rigify's or any rig a control rig map describes).

The motion is first retargeted onto the rig's deform skeleton (the map's
deform bones, seen as a rig of their own: deform_rig), by the same
engine as any retarget (proportions, facing, root motion, planted feet). Each
control is then keyed so that it stands where it stood at rest relative to the
deform bone it drives; IK limbs get their effector from the limb's end bone and
a pole in the plane of the limb. How each control's parent moves (Rigify puts
mechanism bones with constraints between controls) is measured once per
retarget: the rig is posed in a few random poses and evaluated by Blender
(core/control_rig.fit_relation), never frame by frame; a parent that no single
known bone carries (Rigify's middle neck tweak hangs from a bone stretched to the
head) is modelled from its own parents and constraints (core/control_rig.Mechanism)
and kept only if the model reproduces Blender's evaluation of those poses. The
limb's other mode is keyed too, so that flipping the IK/FK switch in the rig's own
UI keeps the pose.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field

import bpy
import mathutils
import numpy as np

from . import contacts
from ..blender import animdata, pose_channels
from ..core import control_rig, native_state
from ..core.control_rig import ControlRigMap
from ..core.rig_data import RigData

KEYS = (
    ("every", "Every Frame", "A key on every frame of the range"),
    ("source", "Source Keys", "Keys only on the frames where the source has keys"),
)
_SAMPLES = 4          # calibration poses besides the rest pose
_CALIBRATION_ANGLE = 0.6  # radians, the random poses' largest turn
_SEED = 1907
_UNKEYED_MOVE = 1e-4  # times the rig's size: a rotation-only control's translation that a map must not need


# ---------------------------------------------------------------------------
# The deform skeleton as a rig of its own

def _deform_parents(obj, rig_map: ControlRigMap, names: set) -> dict:
    """Each deform bone's parent in the skeleton: the map's, else its nearest ancestor among the deform
    bones (through the rig's mechanism bones), None for a root."""
    real, parents = obj.data.bones, {}
    for entry in rig_map.skeleton:
        parent = entry.parent
        if parent is None and not entry.root:
            above = real[entry.bone].parent
            while above is not None and above.name not in names:
                above = above.parent
            parent = above.name if above is not None else None
        if parent is not None and parent not in names:
            raise ValueError(f"control rig '{rig_map.id}': the parent '{parent}' of '{entry.bone}' is not in its "
                             "skeleton")
        parents[entry.bone] = parent
    return parents


def _parents_first(order: list, parents: dict) -> list:
    """The bones depth first (roots and children in the map's order), as Blender lists an armature's."""
    children = {name: [n for n in order if parents[n] == name] for name in order}
    out, stack, seen = [], [n for n in reversed(order) if parents[n] is None], set()
    while stack:
        name = stack.pop()
        if name in seen:  # a cycle among the given parents
            raise ValueError(f"control rig map: the bone '{name}' is its own ancestor")
        seen.add(name)
        out.append(name)
        stack.extend(reversed(children[name]))
    if len(out) != len(order):
        raise ValueError(f"control rig map: the bones {sorted(set(order) - set(out))} hang from no root")
    return out


def deform_rig(obj, rig_map: ControlRigMap) -> RigData:
    """A control rig's deform bones as a rig of their own (plain data, core.rig_data): the map's parents and
    tails where the rig's own hierarchy goes through mechanism bones; everything else is obj's (its name,
    placement, each bone's rest orientation and head)."""
    real = obj.data.bones
    missing = [s.bone for s in rig_map.skeleton if s.bone not in real]
    if missing:
        raise ValueError(f"'{obj.name}' lacks the deform bones {missing} of control rig '{rig_map.id}'")
    tails = {}
    for entry in rig_map.skeleton:
        if entry.tail and entry.tail not in real:
            raise ValueError(f"control rig '{rig_map.id}': the tail bone '{entry.tail}' is not in '{obj.name}'")
        bone = real[entry.bone]
        tail = real[entry.tail].head_local if entry.tail else bone.tail_local
        axis = bone.matrix_local.to_3x3().col[1]
        if (tail - bone.head_local).length < 1e-9 or axis.angle(tail - bone.head_local) > np.radians(1.0):
            raise ValueError(f"control rig '{rig_map.id}': '{entry.bone}' does not point at its tail "
                             f"'{entry.tail}'")
        tails[entry.bone] = np.array(tail, dtype=np.float64)
    parents = _deform_parents(obj, rig_map, set(tails))
    order = _parents_first(list(tails), parents)
    where = {name: i for i, name in enumerate(order)}
    whole = pose_channels.read_rig(obj, [real[name] for name in order])
    tail_points = np.array([tails[name] for name in order])
    parent = [where[parents[name]] if parents[name] is not None else -1 for name in order]
    lengths = np.linalg.norm(tail_points - whole.heads, axis=1)
    # A head on its parent's tail: the parent's tail as the map sets it.
    connected = [p >= 0 and np.linalg.norm(whole.heads[i] - tail_points[p]) < 1e-6 * max(lengths[p], 1e-3)
                 for i, p in enumerate(parent)]
    return RigData(obj.name, tuple(order), tuple(parent), whole.rest, whole.heads, tail_points, lengths,
                   tuple(connected), whole.world, whole.world_rotation, whole.world_scale, whole.floor, whole.channels)


# ---------------------------------------------------------------------------
# Recognising a control rig

def _armature_keys(obj) -> list:
    return list(obj.data.keys())


def find_map(obj, control_map=None) -> ControlRigMap | None:
    """The control rig map for obj: control_map (a map, a JSON file path or a preset id), else the shipped
    preset obj is recognised as, else None. A generator's metarig (Rigify's) raises ValueError saying to
    generate the rig first."""
    if obj is None or getattr(obj, "type", None) != 'ARMATURE':
        raise ValueError(f"the target '{getattr(obj, 'name', obj)}' is not an armature object")
    if isinstance(control_map, ControlRigMap):
        rig_map = control_map
    elif isinstance(control_map, (str, os.PathLike)) and os.fspath(control_map) in control_rig.presets():
        rig_map = control_rig.presets()[os.fspath(control_map)]
    elif isinstance(control_map, (str, os.PathLike)):
        rig_map = control_rig.load(control_map)
    elif isinstance(control_map, dict):
        rig_map = control_rig.parse(control_map)
    elif control_map is None:
        rig_map = control_rig.detect([b.name for b in obj.data.bones], _armature_keys(obj))
        if rig_map is None:
            # A generator's property on the pose bones: an ID property, or (Rigify in 4.x and 5.x) an RNA one.
            wanted = {m.metarig_property for m in control_rig.presets().values() if m.metarig_property}
            props = {k for pb in obj.pose.bones for k in wanted if k in pb.keys() or getattr(pb, k, None)}
            meta = control_rig.metarig_of(props)
            if meta is not None:
                raise ValueError(f"'{obj.name}' {meta.metarig_message}")
            return None
    else:
        raise ValueError(f"control_map must be a map, a JSON file or a preset id, not {control_map!r}")
    missing = rig_map.missing(b.name for b in obj.data.bones)
    if missing:
        shown = ", ".join(missing[:8]) + (f" and {len(missing) - 8} more" if len(missing) > 8 else "")
        raise ValueError(f"'{obj.name}' lacks bones that control rig '{rig_map.id}' names: {shown}"
                         + (f" ({rig_map.path})" if rig_map.path else ""))
    return rig_map


def describe(obj, control_map=None) -> str:
    """What kind of rig obj is, for the panel: a control rig's label, a metarig, or bones."""
    try:
        rig_map = find_map(obj, bpy.path.abspath(control_map) if control_map else None)
    except ValueError as error:
        return "Metarig: generate it first" if "metarig" in str(error) else "Control map does not fit"
    return f"{rig_map.label} (controls)" if rig_map else "Bones (no control rig)"


# ---------------------------------------------------------------------------
# Measuring the rig

def _property(obj, bone, prop):
    pose_bone = obj.pose.bones[bone]
    if prop not in pose_bone.keys():
        raise ValueError(f"'{obj.name}': the control '{bone}' has no property '{prop}'")
    return pose_bone[prop]


@dataclass
class _Layout:
    """What the retarget keys on the rig: controls with their deform bones, poles, bones at rest, and the
    properties with their values."""
    driven: dict = field(default_factory=dict)     # control -> deform bone
    located: set = field(default_factory=set)      # controls keyed with their location
    poles: dict = field(default_factory=dict)      # pole control -> limb
    rest: list = field(default_factory=list)       # controls keyed at rest
    settings: list = field(default_factory=list)   # (bone, property, value)
    modes: dict = field(default_factory=dict)      # limb -> "fk" | "ik"


def _layout(rig_map: ControlRigMap, modes: dict, posed: set) -> _Layout:
    out = _Layout(modes=modes)
    for c in rig_map.controls:
        if c.bone in posed:
            out.driven[c.control] = c.bone
            if c.location:
                out.located.add(c.control)
    for limb in rig_map.limbs:
        if not set(limb.chain) <= posed:
            continue
        for c in limb.fk + limb.ik:
            if c.bone in posed:
                out.driven[c.control] = c.bone
                if c.location:
                    out.located.add(c.control)
        if limb.pole:
            out.poles[limb.pole] = limb
        out.rest += list(limb.ik_rest)
        if limb.switch:
            out.settings.append((limb.switch.bone, limb.switch.property,
                                 limb.switch.ik if modes[limb.name] == "ik" else limb.switch.fk))
        out.settings += [(p.bone, p.property, p.value) for p in limb.properties]
    out.rest = list(dict.fromkeys(n for n in list(rig_map.rest) + out.rest if n not in out.driven))
    out.settings = [(p.bone, p.property, p.value) for p in rig_map.properties] + out.settings
    return out


_MODELLED = {'STRETCH_TO', 'COPY_ROTATION', 'COPY_SCALE'}


def _steps(obj, pose_bone) -> tuple:
    """(steps, why): the bone's constraints as control_rig.Step, in order (muted ones and those at no
    influence left out), or why one cannot be modelled. pose_bone: the evaluated rig's (driven influences)."""
    steps = []
    for con in pose_bone.constraints:
        if con.mute or con.influence <= 0.0:
            continue
        here = f"'{pose_bone.name}' has a {con.type.replace('_', ' ').title()} constraint '{con.name}'"
        if con.type not in _MODELLED or getattr(con, "target", None) is None or \
                con.target.name != obj.name or not con.subtarget:
            return (), f"{here} that MotionKit does not model"
        if con.type == 'STRETCH_TO':
            if con.keep_axis != 'SWING_Y' or con.use_bulge_min or con.use_bulge_max or con.use_bbone_shape or \
                    con.rest_length <= 0.0 or con.volume not in control_rig.VOLUMES:
                return (), f"{here} with settings MotionKit does not model (it models Swing Y, no bulge limits)"
            length = obj.data.bones[con.subtarget].length
            steps.append(control_rig.Step("stretch_to", con.subtarget, con.influence, con.head_tail * length,
                                          con.rest_length, con.volume, con.bulge))
        elif con.type == 'COPY_ROTATION':
            if (con.owner_space, con.target_space) != ('LOCAL', 'LOCAL') or con.mix_mode != 'REPLACE' or \
                    not (con.use_x and con.use_y and con.use_z) or con.invert_x or con.invert_y or con.invert_z:
                return (), f"{here} that is not local to local, Replace, on every axis"
            steps.append(control_rig.Step("copy_local_rotation", con.subtarget, con.influence))
        else:
            if (con.owner_space, con.target_space) != ('WORLD', 'WORLD') or con.use_offset or con.use_add or \
                    con.use_make_uniform or con.power != 1.0 or not (con.use_x and con.use_y and con.use_z):
                return (), f"{here} that is not world to world, on every axis, without offset"
            steps.append(control_rig.Step("copy_scale", con.subtarget, con.influence))
    return tuple(steps), ""


def _mechanism(obj, name, known, controls, steps_of, stack, size, depth=0):
    """(control_rig.Mechanism or None, why) for the bone name from its parent (a known bone, one a Relation
    fits, or a mechanism again, a few levels up) and its constraints (steps_of: name -> (steps, why))."""
    bone = obj.data.bones[name]
    if depth > 3:
        return None, f"'{name}' hangs from too many mechanism bones"
    if not bone.use_inherit_rotation or bone.inherit_scale not in ('FULL', 'NONE') or not bone.use_local_location:
        return None, f"'{name}' inherits its parent's transform in a way MotionKit does not model"
    steps, why = steps_of.get(name, ((), ""))
    if why:
        return None, why
    for step in steps:
        if step.target not in (controls if step.kind == "copy_local_rotation" else known):
            return None, f"'{name}' follows '{step.target}', which this retarget does not key or pose"
    rest = np.array(bone.matrix_local, dtype=np.float64)
    parent, node = bone.parent, None
    if parent is not None:
        rest = np.linalg.inv(np.array(parent.matrix_local, dtype=np.float64)) @ rest
        node = parent.name
        if parent.name not in known:
            node, _ = control_rig.fit_relation(stack(parent.name), {k: stack(k) for k in known}, size)
            if node is None:
                node, why = _mechanism(obj, parent.name, known, controls, steps_of, stack, size, depth + 1)
                if node is None:
                    return None, why
    return control_rig.Mechanism(name, node, rest, bone.inherit_scale == 'FULL', steps), ""


def _calibrate(obj, rig_map, layout: _Layout, deform: list, size: float) -> dict:
    """Each keyed control's parent's Relation (or Mechanism), measured in Blender's own evaluation of the rig
    posed at rest and in a few random poses (with the layout's properties), and the evaluated rest pose
    ({bone: (4, 4)}: a deform bone copying a control that is rolled against it stands rolled there); the rig's
    pose and properties are put back."""
    if obj.name not in bpy.context.view_layer.objects:
        raise ValueError(f"'{obj.name}' is not in the view layer, so Blender does not evaluate it: include its "
                         "collection and retarget again")
    if obj.mode == 'EDIT':
        raise ValueError(f"'{obj.name}' is in Edit Mode: leave it (Object or Pose Mode) and retarget again")
    moving = list(layout.driven) + list(layout.poles)
    samples, bases, steps_of = _evaluate_poses(obj, rig_map, layout, moving, size)
    return _fit_relations(obj, moving, deform, samples, bases, steps_of, size), samples[0]


def _evaluate_poses(obj, rig_map, layout: _Layout, moving: list, size: float):
    """(samples, bases, steps_of): the armature matrices of every pose bone (pose_channels.pose_matrices) as
    Blender evaluates the rig at rest and in _SAMPLES random poses of the moving controls, each moving
    control's basis in each pose, and the constraints of the bones above them (_steps) as evaluated at rest."""
    pose = obj.pose.bones
    touched = moving + layout.rest
    saved = {n: pose[n].matrix_basis.copy() for n in touched}
    saved_props = [(b, p, _property(obj, b, p)) for b, p, _ in layout.settings]
    rng = np.random.default_rng(_SEED)
    samples, bases, steps_of = [], {name: [] for name in moving}, {}
    above = {p.name for name in moving for p in pose[name].parent_recursive}  # where a mechanism may be
    # The random poses reach beyond the limbs: a limb's no-stretch setting would clamp its IK target there
    # (a Limit Distance in Rigify) and hide how the target follows its control when in reach; calibration
    # stretches.
    reach = {(limb.ik_stretch.bone, limb.ik_stretch.property) for limb in rig_map.limbs if limb.ik_stretch}
    # The rig's own action would put its keyed values back on every evaluation: it stands aside meanwhile.
    playing = animdata.assigned_action(obj)
    if playing is not None:
        obj.animation_data.action = None
    try:
        for b, p, value in layout.settings:
            # A no-stretch setting at its "stretch" end (the driver's factor times 1, as generated).
            pose[b][p] = type(pose[b][p])(1 if (b, p) in reach else value)
        # Writing an ID property tags nothing: the drivers that read it (Rigify's switches) are evaluated
        # again only when the object's animation is tagged.
        obj.update_tag(refresh={'OBJECT', 'DATA', 'TIME'})
        for s in range(_SAMPLES + 1):
            for name in touched:
                pose[name].matrix_basis = _random_basis(rng, layout, name, size) if s and name in moving \
                    else mathutils.Matrix.Identity(4)
            bpy.context.view_layer.update()
            samples.append(pose_channels.pose_matrices(obj))
            for name in moving:
                bases[name].append(np.array(pose[name].matrix_basis, dtype=np.float64))
            if s == 0:  # the constraints as evaluated with the layout's properties (their drivers)
                evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).pose.bones
                steps_of = {n: _steps(obj, evaluated[n]) for n in above}
    finally:
        if playing is not None:
            animdata.assign(obj, playing)
        for name, m in saved.items():
            pose[name].matrix_basis = m
        for b, p, value in saved_props:
            pose[b][p] = value
        obj.update_tag(refresh={'OBJECT', 'DATA', 'TIME'})
        bpy.context.view_layer.update()
    return samples, bases, steps_of


def _random_basis(rng, layout: _Layout, name: str, size: float):
    """A random turn of up to _CALIBRATION_ANGLE, and for a located control or pole a random move within a
    twentieth of the rig's size."""
    axis = rng.normal(size=3)
    turn = mathutils.Quaternion(axis / np.linalg.norm(axis), rng.uniform(0.2, 1) * _CALIBRATION_ANGLE)
    m = turn.to_matrix().to_4x4()
    if name in layout.located or name in layout.poles:
        m.translation = rng.uniform(-0.05, 0.05, size=3) * size
    return m


def _fit_relations(obj, moving, deform, samples, bases, steps_of, size) -> dict:
    """Each moving control's parent's Relation (or Mechanism, checked on the poses), fitted to the samples."""
    pose = obj.pose.bones
    stack = lambda name: np.array([s[name] for s in samples])  # noqa: E731
    candidates = {n: stack(n) for n in deform}
    candidates.update({n: stack(n) for n in moving})
    relations = {}
    for name in moving:
        parent = pose[name].parent
        if parent is None:
            relations[name] = None
            continue
        others = {k: v for k, v in candidates.items() if k != name}
        relation, why = control_rig.fit_relation(stack(parent.name), others, size)
        if relation is None and "scaled" not in why:
            # No single bone carries the parent: its own parents and constraints may (checked on the poses).
            relation, modelled = _mechanism(obj, parent.name, set(others), set(moving) - {name}, steps_of,
                                            stack, size)
            if relation is not None:
                modelled = control_rig.check_mechanism(relation, stack(parent.name), stack,
                                                       lambda n: np.array(bases[n]), size)
                relation = None if modelled else relation
            why += f"; {modelled}" if modelled else ""
        if relation is None:
            raise ValueError(f"'{obj.name}': the control '{name}' hangs from '{parent.name}', and {why}; "
                             "set the rig's follow/parent switches to a plain value (0 or 1) and retarget again")
        relations[name] = relation
    return relations


# ---------------------------------------------------------------------------
# The plan

@dataclass
class ControlPlan:
    """A retarget onto controls, computed before anything is written."""
    target: bpy.types.Object
    rig_map: ControlRigMap
    modes: dict                  # limb -> "fk" | "ik"
    frames: np.ndarray
    channels: list
    values: np.ndarray           # (channels, frames)
    rest_channels: list
    rest_values: np.ndarray      # (rest channels, 1): controls at rest and the properties
    deform: object               # retargeting.Plan: the retarget onto the deform skeleton
    keyed: list                  # the controls keyed every frame
    feet: list | None = None     # contacts.Foot per side, the foot being the control its contacts live on

    @property
    def source_name(self):
        return self.deform.source_name


def _source_key_frames(source, frames) -> np.ndarray:
    """Which of frames (a bool mask) hold a key on any of the source action's curves."""
    action = animdata.assigned_action(source)
    found = set()
    for fcurve in animdata.fcurves(action, source):
        found.update(np.round(animdata.read_keys(fcurve)[0]).astype(int).tolist())
    return np.isin(np.round(frames).astype(int), sorted(found))


def plan(source, target, deform_plan, *, controls: str = "auto", limbs=None, control_map=None,
         keys: str = "every", progress=None):
    """A ControlPlan, or None when target is not a control rig (and controls is "auto"). deform_plan(rig):
    the retarget onto the rig's deform skeleton, rig (deform_rig: retargeting.plan with target_rig=rig and
    the retarget's options; a bone map then pairs source bones with the deform skeleton's)."""
    if keys not in [k[0] for k in KEYS]:
        raise ValueError(f"keys must be one of {[k[0] for k in KEYS]}, not {keys!r}")
    rig_map = find_map(target, control_map)
    if rig_map is None:  # limb kinds ("arm", "leg") are preferences for a control rig, if there is one
        if controls in ("fk", "ik") or set(limbs or ()) - {"arm", "leg", "other"}:
            raise ValueError(f"'{target.name}' is not a control rig MotionKit knows (no preset matches; "
                             "give a control rig map)")
        return None
    modes = control_rig.limb_modes(rig_map, controls, limbs)
    native = native_state.native()
    skeleton = deform_rig(target, rig_map)
    if source is target:
        raise ValueError(f"the source and the target are the same armature '{target.name}' (a cycle)")
    deform_plan = deform_plan(skeleton)
    deform_plan.resolve()
    if progress:
        progress(1, 4)
    deform_world = _deform_worlds(native, skeleton, deform_plan)
    mapped = {tgt for _, tgt in deform_plan.pairs}
    posed = set(mapped)
    for name in mapped:  # bones between the hips and a mapped bone are posed too
        posed.update(skeleton.names[b] for b in skeleton.ancestors(skeleton.index(name)))
    layout = _layout(rig_map, modes, posed)
    size = float(skeleton.lengths.max()) * 4 or 1.0
    relations, standing = _calibrate(target, rig_map, layout, [n for n in deform_world if n in posed], size)
    if progress:
        progress(2, 4)
    bases = _solve(target, rig_map, layout, relations, standing, deform_world, size)
    keyed = [n for n in target.pose.bones.keys() if n in bases]  # the rig's bone order
    channels, values = _channels(target, layout, bases, keyed)
    frames = deform_plan.frames
    if keys == "source":
        keep = _source_key_frames(source, frames)
        frames, values = frames[keep], values[:, keep]
    rest_channels, rest_values = _rest_keys(target, layout)
    if not (np.all(np.isfinite(values)) and np.all(np.isfinite(rest_values))):
        raise ValueError("the controls' keys are not finite; check the rig's rest pose")
    if progress:
        progress(3, 4)
    result = ControlPlan(target, rig_map, modes, frames, channels, values, rest_channels, rest_values,
                         deform_plan, keyed)
    if deform_plan.contacts is not None:
        result.feet = _control_feet(result)
    return result


def _deform_worlds(native, skeleton: RigData, deform_plan) -> dict:
    """The deform skeleton's armature-space matrices (frames, 4, 4) by bone, as the retarget posed it."""
    rig = skeleton.native
    rotations, locations = deform_plan.pose
    world_rot, world_heads = native.armature_pose(rig, np.ascontiguousarray(rotations),
                                                  np.ascontiguousarray(locations))
    return {name: control_rig.matrices(world_rot[:, 4 * i:4 * i + 4], world_heads[:, 3 * i:3 * i + 3])
            for i, name in enumerate(skeleton.names)}


def _solve(target, rig_map, layout, relations, standing, deform_world, size) -> dict:
    """Each keyed control's basis matrices (frames, 4, 4), parents first."""
    rest = {b.name: np.array(b.matrix_local, dtype=np.float64) for b in target.data.bones}
    # The retarget poses each deform bone from its rest; the rig may stand it otherwise with its controls at
    # rest (a Copy Transforms from a control rolled against it): the relations were measured on the latter.
    deform_world = {n: m @ (np.linalg.inv(rest[n]) @ standing[n]) if n in standing else m
                    for n, m in deform_world.items()}
    frames_n = next(iter(deform_world.values())).shape[0]
    controls = list(layout.driven) + list(layout.poles)
    top = [c for c in controls if relations[c] is None]  # no parent: the armature's frame
    ordered = top + control_rig.order({c: relations[c] for c in controls if relations[c] is not None},
                                      set(deform_world))
    worlds, bases = dict(deform_world), {}
    for name in ordered:
        relation = relations[name]
        if relation is None:
            frame, offset = np.repeat(np.eye(4)[None], frames_n, axis=0), rest[name]
        else:
            frame = relation.evaluate(lambda n: worlds[n], frames_n, lambda n: bases[n])
            offset = np.linalg.inv(rest[target.pose.bones[name].parent.name]) @ rest[name]
        if name in layout.poles:
            world = _pole_world(layout.poles[name], deform_world, standing, name, frame @ offset)
        else:  # where the control stands, relative to its deform bone, when the rig stands at rest
            bone = layout.driven[name]
            world = deform_world[bone] @ (np.linalg.inv(standing[bone]) @ standing[name])
        worlds[name] = world
        bases[name] = control_rig.basis(frame, offset, world, target.data.bones[name].use_local_location)
        moved = float(np.max(np.linalg.norm(bases[name][:, :3, 3], axis=1)))
        if name not in layout.located and name not in layout.poles and moved > _UNKEYED_MOVE * size:
            raise ValueError(f"control rig '{rig_map.id}': the control '{name}' would have to move by "
                             f"{moved * 1000:.1f} mm to put '{layout.driven[name]}' in place, but the map keys only "
                             "its rotation; mark it \"location\": true, or drive the control it hangs from with "
                             "the bone next to it")
    return bases


def _channels(target, layout, bases, keyed):
    """(channels, values (channels, frames)): the located controls' locations, every control's rotation in
    its own rotation mode."""
    channels, rows = [], []
    for name in keyed:
        if name in layout.located or name in layout.poles:
            channels += [(f"{pose_channels.bone_path(name)}.location", k, name) for k in range(3)]
            rows.append(bases[name][:, :3, 3].T)
    more, values = pose_channels.rotation_keys(target, keyed,
                                               np.hstack([control_rig.quaternions(bases[n]) for n in keyed]))
    return channels + more, np.vstack(rows + [values])


def _pole_world(limb, deform_world, rest, pole, parent_frame) -> np.ndarray:
    """The pole's armature matrices: its parent's rotation (a basis without rotation), its head in the plane
    of the limb at its rest distance from the middle joint."""
    upper, lower, end = (deform_world[n] for n in limb.chain)
    rest_lower = rest[limb.chain[1]]
    rest_pole = rest[pole][:3, 3]
    distance = float(np.linalg.norm(rest_pole - rest_lower[:3, 3]))
    # Where the pole stood at rest, carried by the upper bone: the plane for a straight limb.
    carried = upper @ (np.linalg.inv(rest[limb.chain[0]]) @ np.append(rest_pole, 1.0))
    lower_head = lower[:, :3, 3]
    fallback = carried[:, :3] - lower_head
    heads = control_rig.pole_positions(upper[:, :3, 3], lower_head, end[:, :3, 3], fallback, distance)
    world = parent_frame.copy()
    world[:, :3, 3] = heads
    return world


def _rest_keys(target, layout: _Layout):
    """One key each: the controls held at rest (location and rotation) and the properties set."""
    channels = [(f"{pose_channels.bone_path(name)}.location", k, name) for name in layout.rest for k in range(3)]
    values = [[0.0]] * len(channels)
    if layout.rest:
        more, rotations = pose_channels.rotation_keys(target, layout.rest,
                                                      np.tile([1.0, 0.0, 0.0, 0.0], (1, len(layout.rest))))
        channels += more
        values += rotations.tolist()
    for bone, prop, value in layout.settings:
        path = f'{pose_channels.bone_path(bone)}["{bpy.utils.escape_identifier(prop)}"]'
        channels.append((path, 0, bone))
        values.append([float(value)])
    return channels, np.array(values, dtype=np.float64).reshape(-1, 1)


def apply(plan_: ControlPlan, *, action_name: str | None = None, overwrite: bool = False):
    """Write the controls' keys: a new action on the rig (or its own with overwrite)."""
    target = plan_.target
    deform = plan_.deform

    def write(action):
        for limb in plan_.rig_map.limbs:
            if limb.ik_stretch is not None and limb.name in plan_.modes:
                _drive_ik_stretch(target, limb.ik_stretch)
        animdata.write_keys(target, action, plan_.channels, plan_.frames, plan_.values)
        animdata.write_keys(target, action, plan_.rest_channels, plan_.frames[:1], plan_.rest_values)
        if deform.contacts is not None:  # on the feet's controls, where the animator keys
            contacts.write_contacts(target, action, plan_.feet, deform.frames, deform.contacts)
        carried = deform.carried
        if carried is not None and carried.channels:  # the object's own properties (retarget_channels)
            animdata.write_keys(target, action, carried.channels, deform.frames, carried.values)
        if deform.object_base is not None:  # root motion onto the object: its keys, beside the controls'
            rows = [r for r, channel in enumerate(deform.channels) if not channel[0].startswith("pose.bones")]
            animdata.write_keys(target, action, [deform.channels[r] for r in rows], deform.frames,
                                deform.values[rows])
            deform.object_base.record(action)
        animdata.record_frame_rate(action, deform.frame_rate)

    previous = animdata.assigned_action(target)
    if overwrite and previous is not None:
        write(previous)
        return previous
    return animdata.install_action(target, animdata.new_action(action_name or f"{plan_.source_name} -> {target.name}"),
                                   write)


def _drive_ik_stretch(obj, stretch) -> None:
    """A driver on each IK chain bone's ik_stretch: factor * the control's property (unless one is there)."""
    prop_path = f'{pose_channels.bone_path(stretch.bone)}["{bpy.utils.escape_identifier(stretch.property)}"]'
    for bone in stretch.bones:
        path = f"{pose_channels.bone_path(bone)}.ik_stretch"
        if obj.animation_data is not None and obj.animation_data.drivers.find(path) is not None:
            continue
        fcurve = obj.pose.bones[bone].driver_add("ik_stretch")
        for modifier in list(fcurve.modifiers):
            fcurve.modifiers.remove(modifier)
        driver = fcurve.driver
        driver.type = 'SCRIPTED'
        variable = driver.variables.new()
        variable.name = "stretch"
        variable.targets[0].id = obj
        variable.targets[0].data_path = prop_path
        driver.expression = f"{stretch.factor!r} * stretch"


def _control_feet(plan_: ControlPlan) -> list:
    """The deform plan's feet, each on the control that keys its foot (a limb's IK one in IK, else its FK
    one, else the control the map pairs with the foot), so that the contact curves sit on a control."""
    rig_map = plan_.rig_map
    feet = []
    for foot in plan_.deform.feet:
        drivers = [c.control for c in rig_map.controls if c.bone == foot.foot]
        for limb in rig_map.limbs:
            if foot.foot in limb.chain and limb.name in plan_.modes:
                group = limb.ik if plan_.modes[limb.name] == "ik" else limb.fk
                drivers = [c.control for c in group if c.bone == foot.foot] + drivers
        if not drivers:
            raise ValueError(f"control rig '{rig_map.id}': no control drives the foot '{foot.foot}', so its "
                             "contacts have no control to live on; pair one with it or retarget with "
                             "plant_feet=False")
        feet.append(contacts.Foot(foot.side, foot.thigh, foot.shin, drivers[0], foot.toe))
    return feet
