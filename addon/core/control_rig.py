"""Control rigs: which controls drive which deform bones, and the controls' keys from a deform pose (no bpy).

Animators key a control rig (Rigify's, Auto-Rig Pro's, a studio's own), whose
deform bones follow the controls through constraints. A control rig map (JSON,
format "motionkit-control-rig", presets in presets/control_rigs/) says:

- skeleton: the deform bones the retarget poses, with a parent and a tail where
  the armature's own hierarchy does not give them (Rigify's limbs are split in
  segments whose first one stands for the whole bone);
- controls: control <-> deform bone pairs: each control is keyed so that it
  stands where it stood at rest relative to its deform bone;
- limbs: per limb FK controls, IK controls with a pole, the IK/FK switch
  property and its two values, controls held at rest in IK;
- rest: controls keyed at rest; properties: control properties set (and keyed)
  so that the rig's chain is plain FK.

How a control's parent moves is not read from the rig's constraints but
measured (features/control_rigs.py poses the rig in a few random poses and
lets Blender evaluate it): fit_relation finds the known bone (a deform bone or
another control) that the parent follows rigidly, or whose rotation it takes
while following another's position (a Copy Rotation). solve_bases then gives
each control the basis that puts it at its target, parents first.
"""
from __future__ import annotations

import functools
import json
import os
from dataclasses import dataclass

import numpy as np

FORMAT = "motionkit-control-rig"
PRESETS_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "presets", "control_rigs")
MODES = ("fk", "ik")
# A relation holds when every calibration pose agrees within these (Blender evaluates in single precision).
ANGLE_TOLERANCE = 1e-3      # radians
DISTANCE_TOLERANCE = 1e-4   # times the rig's size


@dataclass(frozen=True)
class Control:
    control: str
    bone: str
    location: bool = False


@dataclass(frozen=True)
class Setting:
    bone: str
    property: str
    value: float


@dataclass(frozen=True)
class Switch:
    bone: str
    property: str
    fk: float
    ik: float


@dataclass(frozen=True)
class Stretch:
    """The IK chain's bones whose IK stretch a control's property drives (factor * property), so that the
    rig's own "no stretch" setting lets Blender's IK bend the limb as captured instead of shortening it."""
    bones: tuple[str, ...]
    bone: str
    property: str
    factor: float


@dataclass(frozen=True)
class Limb:
    name: str
    kind: str
    chain: tuple[str, str, str]
    fk: tuple[Control, ...]
    ik: tuple[Control, ...] = ()
    pole: str | None = None
    ik_rest: tuple[str, ...] = ()
    switch: Switch | None = None
    properties: tuple[Setting, ...] = ()
    ik_stretch: Stretch | None = None


@dataclass(frozen=True)
class SkeletonBone:
    bone: str
    parent: str | None = None   # None: the armature's own hierarchy decides
    tail: str | None = None     # a bone whose head is this one's tail; None: its own tail
    root: bool = False          # "parent": null given: a top bone of the skeleton


@dataclass(frozen=True)
class ControlRigMap:
    id: str
    label: str
    skeleton: tuple[SkeletonBone, ...]
    controls: tuple[Control, ...]
    limbs: tuple[Limb, ...] = ()
    rest: tuple[str, ...] = ()
    properties: tuple[Setting, ...] = ()
    detect_property: str | None = None
    detect_bones: tuple[str, ...] = ()
    metarig_property: str | None = None
    metarig_message: str = ""
    notes: str = ""
    path: str = ""

    def bones_named(self) -> list[str]:
        """Every bone the map names, controls and deform bones alike, each once."""
        names = [s.bone for s in self.skeleton] + list(self.rest)
        names += [c.control for c in self.controls] + [c.bone for c in self.controls]
        names += [p.bone for p in self.properties]
        for limb in self.limbs:
            names += list(limb.chain) + [c.control for c in limb.fk + limb.ik] + [c.bone for c in limb.fk + limb.ik]
            names += list(limb.ik_rest) + ([limb.pole] if limb.pole else [])
            names += ([limb.switch.bone] if limb.switch else []) + [p.bone for p in limb.properties]
            names += list(limb.ik_stretch.bones) + [limb.ik_stretch.bone] if limb.ik_stretch else []
        return list(dict.fromkeys(names))

    def missing(self, bone_names) -> list[str]:
        have = set(bone_names)
        return [n for n in self.bones_named() if n not in have]

    def limb(self, name: str) -> Limb:
        for limb in self.limbs:
            if limb.name == name:
                return limb
        raise ValueError(f"control rig '{self.id}' has no limb '{name}' (it has {[b.name for b in self.limbs]})")


