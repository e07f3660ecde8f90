"""Sample characters that differ the way real rigs differ (no bpy: plain data).

Every character is built from one canonical humanoid, so the true mapping
between any two of them is known (``canonical`` below), which later tests use
as ground truth. They differ in what retargeting must cope with:

=========  ======  ===============  ======  ===========  =================
character  rest    names            height  torso/neck   bone rolls
=========  ======  ===============  ======  ===========  =================
MixamoT    T-pose  mixamorig:...    1.80 m  3 / 1        all zero
RigifyA    A-pose  spine.001, .L    1.65 m  3 / 2        ±90° arms, 180° feet
UnrealA    A-pose  thigh_l, calf_l  1.90 m  3 / 1        ±90° limbs, 90° spine
           +15° forward arms, a ``root`` bone on the floor above ``pelvis``
=========  ======  ===============  ======  ===========  =================

Coordinates are Blender's: Z up, the character faces -Y, its left is +X.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

# Canonical joints, parents first (depth-first order: parent index < child).
SIDES = ("L", "R")
LIMB_KEYS = ("shoulder", "upper_arm", "forearm", "hand", "thigh", "shin", "foot", "toe")


@dataclass(frozen=True)
class Proportions:
    hip_height: float
    pelvis: float
    torso: float
    neck: float
    head: float
    spine_bones: int
    neck_bones: int
    hip_half_width: float
    shoulder_half_width: float
    upper_arm: float
    forearm: float
    hand: float
    thigh: float
    shin: float
    foot: float
    toe: float
    arm_down_deg: float  # rest angle of the arm below horizontal: 0 = T-pose
    arm_forward_deg: float = 0.0

    @property
    def height(self) -> float:
        return self.hip_height + self.pelvis + self.torso + self.neck + self.head

    @property
    def ankle_height(self) -> float:
        return self.hip_height - self.thigh - self.shin


@dataclass(frozen=True)
class BoneSpec:
    name: str
    canonical: str  # "hips", "spine.1", "neck.1", "head", "thigh.L", ...
    parent: str | None
    head: tuple[float, float, float]
    tail: tuple[float, float, float]
    roll: float  # radians, as Blender's edit-bone roll


@dataclass(frozen=True)
class CharacterSpec:
    name: str
    rest_pose: str  # "T" or "A"
    naming: str
    proportions: Proportions
    color: tuple[float, float, float, float]
    bones: tuple[BoneSpec, ...] = field(default=())

    @property
    def canonical(self) -> dict[str, str]:
        """canonical joint -> this character's bone name."""
        return {b.canonical: b.name for b in self.bones}

    def bone(self, canonical: str) -> BoneSpec:
        return next(b for b in self.bones if b.canonical == canonical)


# Naming schemes: canonical key (side-free) -> name pattern ({S}: side word).
MIXAMO = {
    "hips": "mixamorig:Hips", "spine.1": "mixamorig:Spine", "spine.2": "mixamorig:Spine1",
    "spine.3": "mixamorig:Spine2", "neck.1": "mixamorig:Neck", "head": "mixamorig:Head",
    "shoulder": "mixamorig:{Side}Shoulder", "upper_arm": "mixamorig:{Side}Arm",
    "forearm": "mixamorig:{Side}ForeArm", "hand": "mixamorig:{Side}Hand",
    "thigh": "mixamorig:{Side}UpLeg", "shin": "mixamorig:{Side}Leg", "foot": "mixamorig:{Side}Foot",
    "toe": "mixamorig:{Side}ToeBase",
}
RIGIFY = {
    "hips": "spine", "spine.1": "spine.001", "spine.2": "spine.002", "spine.3": "spine.003",
    "neck.1": "spine.004", "neck.2": "spine.005", "head": "spine.006",
    "shoulder": "shoulder.{S}", "upper_arm": "upper_arm.{S}", "forearm": "forearm.{S}",
    "hand": "hand.{S}", "thigh": "thigh.{S}", "shin": "shin.{S}", "foot": "foot.{S}", "toe": "toe.{S}",
}
UNREAL = {
    "root": "root",  # the mannequin's bone on the floor, parent of pelvis
    "hips": "pelvis", "spine.1": "spine_01", "spine.2": "spine_02", "spine.3": "spine_03",
    "neck.1": "neck_01", "head": "head",
    "shoulder": "clavicle_{s}", "upper_arm": "upperarm_{s}", "forearm": "lowerarm_{s}",
    "hand": "hand_{s}", "thigh": "thigh_{s}", "shin": "calf_{s}", "foot": "foot_{s}", "toe": "ball_{s}",
}


def _name(scheme: dict, key: str, side: str | None) -> str:
    pattern = scheme[key]
    if side is None:
        return pattern
    return pattern.format(S=side, s=side.lower(), Side="Left" if side == "L" else "Right")


def _add(a, b, scale=1.0):
    return tuple(x + scale * y for x, y in zip(a, b))


