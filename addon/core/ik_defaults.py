"""Natural defaults for full-body IK on a humanoid (no bpy): which joints move first, how stiff they
are, the ranges a person's joints bend within, and each bone's mass for the balance.

A humanoid is recognised by MotionKit's bone map (hips, spine and limbs labelled). The defaults fill in
only what the rig leaves unset: a bone with IK limits, locks or stiffness of its own keeps them.

- Stages (recruitment): the limbs, clavicles and everything else move first (stage 0); only while a
  target stays out of their reach does the spine join (stage 1, spread over its bones), then the hips
  (stage 2: the body root's rotation and location).
- Stiffness: the spine and the clavicles resist more than the limbs; the hips most.
- Limits, per body part, in degrees: knees and elbows are hinges that bend one way and never past
  straight; the spine's flexion, extension, side bend and twist are the whole spine's, shared by its
  bones; hips, ankles and clavicles within a person's ranges. Every range is soft: on each frame it
  widens to take in the input pose, so that the defaults never move a joint the targets do not need to
  move (a capture's knee a few degrees past straight stays as it is, and goes no further).
- Masses: de Leva's (1996) segment fractions of the body's mass, each segment's share spread over its
  bones by length.

Which way a joint bends is measured, not assumed: the axis of a bone's rest frame (X or Z) whose turn
moves its tail most along the body's forward direction (taken from the feet, as the bone map does),
and the sign that moves it forwards (backwards for a knee).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields

import numpy as np

from . import bone_mapping

# de Leva (1996), adjusted Zatsiorsky-Seluyanov segment masses, male, fractions of the body's.
MASS_FRACTIONS = {"head": 0.0694, "trunk": 0.4346, "upper_arm": 0.0271, "forearm": 0.0162, "hand": 0.0061,
                  "thigh": 0.1416, "shin": 0.0433, "foot": 0.0137}
PARTS = ("hips", "spine", "neck", "head", "clavicle", "upper_arm", "forearm", "hand", "thigh", "shin", "foot",
         "other")


@dataclass
class NaturalDefaults:
    """The editable settings behind the defaults (degrees for angles; stiffness in [0, 1))."""
    spine_stiffness: float = 0.3
    clavicle_stiffness: float = 0.5
    hips_stiffness: float = 0.6
    spine_flexion: float = 80.0     # the whole spine's, forwards
    spine_extension: float = 30.0   # backwards
    spine_side: float = 35.0        # each side
    spine_twist: float = 45.0       # each way
    clavicle_range: float = 25.0    # each way, both swing axes
    hip_flexion: float = 120.0
    hip_extension: float = 20.0
    hip_side: float = 45.0
    hip_twist: float = 45.0
    knee_bend: float = 150.0
    elbow_bend: float = 150.0
    forearm_twist: float = 90.0
    upper_arm_twist: float = 90.0
    wrist_flexion: float = 70.0   # each way
    wrist_side: float = 25.0
    ankle_range: float = 40.0

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, values: dict) -> "NaturalDefaults":
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(values) - known)
        if unknown:
            raise ValueError(f"unknown natural-default settings: {', '.join(unknown)}; "
                             f"expected some of {', '.join(sorted(known))}")
        return cls(**{k: float(v) for k, v in values.items()})


@dataclass
class Joints:
    """Per bone (in the rig's order): what the solver takes (ik_solve's per-bone arrays)."""
    part: list                 # each bone's body part (PARTS)
    stage: np.ndarray          # (B,) int32
    stiffness: np.ndarray      # (B, 3)
    limit_min: np.ndarray      # (B, 3) radians, swing x, twist y, swing z
    limit_max: np.ndarray
    soft: np.ndarray           # (B, 3) bool
    mass: np.ndarray           # (B,)
    facing: np.ndarray = field(default_factory=lambda: np.array([0.0, -1.0, 0.0]))

    def arrays(self) -> dict:
        return {"stage": self.stage, "stiffness": self.stiffness, "limit_min": self.limit_min,
                "limit_max": self.limit_max, "soft": self.soft, "mass": self.mass}


def is_humanoid(body: bone_mapping.Body) -> bool:
    """Hips, a spine, and both arms and both legs down to the hand and the foot."""
    needed = [f"{k}.{s}" for s in bone_mapping.SIDES for k in ("upper_arm", "forearm", "hand", "thigh", "shin")]
    return body.hips is not None and bool(body.spine) and all(k in body.limbs for k in needed)


def facing(rig: bone_mapping.Rig, body: bone_mapping.Body) -> np.ndarray:
    """The horizontal direction the feet point (-Y when no foot tells)."""
    index = {n: i for i, n in enumerate(rig.names)}
    total = np.zeros(3)
    for key in ("foot.L", "foot.R", "toe.L", "toe.R"):
        if key in body.limbs:
            i = index[body.limbs[key]]
            d = rig.tails[i] - rig.heads[i]
            total += np.array([d[0], d[1], 0.0])
    n = np.linalg.norm(total)
    return total / n if n > 1e-9 else np.array([0.0, -1.0, 0.0])


def parts_of(rig: bone_mapping.Rig, body: bone_mapping.Body) -> list:
    """Each bone's body part: labelled bones by their label; a limb's unlabelled bones (twist bones,
    fingers, toes) with the labelled bone above them; the rest "other"."""
    index = {n: i for i, n in enumerate(rig.names)}
    part = ["other"] * len(rig.names)
    labelled = {}
    if body.hips is not None:
        labelled[index[body.hips]] = "hips"
    for name in body.spine:
        labelled[index[name]] = "spine"
    for name in body.neck:
        labelled[index[name]] = "neck"
    if body.head is not None:
        labelled[index[body.head]] = "head"
    for key, name in body.limbs.items():
        slot = key.split(".")[0]
        labelled[index[name]] = {"shoulder": "clavicle", "toe": "foot"}.get(slot, slot)
    for b, parent in enumerate(rig.parents):  # parents come first
        if b in labelled:
            part[b] = labelled[b]
        elif parent >= 0 and part[parent] in ("hand", "foot", "head", "forearm", "upper_arm", "thigh", "shin"):
            part[b] = part[parent]
    return part


def _bend_axis(axes: np.ndarray, towards: np.ndarray) -> tuple[int, float]:
    """The swing axis (0: X, 2: Z) of a rest frame (columns X, Y, Z) whose positive turn moves the tail
    most along `towards`, and the sign (+1: positive angles bend that way)."""
    y = axes[:, 1]
    moves = [float(np.dot(np.cross(axes[:, k], y), towards)) for k in (0, 2)]
    k = 0 if abs(moves[0]) >= abs(moves[1]) else 1
    return (0, 2)[k], 1.0 if moves[k] >= 0 else -1.0


def natural_joints(rig: bone_mapping.Rig, body: bone_mapping.Body, rest_axes: np.ndarray,
                   settings: NaturalDefaults | None = None, body_root: str | None = None) -> Joints:
    """The defaults for every bone of `rig` (rest_axes: (B, 3, 3), each bone's rest frame in armature
    space, columns X, Y, Z). body_root: the bone whose location carries the body (the hips, or the top
    bone): stage 2."""
    s = settings or NaturalDefaults()
    count = len(rig.names)
    part = parts_of(rig, body)
    forward = facing(rig, body)
    rad = np.radians
    stage = np.zeros(count, dtype=np.int32)
    stiffness = np.zeros((count, 3))
    lo = np.full((count, 3), -np.inf)
    hi = np.full((count, 3), np.inf)
    soft = np.zeros((count, 3), dtype=bool)
    spine_count = max(1, sum(p == "spine" for p in part))
    index = {n: i for i, n in enumerate(rig.names)}
    root = index.get(body_root if body_root is not None else body.hips, 0)

    def bend(b, towards, flexion, extension, side, twist):
        axis, sign = _bend_axis(rest_axes[b], towards)
        other = 2 if axis == 0 else 0
        lo[b, axis], hi[b, axis] = (-extension, flexion) if sign > 0 else (-flexion, extension)
        lo[b, other], hi[b, other] = -side, side
        lo[b, 1], hi[b, 1] = -twist, twist
        soft[b] = True

    labels = {v: k for k, v in body.limbs.items()}
    for b, p in enumerate(part):
        is_label = rig.names[b] in labels or rig.names[b] in body.spine or rig.names[b] == body.hips
        if p == "spine" and is_label:
            stage[b] = 1
            stiffness[b] = s.spine_stiffness
            bend(b, forward, rad(s.spine_flexion) / spine_count, rad(s.spine_extension) / spine_count,
                 rad(s.spine_side) / spine_count, rad(s.spine_twist) / spine_count)
        elif p == "clavicle" and is_label:
            stiffness[b] = s.clavicle_stiffness
            lo[b], hi[b] = -rad(s.clavicle_range), rad(s.clavicle_range)
            soft[b] = True
        elif p == "thigh" and is_label:
            bend(b, forward, rad(s.hip_flexion), rad(s.hip_extension), rad(s.hip_side), rad(s.hip_twist))
        elif p == "shin" and is_label:
            bend(b, -forward, rad(s.knee_bend), 0.0, rad(5.0), rad(10.0))
        elif p == "forearm" and is_label:
            bend(b, forward, rad(s.elbow_bend), 0.0, rad(5.0), rad(s.forearm_twist))
        elif p == "upper_arm" and is_label:
            lo[b, 1], hi[b, 1] = -rad(s.upper_arm_twist), rad(s.upper_arm_twist)
            soft[b, 1] = True
        elif p == "hand" and is_label:
            bend(b, forward, rad(s.wrist_flexion), rad(s.wrist_flexion), rad(s.wrist_side), rad(10.0))
        elif p == "foot" and is_label and labels.get(rig.names[b], "").startswith("foot"):
            lo[b], hi[b] = -rad(s.ankle_range), rad(s.ankle_range)
            soft[b] = True
    stage[root] = 2
    stiffness[root] = s.hips_stiffness
    for b in range(count):  # above the body root (a floor root): never moved first
        if b != root and bone_mapping.is_ancestor(rig.parents, b, root):
            stage[b] = 2
    return Joints(part, stage, np.minimum(stiffness, 0.99), lo, hi, soft, masses(rig, part, sides_of(rig, body)),
                  forward)


def masses(rig: bone_mapping.Rig, part: list, side: list) -> np.ndarray:
    """Each bone's share of the body's mass (summing to 1 over the labelled body): de Leva's segment
    fractions, a segment's (per side) spread over its bones by length; trunk = hips, spine and
    clavicles; head = neck and head. Bones of no body part weigh nothing."""
    lengths = np.linalg.norm(rig.tails - rig.heads, axis=1)
    segment = {"hips": "trunk", "spine": "trunk", "clavicle": "trunk", "neck": "head", "head": "head",
               "upper_arm": "upper_arm", "forearm": "forearm", "hand": "hand", "thigh": "thigh", "shin": "shin",
               "foot": "foot"}
    out = np.zeros(len(part))
    groups: dict = {}
    for b, p in enumerate(part):
        if p in segment:
            groups.setdefault((segment[p], side[b] if segment[p] not in ("trunk", "head") else ""), []).append(b)
    for (seg, _side), bones in groups.items():
        share = lengths[bones]
        share = share / share.sum() if share.sum() > 0 else np.full(len(bones), 1.0 / len(bones))
        out[bones] = MASS_FRACTIONS[seg] * share
    total = out.sum()
    return out / total if total > 0 else out


def sides_of(rig: bone_mapping.Rig, body: bone_mapping.Body) -> list:
    """Each bone's side ("L", "R" or ""): a labelled limb bone's, inherited down its children."""
    index = {n: i for i, n in enumerate(rig.names)}
    labelled = {index[name]: key.split(".")[1] for key, name in body.limbs.items()}
    side = [""] * len(rig.names)
    for b, parent in enumerate(rig.parents):
        side[b] = labelled.get(b, side[parent] if parent >= 0 else "")
    return side