# ---------------------------------------------------------------------------
# Reading and checking maps

def _bad(where: str, why: str):
    raise ValueError(f"{where}: not a valid {FORMAT} map: {why}")


def _name(where, data, key, optional=False):
    value = data.get(key)
    if value is None and optional:
        return None
    if not isinstance(value, str) or not value:
        _bad(where, f'"{key}" must be a bone name (a non-empty string), not {value!r}')
    return value


def _object(where, data, what):
    if not isinstance(data, dict):
        _bad(where, f"{what} must be an object, not {data!r}")
    return data


def _list(where, data, key):
    value = data.get(key, [])
    if not isinstance(value, list):
        _bad(where, f'"{key}" must be a list')
    return value


def _names(where, data, key):
    values = _list(where, data, key)
    if not all(isinstance(v, str) and v for v in values):
        _bad(where, f'"{key}" must be a list of bone names')
    return tuple(values)


def _number(where, data, key):
    value = data.get(key)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        _bad(where, f'"{key}" must be a finite number, not {value!r}')
    return value


def _control(where, data) -> Control:
    data = _object(where, data, "a control")
    unknown = set(data) - {"control", "bone", "location"}
    if unknown:
        _bad(where, f"unknown key(s) {sorted(unknown)} in control {data!r}")
    location = data.get("location", False)
    if not isinstance(location, bool):
        _bad(where, f'"location" must be true or false in control {data!r}')
    return Control(_name(where, data, "control"), _name(where, data, "bone"), location)


def _setting(where, data) -> Setting:
    data = _object(where, data, "a property")
    return Setting(_name(where, data, "bone"), _name(where, data, "property"), _number(where, data, "value"))


def _limb(where, data) -> Limb:
    data = _object(where, data, "a limb")
    unknown = set(data) - {"name", "kind", "chain", "fk", "ik", "pole", "ik_rest", "switch", "properties",
                           "ik_stretch"}
    if unknown:
        _bad(where, f"unknown key(s) {sorted(unknown)} in limb {data.get('name')!r}")
    name = _name(where, data, "name")
    here = f"{where}, limb '{name}'"
    kind = data.get("kind", "")
    if kind not in ("arm", "leg", "other"):
        _bad(here, f'"kind" must be "arm", "leg" or "other", not {kind!r}')
    chain = _names(here, data, "chain")
    if len(chain) != 3:
        _bad(here, '"chain" must name three deform bones: upper, lower and end (say thigh, shin, foot)')
    fk = tuple(_control(here, c) for c in _list(here, data, "fk"))
    ik = tuple(_control(here, c) for c in _list(here, data, "ik"))
    if not fk:
        _bad(here, '"fk" must list the limb\'s FK controls')
    pole = _name(here, data, "pole", optional=True)
    if ik and chain[2] not in [c.bone for c in ik]:
        _bad(here, f'one "ik" control must drive the chain\'s end bone {chain[2]!r}')
    switch = None
    if data.get("switch") is not None:
        s = _object(here, data["switch"], '"switch"')
        switch = Switch(_name(here, s, "bone"), _name(here, s, "property"), _number(here, s, "fk"),
                        _number(here, s, "ik"))
    elif ik:
        _bad(here, 'a limb with "ik" controls needs a "switch" (bone, property, fk and ik values)')
    stretch = None
    if data.get("ik_stretch") is not None:
        s = _object(here, data["ik_stretch"], '"ik_stretch"')
        stretch = Stretch(_names(here, s, "bones"), _name(here, s, "bone"), _name(here, s, "property"),
                          _number(here, s, "factor"))
    return Limb(name, kind, chain, fk, ik, pole, _names(here, data, "ik_rest"), switch,
                tuple(_setting(here, p) for p in _list(here, data, "properties")), stretch)