def build_bones(p: Proportions, scheme: dict, roll) -> tuple[BoneSpec, ...]:
    """The canonical humanoid with proportions p, named by scheme, rolled by roll(key, side)."""
    bones: list[BoneSpec] = []

    def add(key, side, parent_key, head, tail):
        parent = None if parent_key is None else next(b.name for b in bones if b.canonical == parent_key)
        canonical = key if side is None else f"{key}.{side}"
        bones.append(BoneSpec(_name(scheme, key, side), canonical, parent,
                              tuple(head), tuple(tail), roll(key, side)))

    z = p.hip_height
    root = None
    if "root" in scheme:  # a game rig's floor root, pointing back along +Y as Unreal's does in Blender
        add("root", None, None, (0, 0, 0), (0, 0.2, 0))
        root = "root"
    add("hips", None, root, (0, 0, z), (0, 0, z + p.pelvis))
    z += p.pelvis
    parent = "hips"
    for i in range(1, p.spine_bones + 1):
        step = p.torso / p.spine_bones
        add(f"spine.{i}", None, parent, (0, 0, z), (0, 0, z + step))
        parent, z = f"spine.{i}", z + step
    chest, chest_top = parent, z
    for i in range(1, p.neck_bones + 1):
        step = p.neck / p.neck_bones
        add(f"neck.{i}", None, parent, (0, 0, z), (0, 0, z + step))
        parent, z = f"neck.{i}", z + step
    add("head", None, parent, (0, 0, z), (0, 0, z + p.head))

    down, fwd = math.radians(p.arm_down_deg), math.radians(p.arm_forward_deg)
    for side, sx in (("L", 1.0), ("R", -1.0)):
        shoulder_z = chest_top - 0.04
        inner = (sx * 0.03, 0.0, shoulder_z)
        outer = (sx * p.shoulder_half_width, 0.0, shoulder_z)
        add("shoulder", side, chest, inner, outer)
        arm_dir = (sx * math.cos(down) * math.cos(fwd), -math.cos(down) * math.sin(fwd), -math.sin(down))
        elbow = _add(outer, arm_dir, p.upper_arm)
        wrist = _add(elbow, arm_dir, p.forearm)
        add("upper_arm", side, f"shoulder.{side}", outer, elbow)
        add("forearm", side, f"upper_arm.{side}", elbow, wrist)
        add("hand", side, f"forearm.{side}", wrist, _add(wrist, arm_dir, p.hand))

        hip = (sx * p.hip_half_width, 0.0, p.hip_height)
        knee = (hip[0], -0.01, p.hip_height - p.thigh)  # a hint of knee bend, as real rigs have
        ankle = (hip[0], 0.0, p.ankle_height)
        ball = (hip[0], -p.foot, 0.025)
        add("thigh", side, "hips", hip, knee)
        add("shin", side, f"thigh.{side}", knee, ankle)
        add("foot", side, f"shin.{side}", ankle, ball)
        add("toe", side, f"foot.{side}", ball, (hip[0], -p.foot - p.toe, 0.025))
    return tuple(bones)


def _rolls_zero(key, side):
    return 0.0


def _rolls_rigify(key, side):
    sign = 1.0 if side == "L" else -1.0
    if key in ("upper_arm", "forearm", "hand"):
        return sign * math.pi / 2
    if key in ("foot", "toe"):
        return math.pi
    return 0.0


def _rolls_unreal(key, side):
    sign = 1.0 if side == "L" else -1.0
    if key in LIMB_KEYS:
        return -sign * math.pi / 2
    return math.pi / 2


def _character(name, rest, naming, scheme, roll, proportions, color):
    return CharacterSpec(name, rest, naming, proportions, color, build_bones(proportions, scheme, roll))


MIXAMO_T = _character("MixamoT", "T", "mixamo", MIXAMO, _rolls_zero, Proportions(
    hip_height=0.98, pelvis=0.10, torso=0.42, neck=0.10, head=0.20, spine_bones=3, neck_bones=1,
    hip_half_width=0.10, shoulder_half_width=0.19, upper_arm=0.30, forearm=0.26, hand=0.18,
    thigh=0.46, shin=0.44, foot=0.14, toe=0.07, arm_down_deg=0.0), (0.80, 0.35, 0.20, 1.0))

RIGIFY_A = _character("RigifyA", "A", "rigify", RIGIFY, _rolls_rigify, Proportions(
    hip_height=0.80, pelvis=0.12, torso=0.45, neck=0.10, head=0.18, spine_bones=3, neck_bones=2,
    hip_half_width=0.11, shoulder_half_width=0.18, upper_arm=0.28, forearm=0.25, hand=0.16,
    thigh=0.37, shin=0.36, foot=0.13, toe=0.06, arm_down_deg=45.0), (0.20, 0.45, 0.80, 1.0))

UNREAL_A = _character("UnrealA", "A", "unreal", UNREAL, _rolls_unreal, Proportions(
    hip_height=1.05, pelvis=0.10, torso=0.45, neck=0.10, head=0.20, spine_bones=3, neck_bones=1,
    hip_half_width=0.12, shoulder_half_width=0.20, upper_arm=0.32, forearm=0.28, hand=0.19,
    thigh=0.49, shin=0.47, foot=0.15, toe=0.07, arm_down_deg=40.0, arm_forward_deg=15.0),
    (0.30, 0.70, 0.35, 1.0))

CHARACTERS = (MIXAMO_T, RIGIFY_A, UNREAL_A)