def parse(data, where: str = "control rig map") -> ControlRigMap:
    """A map from its JSON object; a ValueError names where (the file) and what is wrong."""
    data = _object(where, data, "the map")
    if data.get("format") != FORMAT:
        _bad(where, f'"format" must be "{FORMAT}"')
    if data.get("version") != 1:
        _bad(where, f'unsupported "version" {data.get("version")!r} (this MotionKit reads version 1)')
    known = {"format", "version", "id", "label", "notes", "detect", "metarig", "skeleton", "rest", "properties",
             "controls", "limbs"}
    unknown = set(data) - known
    if unknown:
        _bad(where, f"unknown key(s) {sorted(unknown)}")
    map_id = data.get("id")
    if not isinstance(map_id, str) or not map_id:
        _bad(where, '"id" must be a non-empty string')
    skeleton = []
    for entry in _list(where, data, "skeleton"):
        entry = _object(where, entry, "a skeleton bone")
        skeleton.append(SkeletonBone(_name(where, entry, "bone"), _name(where, entry, "parent", optional=True),
                                     _name(where, entry, "tail", optional=True),
                                     root="parent" in entry and entry["parent"] is None))
    controls = tuple(_control(where, c) for c in _list(where, data, "controls"))
    limbs = tuple(_limb(where, b) for b in _list(where, data, "limbs"))
    if not controls and not limbs:
        _bad(where, 'no "controls" and no "limbs": nothing to key')
    names = [s.bone for s in skeleton]
    if len(set(names)) != len(names):
        _bad(where, "a bone is listed twice in \"skeleton\"")
    driven = {c.bone for c in controls} | {c.bone for b in limbs for c in b.fk + b.ik} | {n for b in limbs
                                                                                          for n in b.chain}
    in_skeleton = set(names)
    if skeleton and not driven <= in_skeleton:
        _bad(where, f"deform bones driven by controls but not in \"skeleton\": {sorted(driven - in_skeleton)}")
    if not skeleton:  # the deform bones the controls drive, in the armature's own hierarchy
        skeleton = [SkeletonBone(n) for n in dict.fromkeys(sorted(driven))]
    keyed = [c.control for c in controls] + [c.control for b in limbs for c in b.fk + b.ik]
    keyed += [b.pole for b in limbs if b.pole]
    if len(set(keyed)) != len(keyed):
        twice = sorted({k for k in keyed if keyed.count(k) > 1})
        _bad(where, f"control(s) keyed by two entries: {twice}")
    detect = _object(where, data.get("detect", {}), '"detect"')
    metarig = _object(where, data.get("metarig", {}), '"metarig"')
    return ControlRigMap(
        map_id, str(data.get("label", map_id)), tuple(skeleton), controls, limbs, _names(where, data, "rest"),
        tuple(_setting(where, p) for p in _list(where, data, "properties")),
        detect.get("armature_property"), _names(where, detect, "bones"), metarig.get("pose_bone_property"),
        str(metarig.get("message", "")), str(data.get("notes", "")), where)


def load(path) -> ControlRigMap:
    path = os.fspath(path)
    try:
        with open(path, encoding="utf-8") as f:
            data = json.load(f)
    except (OSError, UnicodeDecodeError) as error:
        raise ValueError(f"{path}: cannot read the control rig map: {error}") from None
    except json.JSONDecodeError as error:
        raise ValueError(f"{path}, line {error.lineno}: not JSON: {error.msg}") from None
    return parse(data, path)


@functools.lru_cache(maxsize=1)
def _presets() -> tuple[ControlRigMap, ...]:
    maps = [load(os.path.join(PRESETS_DIR, f)) for f in sorted(os.listdir(PRESETS_DIR)) if f.endswith(".json")]
    ids = [m.id for m in maps]
    if len(set(ids)) != len(ids):
        raise ValueError(f"{PRESETS_DIR}: a control rig id is used twice: {ids}")
    return tuple(maps)


def presets() -> dict[str, ControlRigMap]:
    return {m.id: m for m in _presets()}


def detect(bone_names, armature_properties=()) -> ControlRigMap | None:
    """The shipped map whose detection property and bones the armature has, if any."""
    names, props = set(bone_names), set(armature_properties)
    for rig_map in _presets():
        if rig_map.detect_bones and set(rig_map.detect_bones) <= names and \
                (rig_map.detect_property is None or rig_map.detect_property in props):
            return rig_map
    return None


def metarig_of(pose_bone_properties) -> ControlRigMap | None:
    """The shipped map whose generator's metarig this is (its pose bones carry the generator's property)."""
    props = set(pose_bone_properties)
    for rig_map in _presets():
        if rig_map.metarig_property and rig_map.metarig_property in props:
            return rig_map
    return None


def limb_modes(rig_map: ControlRigMap, controls: str, overrides=None) -> dict[str, str]:
    """Each limb's mode: "auto" puts legs in IK and the rest in FK (the usual choice: planted feet hold still,
    arms keep their arcs), "fk" or "ik" every limb that has that mode; overrides {limb name or kind ("arm",
    "leg"): mode} last, names after kinds."""
    if controls not in ("auto", "fk", "ik"):
        raise ValueError(f"controls must be 'auto', 'fk', 'ik' or 'none', not {controls!r}")
    modes = {}
    for limb in rig_map.limbs:
        want = ("ik" if limb.kind == "leg" else "fk") if controls == "auto" else controls
        modes[limb.name] = want if (want == "fk" or limb.ik) else "fk"
    overrides = dict(overrides or {})
    kinds = {k: overrides.pop(k) for k in ("arm", "leg", "other") if k in overrides}
    for name, mode in [(limb.name, kinds[limb.kind]) for limb in rig_map.limbs if limb.kind in kinds] + \
            list(overrides.items()):
        limb = rig_map.limb(name)
        if mode not in MODES:
            raise ValueError(f"limb '{name}': mode must be 'fk' or 'ik', not {mode!r}")
        if mode == "ik" and not limb.ik:
            raise ValueError(f"limb '{name}' of control rig '{rig_map.id}' has no IK controls")
        modes[name] = mode
    return modes


# ---------------------------------------------------------------------------
# Matrices (frames, 4, 4), armature space

def matrices(quaternions, heads) -> np.ndarray:
    """(n, 4, 4) from unit quaternions w x y z (n, 4) and translations (n, 3)."""
    q = np.asarray(quaternions, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = q.T
    m = np.zeros((q.shape[0], 4, 4))
    m[:, 0, 0] = 1 - 2 * (y * y + z * z)
    m[:, 0, 1] = 2 * (x * y - w * z)
    m[:, 0, 2] = 2 * (x * z + w * y)
    m[:, 1, 0] = 2 * (x * y + w * z)
    m[:, 1, 1] = 1 - 2 * (x * x + z * z)
    m[:, 1, 2] = 2 * (y * z - w * x)
    m[:, 2, 0] = 2 * (x * z - w * y)
    m[:, 2, 1] = 2 * (y * z + w * x)
    m[:, 2, 2] = 1 - 2 * (x * x + y * y)
    m[:, :3, 3] = heads
    m[:, 3, 3] = 1.0
    return m


def quaternions(m) -> np.ndarray:
    """Unit quaternions w x y z (n, 4), positive w, of the rotation parts of (n, 3+, 3+) rigid matrices."""
    r = np.asarray(m, dtype=np.float64)[:, :3, :3]
    trace = r[:, 0, 0] + r[:, 1, 1] + r[:, 2, 2]
    q = np.empty((r.shape[0], 4))
    # Shepperd's method: the largest of the four candidates is taken, per matrix.
    cand = np.stack([trace, r[:, 0, 0], r[:, 1, 1], r[:, 2, 2]], axis=1)
    pick = np.argmax(cand, axis=1)
    for k in range(4):
        s = pick == k
        if not np.any(s):
            continue
        a = r[s]
        if k == 0:
            t = np.sqrt(1.0 + trace[s]) * 2
            q[s] = np.stack([0.25 * t, (a[:, 2, 1] - a[:, 1, 2]) / t, (a[:, 0, 2] - a[:, 2, 0]) / t,
                             (a[:, 1, 0] - a[:, 0, 1]) / t], axis=1)
        else:
            i, j, l = (k - 1), k % 3, (k + 1) % 3
            t = np.sqrt(1.0 + a[:, i, i] - a[:, j, j] - a[:, l, l]) * 2
            v = np.empty((a.shape[0], 4))
            v[:, 0] = (a[:, l, j] - a[:, j, l]) / t
            v[:, 1 + i] = 0.25 * t
            v[:, 1 + j] = (a[:, j, i] + a[:, i, j]) / t
            v[:, 1 + l] = (a[:, l, i] + a[:, i, l]) / t
            q[s] = v
    q *= np.where(q[:, :1] < 0, -1.0, 1.0) / np.linalg.norm(q, axis=1, keepdims=True)
    return q


def rigid_inverse(m) -> np.ndarray:
    """Inverses of rigid (..., 4, 4) matrices (rotation and translation only): the rotation transposed."""
    m = np.asarray(m, dtype=np.float64)
    out = np.zeros_like(m)
    rt = np.swapaxes(m[..., :3, :3], -1, -2)
    out[..., :3, :3] = rt
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", rt, m[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


# ---------------------------------------------------------------------------
# A control's parent, measured

@dataclass(frozen=True)
class Relation:
    """How a bone (a control's parent) moves with known bones: its rotation is rotation_of's times
    rotation_offset; its head is the point location_point of location_of's frame. None: the armature
    (a fixed frame). For a rigid follower both are the same bone."""
    rotation_of: str | None
    rotation_offset: np.ndarray  # (3, 3)
    location_of: str | None
    location_point: np.ndarray   # (3,)

    @property
    def rigid(self) -> bool:
        return self.rotation_of == self.location_of

    def depends_on(self) -> set:
        return {n for n in (self.rotation_of, self.location_of) if n is not None}

    def evaluate(self, frames_of, count: int, locals_of=None) -> np.ndarray:
        """(count, 4, 4) matrices, given frames_of(name) -> (count, 4, 4) of the known bones (locals_of, the
        controls' bases, is for a Mechanism's sake)."""
        out = np.zeros((count, 4, 4))
        out[:, 3, 3] = 1.0
        rot = np.eye(3)[None] if self.rotation_of is None else frames_of(self.rotation_of)[:, :3, :3]
        out[:, :3, :3] = rot @ self.rotation_offset
        if self.location_of is None:
            out[:, :3, 3] = self.location_point
        else:
            m = frames_of(self.location_of)
            out[:, :3, 3] = np.einsum("nij,j->ni", m[:, :3, :3], self.location_point) + m[:, :3, 3]
        return out


def _angle(a, b) -> np.ndarray:
    """Angles between (n, 3, 3) rotations, from the chord ||a - b|| = 2 sqrt(2) sin(angle / 2), which keeps
    its precision for small angles (the trace's arccos loses half the digits there)."""
    chord = np.linalg.norm(np.asarray(a) - np.asarray(b), axis=(1, 2))
    return 2 * np.arcsin(np.clip(chord / (2 * np.sqrt(2)), 0.0, 1.0))


def fit_relation(bone: np.ndarray, candidates: dict, size: float) -> tuple[Relation | None, str]:
    """The relation (see Relation) that bone's sampled matrices (samples, 4, 4) keep with one of the
    candidates' ({name: (samples, 4, 4)}, in order of preference; None: the armature), and an explanation
    when none does. size: the rig's size, for the distance tolerance."""
    bone = np.asarray(bone, dtype=np.float64)
    scale = np.linalg.norm(bone[:, :3, :3], axis=1)
    if np.max(np.abs(scale - 1)) > 1e-3:
        return None, f"it is scaled (axis lengths {np.round(scale.min(), 4)}..{np.round(scale.max(), 4)})"
    fixed = {None: np.repeat(np.eye(4)[None], bone.shape[0], axis=0)}
    rotation = location = None
    spread = np.inf  # how far the bone's head drifts in the frame of the candidate nearest to carrying it
    for name, frames in {**fixed, **candidates}.items():
        frames = np.asarray(frames, dtype=np.float64)
        rel = np.linalg.inv(frames) @ bone  # a candidate may be scaled (a stretched bone): not rigid_inverse
        if rotation is None:
            offsets = np.transpose(frames[:, :3, :3], (0, 2, 1)) @ bone[:, :3, :3]
            if np.max(_angle(offsets, offsets[:1])) < ANGLE_TOLERANCE:
                rotation = (name, offsets[0])
        if location is None:
            points = rel[:, :3, 3]
            drift = float(np.max(np.linalg.norm(points - points[:1], axis=1)))
            spread = min(spread, drift)
            if drift < DISTANCE_TOLERANCE * size:
                location = (name, points[0])
        if rotation is not None and location is not None and rotation[0] == location[0]:
            break
    if rotation is None:
        return None, "its rotation follows no single bone (a blend, such as a Copy Rotation at part influence?)"
    if location is None:
        return None, f"its position follows no single bone (the nearest drifts {spread / size:.1e} of the rig's size)"
    # A rigid follower of one bone is preferred to a split between two, when both fit.
    for name, frames in candidates.items():
        if name == location[0] and name != rotation[0]:
            offsets = np.transpose(np.asarray(frames)[:, :3, :3], (0, 2, 1)) @ bone[:, :3, :3]
            if np.max(_angle(offsets, offsets[:1])) < ANGLE_TOLERANCE:
                rotation = (name, offsets[0])
    return Relation(rotation[0], rotation[1], location[0], location[1]), ""


# ---------------------------------------------------------------------------
# A control's parent, modelled where no single known bone carries it

STEPS = ("stretch_to", "copy_local_rotation", "copy_scale")
VOLUMES = ("VOLUME_XZX", "VOLUME_X", "VOLUME_Z", "NO_VOLUME")


@dataclass(frozen=True)
class Step:
    """One constraint of a mechanism bone, as Blender evaluates it (in pose space, in the stack's order; influence
    blends the result with the matrix before it, rotations along the shortest arc, the rest linearly):
    "stretch_to": its Y axis swung the shortest way onto the target's point (point: that far along the target's
    Y), scaled along Y by the distance over rest_length and across by the volume mode; "copy_local_rotation":
    its rotation in its own local space replaced by a control's basis rotation (Copy Rotation, local to local,
    Replace, every axis); "copy_scale": its axes scaled to the target's (world to world)."""
    kind: str
    target: str
    influence: float = 1.0
    point: float = 0.0
    rest_length: float = 1.0
    volume: str = "VOLUME_XZX"
    bulge: float = 1.0


@dataclass(frozen=True)
class Mechanism:
    """How a bone moves that no single known bone carries (Rigify's neck: MCH-STR-neck hangs from the neck
    control and stretches to the head; MCH-spine.005, the middle tweak's parent, rides on it and takes half
    the head's own rotation): its parent's frame (None: the armature; a known bone's name; a Relation or
    another Mechanism), its rest offset (inverse(parent's rest) @ its rest), the parent's scale inherited or
    not (inherit_scale "NONE": the parent's axes normalised for its rotation, the full parent for its head),
    then its constraints' steps. features/control_rigs.py builds one from the rig's parents and constraints
    and keeps it only if it reproduces Blender's own evaluation of the calibration poses."""
    bone: str
    parent: object
    rest_offset: np.ndarray  # (4, 4)
    inherit_scale: bool
    steps: tuple = ()

    rigid = False

    def depends_on(self) -> set:
        out = {s.target for s in self.steps}
        if isinstance(self.parent, str):
            out.add(self.parent)
        elif self.parent is not None:
            out |= self.parent.depends_on()
        return out

    def evaluate(self, frames_of, count: int, locals_of=None) -> np.ndarray:
        """(count, 4, 4) pose matrices (scaled where Blender scales the bone), given frames_of(name) -> (count,
        4, 4) of the known bones and locals_of(name) -> (count, 4, 4), the bases of the controls whose local
        rotation a step copies."""
        if self.parent is None:
            parent = np.repeat(np.eye(4)[None], count, axis=0)
        elif isinstance(self.parent, str):
            parent = np.asarray(frames_of(self.parent), dtype=np.float64)
        else:
            parent = self.parent.evaluate(frames_of, count, locals_of)
        start = parent @ self.rest_offset
        if not self.inherit_scale:
            head = start[:, :3, 3].copy()
            start = _orthonormal(parent) @ self.rest_offset
            start[:, :3, 3] = head
        m = start
        for step in self.steps:
            if step.kind == "stretch_to":
                after = _stretch_to(m, frames_of(step.target) @ np.array([0.0, step.point, 0.0, 1.0]), step)
            elif step.kind == "copy_local_rotation":
                # Local space is the frame the bone has with an identity basis (start): Replace keeps the
                # owner's local location and scale and takes the control's basis rotation.
                local = np.linalg.inv(start) @ m
                turn = np.asarray(locals_of(step.target), dtype=np.float64)[:, :3, :3]
                turn = turn / np.linalg.norm(turn, axis=1, keepdims=True)
                after = m.copy()
                after[:, :3, :3] = start[:, :3, :3] @ turn * np.linalg.norm(local[:, :3, :3], axis=1)[:, None, :]
            elif step.kind == "copy_scale":
                target = np.linalg.norm(np.asarray(frames_of(step.target))[:, :3, :3], axis=1)
                after = m.copy()
                after[:, :3, :3] = m[:, :3, :3] / np.linalg.norm(m[:, :3, :3], axis=1)[:, None, :] * target[:, None, :]
            else:
                raise ValueError(f"unknown mechanism step {step.kind!r}")
            m = interpolate(m, after, step.influence)
        return m


def _orthonormal(m) -> np.ndarray:
    """(n, 4, 4) with the rotation parts' axes made orthonormal keeping Y's direction (Blender's
    orthogonalize_m4_stable on axis Y), translations kept."""
    out = np.array(m, dtype=np.float64)
    y = out[:, :3, 1] / np.linalg.norm(out[:, :3, 1], axis=1, keepdims=True)
    x = out[:, :3, 0] - np.sum(out[:, :3, 0] * y, axis=1, keepdims=True) * y
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    out[:, :3, 0], out[:, :3, 1], out[:, :3, 2] = x, y, np.cross(x, y)
    return out


def swing(a, b) -> np.ndarray:
    """(n, 3, 3) rotations turning the unit vectors a (n, 3) onto b (n, 3) the shortest way."""
    v = np.cross(a, b)
    c = np.sum(a * b, axis=1)
    k = np.zeros((len(v), 3, 3))
    k[:, 0, 1], k[:, 0, 2], k[:, 1, 2] = -v[:, 2], v[:, 1], -v[:, 0]
    k -= np.transpose(k, (0, 2, 1))
    return np.eye(3)[None] + k + k @ k / np.maximum(1.0 + c, 1e-12)[:, None, None]


def _stretch_to(m, point, step: Step) -> np.ndarray:
    """Blender's Stretch To (Swing Y) on pose matrices m (n, 4, 4) toward points (n, 4)."""
    size = np.linalg.norm(m[:, :3, :3], axis=1)
    axes = m[:, :3, :3] / size[:, None, :]
    vec = point[:, :3] - m[:, :3, 3]
    length = np.linalg.norm(vec, axis=1)
    dist = length / size[:, 1]
    bulge = (step.rest_length / dist) ** step.bulge
    across = {"VOLUME_XZX": (np.sqrt(bulge), np.sqrt(bulge)), "VOLUME_X": (bulge, np.ones_like(bulge)),
              "VOLUME_Z": (np.ones_like(bulge), bulge), "NO_VOLUME": (np.ones_like(bulge),) * 2}[step.volume]
    scale = size * np.stack([across[0], dist / step.rest_length, across[1]], axis=1)
    out = m.copy()
    out[:, :3, :3] = swing(axes[:, :, 1], vec / length[:, None]) @ axes * scale[:, None, :]
    return out


def _polar(m):
    """Polar decompositions m = u @ p of (n, 3, 3): u a rotation, p symmetric (the scale in u's axes)."""
    w, s, vt = np.linalg.svd(m)
    return w @ vt, np.transpose(vt, (0, 2, 1)) @ (s[:, :, None] * vt)


def interpolate(a, b, t: float) -> np.ndarray:
    """Blender's blend of two matrices (n, 4, 4) by t (a constraint's influence): the polar decompositions'
    rotations along the shortest arc, their scales and the translations linearly."""
    if t >= 1.0:
        return np.array(b, dtype=np.float64)
    if t <= 0.0:
        return np.array(a, dtype=np.float64)
    ua, pa = _polar(np.asarray(a)[:, :3, :3])
    ub, pb = _polar(np.asarray(b)[:, :3, :3])
    qa, qb = quaternions(ua), quaternions(ub)
    qb = np.where(np.sum(qa * qb, axis=1, keepdims=True) < 0, -qb, qb)
    theta = np.arccos(np.clip(np.sum(qa * qb, axis=1), -1.0, 1.0))[:, None]
    sin = np.sin(theta)
    small = sin < 1e-9
    wa = np.where(small, 1.0 - t, np.sin((1.0 - t) * theta) / np.where(small, 1.0, sin))
    wb = np.where(small, t, np.sin(t * theta) / np.where(small, 1.0, sin))
    out = np.array(a, dtype=np.float64)
    out[:, :3, :3] = matrices(wa * qa + wb * qb, np.zeros((len(qa), 3)))[:, :3, :3] @ ((1.0 - t) * pa + t * pb)
    out[:, :3, 3] = (1.0 - t) * np.asarray(a)[:, :3, 3] + t * np.asarray(b)[:, :3, 3]
    return out


def check_mechanism(mechanism: Mechanism, measured: np.ndarray, frames_of, locals_of, size: float) -> str:
    """"" when the mechanism reproduces the measured matrices (samples, 4, 4) within the relations' tolerances
    (rotation, head, axis lengths), else how far it is off."""
    measured = np.asarray(measured, dtype=np.float64)
    model = mechanism.evaluate(frames_of, measured.shape[0], locals_of)
    axes = lambda m: m[:, :3, :3] / np.linalg.norm(m[:, :3, :3], axis=1, keepdims=True)  # noqa: E731
    angle = float(np.max(_angle(axes(model), axes(measured))))
    drift = float(np.max(np.linalg.norm(model[:, :3, 3] - measured[:, :3, 3], axis=1)))
    scale = float(np.max(np.abs(np.linalg.norm(model[:, :3, :3], axis=1) - np.linalg.norm(measured[:, :3, :3], axis=1))))
    if angle < ANGLE_TOLERANCE and drift < DISTANCE_TOLERANCE * size and scale < 1e-3:
        return ""
    return (f"modelled from its parents and constraints it is off by {np.degrees(angle):.3f} deg, "
            f"{drift / size:.1e} of the rig's size and {scale:.1e} in scale")


def order(relations: dict, known: set) -> list[str]:
    """The controls (relations' keys) in an order where each comes after the controls its parent follows;
    known: bones whose frames are given (deform bones). A cycle raises ValueError naming its controls."""
    done, out = set(known), []
    pending = list(relations)
    while pending:
        ready = [c for c in pending if relations[c].depends_on() - {c} <= done]
        if not ready:
            raise ValueError(f"the controls {pending} follow one another in a cycle")
        for c in ready:
            out.append(c)
            done.add(c)
        pending = [c for c in pending if c not in done]
    return out


# ---------------------------------------------------------------------------
# Targets and bases

def pole_positions(upper, lower, end, fallback, distance: float, bias: float = 1e-3) -> np.ndarray:
    """Pole targets (n, 3) in the plane of each frame's limb (upper, lower and end joints, (n, 3) each), on
    the bent joint's side, distance from it. fallback (n, 3): the pole's direction when the limb is straight
    (it weighs bias times the limb's length against the bend, so that a straight limb keeps a plane and a bent
    one keeps its own to within a few hundredths of a degree)."""
    line = end - upper
    length = np.linalg.norm(line, axis=1, keepdims=True)
    axis = line / np.maximum(length, 1e-12)
    bend = (lower - upper) - np.sum((lower - upper) * axis, axis=1, keepdims=True) * axis
    side = fallback - np.sum(fallback * axis, axis=1, keepdims=True) * axis
    side /= np.maximum(np.linalg.norm(side, axis=1, keepdims=True), 1e-12)
    direction = bend + bias * length * side
    direction /= np.maximum(np.linalg.norm(direction, axis=1, keepdims=True), 1e-12)
    return lower + distance * direction


def basis(parent: np.ndarray, rest_offset: np.ndarray, target: np.ndarray, local_location: bool = True) -> np.ndarray:
    """A bone's basis matrices (n, 4, 4) that put it at target (n, 4, 4), all rigid. Blender's pose is parent @
    rest_offset @ basis, rest_offset = inverse(parent's rest) @ bone's rest (no parent: the armature, and
    rest_offset the bone's rest); a bone without local location takes its translation in the parent's
    axes instead: parent @ translation @ rest_offset @ rotation."""
    if local_location:
        return rigid_inverse(parent @ rest_offset) @ target
    relative = rigid_inverse(parent) @ target
    out = rigid_inverse(rest_offset)[None] @ relative
    out[:, :3, 3] = relative[:, :3, 3] - rest_offset[:3, 3]
    return out

