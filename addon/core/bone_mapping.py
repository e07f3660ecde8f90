"""Which bone of one armature corresponds to which bone of another (rest pose only, no bpy).

classify() labels a humanoid's hips, spine, neck, head, limb and finger bones;
auto_map() joins two such labellings into the (source bone, target bone) pairs the
retarget engine drives. Three sources of evidence, in this order:

1. a shipped scheme preset (addon/core/presets/*.json) whose bone names all
   exist, in any namespace (mixamorig6:Hips answers to mixamorig:Hips);
2. bone names: namespaces and DEF-/ORG- stripped, the side read from markers
   (.L, _r, Left, lHip, LHipJoint...), body-part words with synonyms;
3. the skeleton's shape: the hips are where one subtree goes up and two go
   down to the floor (through a pelvis bone the legs branch from), the chest
   is where the arms branch off, and the upper and lower limb bones are the
   two longest consecutive segments of a limb.

Names choose among the chains the shape offers (a subtree holding bones named
as a leg is a leg before any other reaching the floor) and label the bones
along them; they are trusted only where they agree with the shape (the bone
lies in the limb chain the shape found), and the shape fills what they leave.
Body.how records which evidence produced each label. Joints characters carry
beside the body (Mixamo's *_split segments, a facial-animation joint parked
on the floor, clothes, hair, props) are helpers: never labelled, never
mapped. auto_map_report() says by name what a map leaves out.

Fingers and twist bones are labelled last, by name alone (their names make
them helpers, which the shape rules ignore):

- Body.fingers: the phalanges of each finger, root to tip, found in the
  subtree of each labelled hand (Mixamo's LeftHandIndex1-3, Rigify's
  f_index.01.L and its DEF- copy, Unreal's index_01_l, Character Creator's
  CC_Base_L_Index1, Daz's lIndex1, Biped's Finger1/Finger11, CMU's LThumb...).
  End bones (Mixamo's LeftHandIndex4, Biped's Finger1Nub) are left out.
- Body.metacarpals: a separate bone between the hand and a finger (Unreal's
  index_metacarpal_l, Rigify's palm.01.L).
- Body.twists: twist bones (upperarm_twist_01_l) hanging from a labelled upper
  arm, forearm, thigh or shin.

auto_map() pairs fingers chain to chain (first and last bones when their
lengths differ) and metacarpals where both rigs have them; twist bones are
never paired (the retarget gives them a share of their limb's twist).

Blender conventions throughout: Z is up, a character usually faces -Y and its
left is +X, but the facing is measured from the feet, not assumed.
"""
from __future__ import annotations

import copy
import functools
import json
import os
import re
from dataclasses import dataclass, field

import numpy as np

from . import chain_modes

SIDES = ("L", "R")
ARM_KEYS = ("shoulder", "upper_arm", "forearm", "hand")
LEG_KEYS = ("thigh", "shin", "foot", "toe")
LIMB_KEYS = tuple(f"{key}.{side}" for side in SIDES for key in ARM_KEYS + LEG_KEYS)
# The slots of a limb chain, root to tip. "connector" is a short bone from the
# hips to the hip joint (CMU's LHipJoint): it has a slot so that names and
# lengths can place the thigh after it, but it is never reported or mapped.
ARM_SLOTS = ARM_KEYS
LEG_SLOTS = ("connector",) + LEG_KEYS
FINGERS = ("thumb", "index", "middle", "ring", "pinky")
FINGER_KEYS = tuple(f"{finger}.{side}" for side in SIDES for finger in FINGERS)
# The limb bones twist bones hang from (the retarget gives them a share of that bone's twist).
TWIST_LIMB_KEYS = tuple(f"{key}.{side}" for side in SIDES for key in ("upper_arm", "forearm", "thigh", "shin"))

MAP_FORMAT = "motionkit-bone-map"
SCHEME_FORMAT = "motionkit-bone-scheme"
PRESETS_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "presets")


@dataclass(frozen=True)
class Rig:
    """An armature's rest pose: names, parent indices (-1 for roots, any order), heads and tails."""
    names: tuple[str, ...]
    parents: tuple[int, ...]
    heads: np.ndarray
    tails: np.ndarray

    def __post_init__(self):
        names = tuple(str(n) for n in self.names)
        parents = tuple(int(p) for p in self.parents)
        count = len(names)
        if len(parents) != count:
            raise ValueError(f"Rig has {count} names but {len(parents)} parents")
        heads = np.array(self.heads, dtype=np.float64)
        tails = np.array(self.tails, dtype=np.float64)
        for label, array in (("heads", heads), ("tails", tails)):
            if array.shape != (count, 3):
                raise ValueError(f"Rig {label} must have shape ({count}, 3), not {array.shape}")
        repeated = sorted({n for n in names if names.count(n) > 1})
        if repeated:
            raise ValueError(f"Rig bone names appear twice: {', '.join(repeated)}")
        for i, parent in enumerate(parents):
            if parent < -1 or parent >= count or parent == i:
                raise ValueError(f"Rig bone {names[i]!r} has an invalid parent index {parent}")
        heads.flags.writeable = False
        tails.flags.writeable = False
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "parents", parents)
        object.__setattr__(self, "heads", heads)
        object.__setattr__(self, "tails", tails)
        if len(_depth_first(parents)) != count:
            raise ValueError("Rig parents form a cycle")

    @classmethod
    def from_parent_names(cls, names, parent_names, heads, tails) -> "Rig":
        """A Rig from parent names (None for roots) rather than indices."""
        names = tuple(names)
        index = {name: i for i, name in enumerate(names)}
        missing = sorted({p for p in parent_names if p is not None and p not in index})
        if missing:
            raise ValueError(f"Rig parents name unknown bones: {', '.join(missing)}")
        return cls(names, tuple(-1 if p is None else index[p] for p in parent_names), heads, tails)


@dataclass
class Body:
    """A humanoid's labelled bones (names), each with how it was found."""
    hips: str | None = None
    spine: list[str] = field(default_factory=list)  # above the hips up to the chest (inclusive)
    neck: list[str] = field(default_factory=list)   # above the chest, below the head
    head: str | None = None
    limbs: dict[str, str] = field(default_factory=dict)  # "thigh.L" -> bone name; missing ones absent
    how: dict[str, str] = field(default_factory=dict)    # key -> "preset:<scheme>", "name" or "structure"
    root: str | None = None  # a bone above the hips (a game rig's floor root: Unreal's root, a dataset's Root)
    # "index.L" -> the finger's phalanges, root to tip (end bones such as Mixamo's ...Index4 left out);
    # fingers a hand lacks are absent. Body.how has the same keys.
    fingers: dict[str, list[str]] = field(default_factory=dict)
    # "index.L" -> a metacarpal bone between the hand and that finger (Unreal's index_metacarpal_l,
    # Rigify's palm.01.L), where the rig has one. Body.how keys: "index_metacarpal.L".
    metacarpals: dict[str, str] = field(default_factory=dict)
    # twist bone name -> the limb key ("forearm.L") of the labelled bone it hangs from; never mapped.
    twists: dict[str, str] = field(default_factory=dict)


# ---------------------------------------------------------------------------
# Names

_NAMESPACE = re.compile(r"^.*:")  # mixamorig:, mixamorig1:, any exporter's namespace
_RIG_PREFIX = re.compile(r"^(DEF|ORG)[-_.]", re.IGNORECASE)
_CAMEL = re.compile(r"[A-Z]+(?=[A-Z][a-z])|[A-Z]?[a-z]+|[A-Z]+|\d+")
# A side letter glued to a capitalised word: lHip, rShoulder (GAMES-105), LHipJoint (CMU).
_SIDE_PREFIX = re.compile(r"^([lLrR])(?=[A-Z][a-z0-9])")

# Two-word body parts, matched before single words (LeftUpLeg, LowerBack, LeftForeArm).
_PHRASES = {
    ("up", "leg"): "thigh", ("upper", "leg"): "thigh", ("lower", "leg"): "shin", ("lo", "leg"): "shin",
    ("up", "arm"): "upper_arm", ("upper", "arm"): "upper_arm", ("lower", "arm"): "forearm",
    ("lo", "arm"): "forearm", ("fore", "arm"): "forearm", ("lower", "back"): "spine",
    ("upper", "back"): "spine", ("upper", "chest"): "spine", ("toe", "base"): "toe",
    ("collar", "bone"): "clavicle",
}
_WORDS = {
    "hips": "hip", "hip": "hip", "pelvis": "pelvis", "root": "root",
    "spine": "spine", "back": "spine", "lowerback": "spine", "upperback": "spine", "torso": "spine",
    "chest": "spine", "upperchest": "spine", "abdomen": "spine", "waist": "spine",
    "neck": "neck", "head": "head",
    "clavicle": "clavicle", "collar": "clavicle", "collarbone": "clavicle", "shoulder": "shoulder",
    "arm": "upper_arm", "upperarm": "upper_arm", "uparm": "upper_arm",
    "forearm": "forearm", "lowerarm": "forearm", "loarm": "forearm", "elbow": "forearm",
    "hand": "hand", "wrist": "hand",
    "thigh": "thigh", "upleg": "thigh", "upperleg": "thigh",
    "shin": "shin", "calf": "shin", "leg": "shin", "lowerleg": "shin", "loleg": "shin", "knee": "shin",
    "foot": "foot", "ankle": "foot",
    "toe": "toe", "toes": "toe", "toebase": "toe", "ball": "toe",
}
# Words that make a bone a helper whatever else its name says: such bones are
# never labelled, and the shape analysis ignores them where it safely can.
_HELPER_WORDS = {
    "twist", "roll", "ik", "pole", "target", "tgt", "helper", "corrective", "end", "nub", "null", "dummy",
    "socket", "attach", "weapon", "prop", "jiggle", "metacarpal", "face", "jaw", "lip", "lips", "mouth",
    "nose", "chin", "tongue", "teeth", "forehead", "hair", "bck", "fwd", "bicep", "tricep", "scap",
    "latissimus", "vb",
    # Mixamo characters' own joints beside the standard ones: LeftShoulder_split and Spine1_split (identity
    # in Mixamo's clips), a facial-animation joint on the floor (BoyFacialAnim_Joint), and clothes, hair and
    # props whose names hold a body word (LeftPantLeg, Left_ShortSleeve, LFootTongue, Bind_Left_JacketString).
    "split", "facial", "pant", "pants", "sleeve", "cape", "skirt", "hood", "hat", "visor", "strap", "string",
    "belt", "bag", "pouch", "backpack", "butt", "belly", "jowel", "jowl", "whistle", "peck", "scarf", "tie",
}
# Fingers, face and flesh bones come in pairs: these words are helpers only on a
# sided name, so that an unsided "spineMiddle" or "Ring" stays what it is.
_SIDED_HELPER_WORDS = {
    "thumb", "index", "middle", "mid", "ring", "pinky", "pinkie", "little", "finger", "fingers", "f", "palm",
    "carpal", "forefinger", "pointer",
    "heel", "breast", "bust", "pec", "pectoral", "eye", "eyes", "eyelid", "lid", "brow", "eyebrow", "ear",
    "cheek", "temple", "inner", "outer",
}
_LIMB_TERMS = {
    "clavicle": ("shoulder",),
    # Mixamo's LeftShoulder is the clavicle, GAMES-105's lShoulder (joint-named)
    # the upper arm: the chain order decides between them.
    "shoulder": ("shoulder", "upper_arm"),
    "upper_arm": ("upper_arm",), "forearm": ("forearm",), "hand": ("hand",),
    "thigh": ("thigh",),
    # GAMES-105's lHip is the thigh, CMU's LHipJoint a connector before LeftUpLeg.
    "hip": ("thigh", "connector"),
    "shin": ("shin",), "foot": ("foot",), "toe": ("toe",),
}
_TRUNK = {"hip": "hips", "pelvis": "hips", "root": "hips", "spine": "spine", "neck": "neck", "head": "head"}


@dataclass(frozen=True)
class NameInfo:
    """What a bone name says: its side, candidate labels (preferred first), whether it is a helper."""
    side: str | None
    keys: tuple[str, ...]
    helper: bool


def _strip(name: str) -> str:
    return _RIG_PREFIX.sub("", _NAMESPACE.sub("", name))


def _name_side(base: str) -> str | None:
    lower = base.lower()
    found = set()
    if "left" in lower:
        found.add("L")
    if "right" in lower:
        found.add("R")
    parts = [p for p in re.split(r"[^A-Za-z0-9]+", base) if p]
    for part in parts:
        if part in ("L", "l"):
            found.add("L")
        elif part in ("R", "r"):
            found.add("R")
    if parts:
        match = _SIDE_PREFIX.match(parts[0])
        if match:
            found.add(match.group(1).upper())
    return found.pop() if len(found) == 1 else None


def _tokens(base: str) -> list[str]:
    """Lower-case words and numbers of a name, in order, side markers kept as words of their own."""
    tokens = []
    for part in re.split(r"[^A-Za-z0-9]+", base):
        for word in _CAMEL.findall(part):
            word = word.lower()
            for side in ("left", "right"):  # glued lower-case names: leftupleg
                if word != side and word.startswith(side):
                    word = word[len(side):]
                if word != side and word.endswith(side):
                    word = word[:-len(side)]
            if word:
                tokens.append(word)
    return tokens


def _words(base: str) -> list[str]:
    """Lower-case words of a name, side markers and numbers dropped."""
    return [t for t in _tokens(base) if not t.isdigit() and t not in ("l", "r", "left", "right")]


def _last_term(words: list[str]) -> str | None:
    """The body part a name ends on: pelvis_lowerback is the lower back, lTorso_Clavicle the clavicle."""
    term, i = None, 0
    while i < len(words):
        if tuple(words[i:i + 2]) in _PHRASES:
            term, i = _PHRASES[tuple(words[i:i + 2])], i + 2
        else:
            term, i = _WORDS.get(words[i], term), i + 1
    return term


@functools.lru_cache(maxsize=4096)
def name_info(name: str) -> NameInfo:
    """Side, candidate labels and helper status of one bone name."""
    base = _strip(name)
    side = _name_side(base)
    words = _words(base)
    helper = any(w in _HELPER_WORDS for w in words) or (
        side is not None and any(w in _SIDED_HELPER_WORDS for w in words))
    if helper:
        return NameInfo(side, (), True)
    term = _last_term(words)
    if term is None:
        return NameInfo(side, (), False)
    if side is None and term in _TRUNK:
        return NameInfo(None, (_TRUNK[term],), False)
    if term in _LIMB_TERMS:
        return NameInfo(side, _LIMB_TERMS[term], False)
    # A sided trunk word (pelvis.L, spine_04_l): a flesh or helper bone.
    return NameInfo(side, (), term in ("pelvis", "root"))


# Finger names. These words make a bone a helper in name_info, so the shape
# rules ignore the fingers; the fingers are read apart, under each labelled hand.
_FINGER_WORDS = {
    "thumb": "thumb", "index": "index", "fore": "index", "pointer": "index", "middle": "middle",
    "mid": "middle", "ring": "ring", "pinky": "pinky", "pinkie": "pinky", "little": "pinky",
}
_PALM_FINGERS = {1: "index", 2: "middle", 3: "ring", 4: "pinky"}  # Rigify's palm.01.L .. palm.04.L
_SEGMENT_WORDS = {"proximal": 1, "intermediate": 2, "medial": 2, "distal": 3}  # Unity/VRM, Rokoko
_END_WORDS = {"end", "nub", "tip", "site"}
_SIDE_WORDS = ("l", "r", "left", "right")
# A finger-named bone with one of these words is a control or a mechanism, not
# a phalanx: Rigify's thumb.01_master.L and MCH-..., ik, fk, twist and the like.
_NOT_FINGER_WORDS = (_HELPER_WORDS - {"metacarpal", "end", "nub"}) | {
    "master", "mch", "fk", "tweak", "drv", "ctrl", "control", "mstr", "bend"}
# 3ds Max Biped's Finger0 (thumb), Finger01, Finger02 (its 2nd and 3rd segments),
# Finger1 (index)...; Rokoko's Finger2Proximal. Which finger N is is read per hand.
_NUMBERED_FINGER = re.compile(r"finger(\d)(\d?)(?!\d)", re.IGNORECASE)


@dataclass(frozen=True)
class _FingerName:
    """What a bone name says about a finger bone."""
    finger: str | None   # "thumb" ... "pinky"; None for a numbered finger (FingerN)
    number: int | None   # the N of FingerN
    segment: int | None  # the phalanx's place from the hand (1 for the first), where the name tells it
    metacarpal: bool
    end: bool            # an end/nub/tip word: such a leaf is an end bone, not a phalanx
    family: str          # "DEF", "ORG" or "": Rigify's deform, original and control bones of one name


def _named_finger(tokens: list[str]) -> tuple[str | None, int | None]:
    """The finger a name's words name, and the number right after that word (Thumb4, thumb.01.L, thumb_01_l)."""
    for i, token in enumerate(tokens):
        word = token[:-len("finger")] if token.endswith("finger") and token != "finger" else token  # forefinger
        if word in _FINGER_WORDS and tokens[i + 1:i + 2] != ["arm"]:  # not the fore of ForeArm
            rest = [t for t in tokens[i + 1:] if t != "finger" and t not in _SIDE_WORDS]
            return _FINGER_WORDS[word], (int(rest[0]) if rest and rest[0].isdigit() else None)
    return None, None


@functools.lru_cache(maxsize=4096)
def _finger_name(name: str) -> _FingerName | None:
    """What a name says about a finger bone or metacarpal; None when it names neither."""
    base = _strip(name)
    tokens = _tokens(base)
    words = set(tokens)
    if words & _NOT_FINGER_WORDS:
        return None
    finger, segment = _named_finger(tokens)
    number = None
    in_hand = any(tokens[i:i + 2] == ["in", "hand"] for i in range(len(tokens)))  # Perception Neuron
    metacarpal = bool(words & {"metacarpal", "palm"}) or in_hand
    if finger is None and "palm" in words:
        digits = [int(t) for t in tokens if t.isdigit()]
        finger, segment = _PALM_FINGERS.get(digits[0] if digits else 0), None
    elif finger is None:
        match = _NUMBERED_FINGER.search(base)
        if match is None:
            return None
        number = int(match.group(1))
        segment = int(match.group(2)) + 1 if match.group(2) else None
    if finger is None and number is None:
        return None
    segment = next((_SEGMENT_WORDS[t] for t in tokens if t in _SEGMENT_WORDS), segment)
    family = _RIG_PREFIX.match(_NAMESPACE.sub("", name))
    return _FingerName(finger, number, segment, metacarpal, bool(words & _END_WORDS),
                       family.group(1).upper() if family else "")


# ---------------------------------------------------------------------------
# Skeleton shape

def _depth_first(parents) -> list[int]:
    children = [[] for _ in parents]
    roots = []
    for i, parent in enumerate(parents):
        (roots if parent < 0 else children[parent]).append(i)
    order, stack = [], list(reversed(roots))
    while stack:
        i = stack.pop()
        order.append(i)
        stack.extend(reversed(children[i]))
    return order


class _Shape:
    """The rest skeleton with the measures the structural rules use."""

    def __init__(self, rig: Rig):
        self.rig = rig
        count = len(rig.names)
        self.children = [[] for _ in range(count)]
        for i, parent in enumerate(rig.parents):
            if parent >= 0:
                self.children[parent].append(i)
        self.order = _depth_first(rig.parents)
        self.info = [name_info(n) for n in rig.names]
        self.length = np.linalg.norm(rig.tails - rig.heads, axis=1)
        self.members = self._subtrees(count)
        self.ignored = self._ignored(count)
        self.kids = [[c for c in self.children[i] if not self.ignored[c]] for i in range(count)]
        kept = [i for i in range(count) if not self.ignored[i]] or list(range(count))
        z = np.concatenate([rig.heads[kept, 2], rig.tails[kept, 2]]) if count else np.zeros(1)
        self.floor = float(z.min())
        self.height = float(z.max() - z.min()) or 1.0
        self.top = [self._points(i)[:, 2].max() if count else 0.0 for i in range(count)]
        self.bottom = [self._points(i)[:, 2].min() if count else 0.0 for i in range(count)]

    def _subtrees(self, count):
        members = [[i] for i in range(count)]
        for i in reversed(self.order):
            for child in self.children[i]:
                members[i].extend(members[child])
        return [sorted(m) for m in members]

    def _ignored(self, count):
        # A helper's whole subtree (ik_foot_root -> ik_foot_l, palm -> fingers,
        # face -> ...) is left out of the shape rules, unless a bone below it is
        # named as a body part: then the names are the doubtful ones.
        ignored = [False] * count
        for i in self.order:
            if ignored[i] or not self.info[i].helper:
                continue
            below = self.members[i]
            if not any(self.info[j].keys and not self.info[j].helper for j in below):
                for j in below:
                    ignored[j] = True
        return ignored

    def _points(self, i):
        kept = [j for j in self.members[i] if not self.ignored[j]] or [i]
        return np.concatenate([self.rig.heads[kept], self.rig.tails[kept]])

    def reach(self, i, origin) -> float:
        return float(np.linalg.norm(self._points(i) - origin, axis=1).max())

    def goes_up(self, child, bone) -> bool:
        return self.top[child] > self.rig.heads[bone, 2] + 0.2 * self.height

    def goes_down(self, child, bone) -> bool:
        # Legs reach the floor; arms hanging down from the chest do not.
        return (self.bottom[child] < self.rig.heads[bone, 2] - 0.2 * self.height
                and self.bottom[child] < self.floor + 0.15 * self.height)

    def farthest_path(self, start) -> list[int]:
        """start, then at each branching the child whose subtree reaches farthest from the branching bone.

        This walks past twist leaves and picks a path through the fingers or
        toes. Distances are from the branching bone's head, not the limb's
        root: seen from the hip, the metarig's heel (on the floor) is farther
        than its toe (just above it); seen from the ankle, it is not.
        """
        path = [start]
        while self.kids[path[-1]]:
            origin = self.rig.heads[path[-1]]
            path.append(max(self.kids[path[-1]], key=lambda c: (self.reach(c, origin), -c)))
        return path


def _find_hips(shape: _Shape) -> int | None:
    for bone in shape.order:
        if shape.ignored[bone]:
            continue
        if any(shape.goes_up(c, bone) for c in shape.kids[bone]) and len(_leg_starts(shape, bone)) >= 2:
            return bone
    return None


def _up_chain(shape: _Shape, hips: int) -> list[int]:
    """From the hips up to the top of the head, following the highest-reaching child."""
    heads, tails = shape.rig.heads, shape.rig.tails
    ups = [c for c in shape.kids[hips] if shape.goes_up(c, hips)]
    if not ups:
        return []
    chain = [max(ups, key=lambda c: (shape.top[c], -c))]
    while shape.kids[chain[-1]]:
        bone = chain[-1]
        child = max(shape.kids[bone], key=lambda c: (shape.top[c], -c))
        # Face bones under the head stay below the top of the skull.
        if shape.top[child] <= max(heads[bone, 2], tails[bone, 2]) + 1e-3 * shape.height:
            break
        chain.append(child)
    return chain


def _leg_starts(shape: _Shape, hips: int) -> list[int]:
    """The first bones of the two legs below hips.

    A bone going down that the two legs branch from (Mixamo's Pelvis between
    Hips and the legs) is passed through. A leg starts at the hip: a subtree
    going down from far off (a joint parked on the floor) is none. Subtrees
    holding bones named as legs come first, so that no other bone reaching
    the floor displaces a leg its names declare; then the lowest reaching.
    """
    starts = []
    for child in shape.kids[hips]:
        if not shape.goes_down(child, hips):
            continue
        below = [c for c in shape.kids[child] if shape.goes_down(c, child)]
        named = any(k in LEG_SLOTS for k in shape.info[child].keys)
        starts += below if len(below) >= 2 and not named else [child]
    origin = shape.rig.heads[hips]
    starts = [c for c in starts if np.linalg.norm(shape.rig.heads[c] - origin) < 0.3 * shape.height]
    ranked = sorted(starts, key=lambda c: (-_named_sides(shape, c, LEG_SLOTS), shape.bottom[c], c))
    return sorted(ranked[:2])


def _named_sides(shape: _Shape, start: int, slots: tuple[str, ...]) -> int:
    """How many sides the non-helper bones of start's subtree name as limb bones of slots (0, 1 or 2)."""
    return len({shape.info[b].side for b in shape.members[start]
                if not shape.ignored[b] and shape.info[b].side and set(shape.info[b].keys) & set(slots)})


def _horizontal(v) -> np.ndarray:
    return np.array([v[0], v[1], 0.0])


def _find_chest(shape: _Shape, up: list[int]) -> tuple[int | None, list[int]]:
    """The up-chain position the arms branch from, and the arms' first bones.

    The arms are the pair of side subtrees, on opposite sides, that reach
    farthest (breast, pectoral or accessory bones reach far less).
    """
    best, best_reach = (None, []), 0.1 * shape.height
    heads = shape.rig.heads
    for position, bone in enumerate(up):
        side = [c for c in shape.kids[bone] if c not in up]
        reach = {c: shape.reach(c, heads[c]) for c in side}
        tips = {c: _horizontal(_tip(shape, c) - heads[bone]) for c in side}
        for a in side:
            for b in side:
                if a < b and float(np.dot(tips[a], tips[b])) < 0 and min(reach[a], reach[b]) > best_reach:
                    best, best_reach = (position, [a, b]), min(reach[a], reach[b])
    return best


def _tip(shape: _Shape, start: int) -> np.ndarray:
    return shape.rig.tails[shape.farthest_path(start)[-1]]


def _structural_slots(shape: _Shape, chain: list[int], slots: tuple[str, ...]) -> dict[str, int]:
    """Limb slots by length: the upper and lower limb are the two longest consecutive bones.

    slots is (before, upper, lower, end, after...): the bone before the upper
    limb is the clavicle or connector, those after it the hand, or foot and toe.
    """
    if not chain:
        return {}
    # A segment's length is from its joint to the next joint of the chain: a bone's own tail may point at
    # another child (an importer aims it at a sleeve or pant-leg joint beside the knee).
    heads = shape.rig.heads
    length = [float(np.linalg.norm(heads[chain[i + 1]] - heads[chain[i]])) if i + 1 < len(chain)
              else shape.length[chain[i]] for i in range(len(chain))]
    sums = [length[i] + length[i + 1] for i in range(len(chain) - 1)]
    upper = int(np.argmax(sums)) if sums else 0
    labels = {}
    if upper > 0:
        labels[slots[0]] = chain[upper - 1]
    for offset, slot in enumerate(slots[1:]):
        if upper + offset < len(chain):
            labels[slot] = chain[upper + offset]
    return labels


def _named_slots(shape: _Shape, chain: list[int], slots: tuple[str, ...],
                 structural: dict[str, int]) -> dict[str, int]:
    """Slots from names along the chain, in slot order.

    Among the assignments that keep slots in chain order, the one labelling
    the most bones wins; ties go to agreement with the lengths, then to each
    name's preferred reading, then to the earlier bone (the first segment of
    a split DEF-upper_arm.L / .001).
    """
    candidates = [[s for s in shape.info[b].keys if s in slots] for b in chain]

    @functools.lru_cache(maxsize=None)
    def best(i, first_slot):
        if i == len(chain):
            return (0, 0, 0), ()
        choices = []
        for rank, slot in enumerate(candidates[i]):
            k = slots.index(slot)
            if k >= first_slot:
                (count, agree, pref), rest = best(i + 1, k + 1)
                choices.append(((count + 1, agree + (structural.get(slot) == chain[i]), pref - rank),
                                ((slot, chain[i]),) + rest))
        choices.append(best(i + 1, first_slot))
        return max(choices, key=lambda c: c[0])  # max keeps the first of equals: assigning this bone

    return dict(best(0, 0)[1])


def _limb_slots(shape: _Shape, chain: list[int], slots: tuple[str, ...]) -> tuple[dict[str, int], dict[str, str]]:
    """Names where they fit the chain, lengths for the slots names leave empty."""
    structural = _structural_slots(shape, chain, slots)
    named = _named_slots(shape, chain, slots, structural)
    labels = dict(named)
    how = {slot: "name" for slot in named}
    position = {bone: i for i, bone in enumerate(chain)}
    for slot, bone in structural.items():
        if slot in labels or bone in labels.values():
            continue
        k = slots.index(slot)
        before = [position[labels[s]] for s in slots[:k] if s in labels]
        after = [position[labels[s]] for s in slots[k + 1:] if s in labels]
        if all(p < position[bone] for p in before) and all(p > position[bone] for p in after):
            labels[slot], how[slot] = bone, "structure"
    return labels, how


def _forward(shape: _Shape, legs: list[dict[str, int]]) -> np.ndarray:
    """The horizontal direction the feet point (-Y when there are no feet to tell)."""
    heads, tails = shape.rig.heads, shape.rig.tails
    total = np.zeros(3)
    for labels in legs:
        for slot in ("foot", "toe"):
            if slot in labels:
                total += _horizontal(tails[labels[slot]] - heads[labels[slot]])
    norm = np.linalg.norm(total)
    return total / norm if norm > 1e-9 else np.array([0.0, -1.0, 0.0])


def _assign_sides(shape: _Shape, chains: list[list[int]], centre, left) -> list[str]:
    """L/R for a pair of chains: from their names when these tell them apart, else from where they lie."""
    from_names = []
    for chain in chains:
        sides = {shape.info[b].side for b in chain} - {None}
        from_names.append(sides.pop() if len(sides) == 1 else None)
    if None not in from_names and len(set(from_names)) == len(chains):
        return from_names
    heads, tails = shape.rig.heads, shape.rig.tails
    lateral = [float(np.dot(np.concatenate([heads[c], tails[c]]).mean(axis=0) - centre, left)) for c in chains]
    if len(chains) == 1:
        return [from_names[0] or ("L" if lateral[0] >= 0 else "R")]
    return ["L", "R"] if lateral[0] >= lateral[1] else ["R", "L"]


def _structural_body(shape: _Shape, hips: int) -> Body:
    rig, info = shape.rig, shape.info
    names = rig.names
    body = Body(hips=names[hips], how={"hips": "name" if info[hips].keys == ("hips",) else "structure"})

    legs = [shape.farthest_path(start) for start in _leg_starts(shape, hips)]
    leg_labels = [_limb_slots(shape, chain, LEG_SLOTS) for chain in legs]
    up = _up_chain(shape, hips)
    chest, arm_starts = _find_chest(shape, up)
    arms = [shape.farthest_path(start) for start in arm_starts]
    arm_labels = [_limb_slots(shape, chain, ARM_SLOTS) for chain in arms]

    forward = _forward(shape, [labels for labels, _ in leg_labels])
    left = np.cross([0.0, 0.0, 1.0], forward)
    _label_limbs(body, shape, legs, leg_labels, rig.heads[hips], left)
    if arms:
        _label_limbs(body, shape, arms, arm_labels, rig.heads[up[chest]], left)
    _label_trunk(body, shape, up, chest)
    return body


def _label_limbs(body: Body, shape: _Shape, chains, labelled, centre, left) -> None:
    for chain, side, (labels, how) in zip(chains, _assign_sides(shape, chains, centre, left), labelled):
        for slot, bone in labels.items():
            if slot != "connector":
                body.limbs[f"{slot}.{side}"] = shape.rig.names[bone]
                body.how[f"{slot}.{side}"] = how[slot]


def _label_trunk(body: Body, shape: _Shape, up: list[int], chest: int | None) -> None:
    """Spine up to the chest, neck above it, head at the top (or the bone named head)."""
    if not up:
        return
    names, info = shape.rig.names, shape.info
    if chest is None:  # no arms: the first bone named neck or head ends the spine
        trunk_named = [i for i, b in enumerate(up) if info[b].keys in (("neck",), ("head",))]
        chest = (trunk_named[0] if trunk_named else len(up) - 1) - 1
    named_head = [i for i, b in enumerate(up) if i > chest and info[b].keys == ("head",)]
    head = named_head[0] if named_head else len(up) - 1
    if head <= chest:
        head = None
    # A segment split off its neighbour (Mixamo's Spine1_split, at rest in Mixamo's own clips) stays in the
    # chain's shape but is not one of its joints: the chain pairs bone to bone with a rig without it.
    spine = [b for b in up[:chest + 1] if not _is_split(names[b])]
    neck = [b for b in (up[chest + 1:head] if head is not None else up[chest + 1:]) if not _is_split(names[b])]
    body.spine = [names[b] for b in spine]
    body.neck = [names[b] for b in neck]
    for key, bones in (("spine", spine), ("neck", neck)):
        if bones:
            body.how[key] = "name" if all(info[b].keys == (key,) for b in bones) else "structure"
    if head is not None:
        body.head = names[up[head]]
        body.how["head"] = "name" if named_head else "structure"


def _is_split(name: str) -> bool:
    return "split" in _words(_strip(name))


def _names_only_body(shape: _Shape) -> Body:
    """No hips shape to check names against (no legs, say): the names alone, first bone in depth-first order."""
    body = Body()
    names = shape.rig.names
    for bone in shape.order:
        info = shape.info[bone]
        if shape.ignored[bone] or not info.keys:
            continue
        key = info.keys[0]
        if key == "hips" and body.hips is not None and is_ancestor(shape.rig.parents, names.index(body.hips), bone):
            body.hips = names[bone]  # joint_Root above Hips: the lower one is the body's
        elif key in ("hips", "head") and getattr(body, key) is None:
            setattr(body, key, names[bone])
            body.how[key] = "name"
        elif key in ("spine", "neck"):
            getattr(body, key).append(names[bone])
            body.how[key] = "name"
        elif key != "connector" and info.side and f"{key}.{info.side}" not in body.limbs:
            body.limbs[f"{key}.{info.side}"] = names[bone]
            body.how[f"{key}.{info.side}"] = "name"
    return body


# ---------------------------------------------------------------------------
# Fingers and twist bones, found by name below the labelled limbs

def _children(parents) -> list[list[int]]:
    children = [[] for _ in parents]
    for i, parent in enumerate(parents):
        if parent >= 0:
            children[parent].append(i)
    return children


def _depths_below(children, bone: int) -> dict[int, int]:
    """Each bone under bone (not bone itself) and how many bones down it is."""
    depth, stack = {}, [(c, 1) for c in children[bone]]
    while stack:
        b, d = stack.pop()
        depth[b] = d
        stack.extend((c, d + 1) for c in children[b])
    return depth


def _label_fingers_and_twists(body: Body, rig: Rig) -> None:
    children = _children(rig.parents)
    _label_fingers(body, rig, children)
    _label_twists(body, rig, children)


def _label_fingers(body: Body, rig: Rig, children) -> None:
    """Phalanges and metacarpals, by their names, in the subtree of each labelled hand.

    The side is the hand's. In a consistent rig the fingers' names say the
    same; where they do not (hands labelled by position in a mirrored rig),
    keeping each hand's fingers with it keeps them moving with that hand.
    """
    for side in SIDES:
        hand = body.limbs.get(f"hand.{side}")
        if hand is None:
            continue
        digits = _hand_digits(rig, children, rig.names.index(hand))
        for finger in FINGERS:
            key = f"{finger}.{side}"
            if digits.get((finger, False)):
                body.fingers[key] = [rig.names[b] for b in digits[finger, False]]
                body.how[key] = "name"
            if digits.get((finger, True)):
                body.metacarpals[key] = rig.names[digits[finger, True][0]]
                body.how[f"{finger}_metacarpal.{side}"] = "name"


def _ends_only_below(rig: Rig, children, bone: int) -> bool:
    """Whether nothing but end leaves (named end, nub, tip or site) hangs below bone."""
    for child in children[bone]:
        read = _finger_name(rig.names[child])
        if children[child] or not (_END_WORDS & set(_words(_strip(rig.names[child])))
                                   or (read is not None and read.end)):
            return False
    return True


def _hand_digits(rig: Rig, children, hand: int) -> dict[tuple[str, bool], list[int]]:
    """(finger, is metacarpal) -> its bones under hand, root to tip, end bones left out."""
    depth = _depths_below(children, hand)
    read = {}
    for bone in depth:
        found = _finger_name(rig.names[bone])
        # An end bone is a leaf past the 3rd segment (Mixamo's ...Index4) or one named end, nub or tip; a
        # leaf exporters added below it (FBX's ..._end) does not make it a phalanx.
        if found is None or (_ends_only_below(rig, children, bone) and (found.end or (found.segment or 0) > 3)):
            continue
        read[bone] = found
    # FingerN counts from 0 (Biped's Finger0 is the thumb) where there is a Finger0 or a
    # thumb named apart; otherwise from 1 (Rokoko's Finger1 is the thumb).
    offset = 0 if any(r.number == 0 or r.finger == "thumb" for r in read.values()) else 1
    groups = {}
    for bone, found in read.items():
        finger = found.finger
        if finger is None and 0 <= found.number - offset < len(FINGERS):
            finger = FINGERS[found.number - offset]
        if finger is not None:
            groups.setdefault((finger, found.metacarpal), []).append(bone)
    hand_family = _RIG_PREFIX.match(_NAMESPACE.sub("", rig.names[hand]))
    hand_family = hand_family.group(1).upper() if hand_family else ""
    return {key: _digit_chain(rig, depth, read, bones, hand_family) for key, bones in groups.items()}


def _digit_chain(rig: Rig, depth, read, bones: list[int], hand_family: str) -> list[int]:
    """One finger's bones root to tip, each below the one before.

    A generated Rigify rig has a finger thrice (DEF-thumb.01.L, ORG-thumb.01.L
    and the control thumb.01.L): the copies of the hand's own family win, then
    the deform bones, the controls, the originals.
    """
    def rank(bone):
        family = read[bone].family
        return family != hand_family, ("DEF", "", "ORG").index(family)

    best = min(rank(b) for b in bones)
    chain = []
    for bone in sorted((b for b in bones if rank(b) == best), key=lambda b: (depth[b], read[b].segment or 0, b)):
        if not chain or is_ancestor(rig.parents, chain[-1], bone):
            chain.append(bone)
    return chain


def _is_twist(name: str) -> bool:
    return any("twist" in word for word in _words(_strip(name)))


def _label_twists(body: Body, rig: Rig, children) -> None:
    """Twist bones hanging from a labelled upper arm, forearm, thigh or shin, with only twist bones below them."""
    limb_of = {body.limbs[key]: key for key in TWIST_LIMB_KEYS if key in body.limbs}
    for bone, name in enumerate(rig.names):
        parent = rig.parents[bone]
        if parent < 0 or rig.names[parent] not in limb_of or not _is_twist(name):
            continue
        if all(_is_twist(rig.names[b]) for b in _depths_below(children, bone)):
            body.twists[name] = limb_of[rig.names[parent]]


# ---------------------------------------------------------------------------
# Presets

def _read_json(path, what):
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise ValueError(f"{path}: cannot read {what}: {error}") from None


def _check_scheme(path, data) -> dict:
    def bad(why):
        raise ValueError(f"{path}: not a valid {SCHEME_FORMAT} preset: {why}")

    if not isinstance(data, dict) or data.get("format") != SCHEME_FORMAT:
        bad(f'"format" must be "{SCHEME_FORMAT}"')
    if data.get("version") != 1:
        bad(f'unsupported "version" {data.get("version")!r} (this MotionKit reads version 1)')
    if not isinstance(data.get("id"), str) or not data["id"]:
        bad('"id" must be a non-empty string')
    bones = data.get("bones")
    if not isinstance(bones, dict):
        bad('"bones" must be an object')
    for key, value in bones.items():
        if key in ("spine", "neck"):
            if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
                bad(f'"{key}" must be a list of bone names')
        elif key in ("hips", "head", "root") or key in LIMB_KEYS:
            if not isinstance(value, str):
                bad(f'"{key}" must be a bone name')
        else:
            bad(f'unknown bone key "{key}"')
    optional = data.get("optional", [])
    if not isinstance(optional, list) or not all(isinstance(v, str) for v in optional):
        bad('"optional" must be a list of bone names')
    return data


@functools.lru_cache(maxsize=1)
def _load_schemes() -> dict[str, dict]:
    found = {}
    for file in sorted(os.listdir(PRESETS_DIR)):
        if file.endswith(".json"):
            path = os.path.join(PRESETS_DIR, file)
            data = _check_scheme(path, _read_json(path, "a bone scheme"))
            if data["id"] in found:
                raise ValueError(f"{path}: scheme id {data['id']!r} is used twice")
            found[data["id"]] = data
    return found


def schemes() -> dict[str, dict]:
    """The shipped scheme presets by id (copies: changing them changes nothing here)."""
    return copy.deepcopy(_load_schemes())


def _scheme_names(scheme: dict) -> list[str]:
    bones = scheme["bones"]
    names = []
    for key, value in bones.items():
        names.extend(value if isinstance(value, list) else [value])
    return names


def _answering(rig: Rig) -> dict[str, str]:
    """Each name a preset may give -> the rig's bone answering to it.

    A bone answers to its own name and, where no other bone has the same name
    past its namespace, to that name in any namespace: a character exported
    as mixamorig6: or newVegas: answers to the Mixamo preset's mixamorig:Hips.
    """
    bases = {}
    for name in rig.names:
        bases.setdefault(_NAMESPACE.sub("", name), []).append(name)
    return {base: found[0] for base, found in bases.items() if len(found) == 1} | {n: n for n in rig.names}


def _answer(answering: dict[str, str], name: str) -> str | None:
    return answering.get(name) or answering.get(_NAMESPACE.sub("", name))


def detect_scheme(rig: Rig) -> str | None:
    """The shipped scheme all of whose (non-optional) bone names the rig has (in any namespace), or None.

    When several fit, the one naming the most of the rig's bones wins, then the first id.
    """
    answering = _answering(rig)
    fits = []
    for scheme_id, scheme in sorted(_load_schemes().items()):
        optional = set(scheme.get("optional", []))
        found = [_answer(answering, n) is not None for n in _scheme_names(scheme)]
        if all(f for f, n in zip(found, _scheme_names(scheme)) if n not in optional):
            fits.append((-sum(found), scheme_id))
    return min(fits)[1] if fits else None


def _scheme(scheme_id: str) -> dict:
    found = _load_schemes()
    if scheme_id not in found:
        raise ValueError(f"unknown bone scheme {scheme_id!r} (known: {', '.join(sorted(found))})")
    return found[scheme_id]


def _body_from_scheme(rig: Rig, scheme_id: str) -> Body:
    bones, answering = _scheme(scheme_id)["bones"], _answering(rig)
    how = f"preset:{scheme_id}"
    body = Body()
    for key, value in bones.items():
        if key in ("spine", "neck"):
            chain = [b for b in (_answer(answering, n) for n in value) if b is not None]
            setattr(body, key, chain)
            if chain:
                body.how[key] = how
        elif _answer(answering, value) is not None:
            if key in ("hips", "head", "root"):
                setattr(body, key, _answer(answering, value))
            else:
                body.limbs[key] = _answer(answering, value)
            body.how[key] = how
    return body


# ---------------------------------------------------------------------------
# Classifying and mapping

def classify(rig: Rig, *, presets: bool = True) -> Body:
    """Labels the rig's hips, spine, neck, head and limb bones, then the fingers and twist bones.

    presets=False skips the scheme presets and goes by names and shape alone.
    Fingers and twist bones are found by name below the labelled hands and
    limbs, whichever way those were found.
    """
    if presets:
        scheme_id = detect_scheme(rig)
        if scheme_id is not None:
            body = _body_from_scheme(rig, scheme_id)
            _label_floor_root(body, rig)
            _label_fingers_and_twists(body, rig)
            return body
    shape = _Shape(rig)
    hips = _find_hips(shape)
    body = _names_only_body(shape) if hips is None else _structural_body(shape, hips)
    _label_floor_root(body, rig)
    _label_fingers_and_twists(body, rig)
    return body


def is_ancestor(parents, ancestor: int, bone: int) -> bool:
    """Whether ancestor lies above bone (strictly) in a parents list."""
    while bone >= 0:
        bone = parents[bone]
        if bone == ancestor:
            return True
    return False


def _label_floor_root(body: Body, rig: Rig) -> None:
    """The top bone above the hips, if any: a game rig's root on the floor (Unreal's root, Bandai's joint_Root).

    It carries the body's ground position and facing, not the pelvis, so it is
    never mapped to a hips bone; retargeting handles it apart (see retargeting.FLOOR_ROOTS).
    """
    if body.hips is None or body.root is not None:
        return
    top = rig.names.index(body.hips)
    while rig.parents[top] >= 0:
        top = rig.parents[top]
    if rig.names[top] != body.hips:
        body.root = rig.names[top]
        body.how["root"] = "structure"


def _chain_pairs(source: list[str], target: list[str], neck: bool) -> list[tuple[str, str]]:
    if not source or not target:
        return []
    if len(source) == len(target):
        return list(zip(source, target))
    if neck:  # the head mapping already gives the neck's end
        return [(source[0], target[0])]
    if len(source) == 1 or len(target) == 1:  # a lone spine bone carries the chest
        return [(source[-1], target[-1])]
    return [(source[0], target[0]), (source[-1], target[-1])]


def _finger_pairs(source: list[str], target: list[str]) -> list[tuple[str, str]]:
    """Bone by bone when the fingers have as many phalanges, else first with first and last with last.

    The retarget interpolates the bones between; a finger of one bone is the
    whole finger, whose turn belongs to the other's first phalanx.
    """
    if not source or not target:
        return []
    if len(source) == len(target):
        return list(zip(source, target))
    if len(source) == 1 or len(target) == 1:
        return [(source[0], target[0])]
    return [(source[0], target[0]), (source[-1], target[-1])]


def _join(source: Body, target: Body, target_rig: Rig) -> list[tuple[str, str]]:
    pairs = []
    if source.root and target.root:
        pairs.append((source.root, target.root))
    if source.hips and target.hips:
        pairs.append((source.hips, target.hips))
    pairs += _chain_pairs(source.spine, target.spine, neck=False)
    pairs += _chain_pairs(source.neck, target.neck, neck=True)
    if source.head and target.head:
        pairs.append((source.head, target.head))
    pairs += [(source.limbs[k], target.limbs[k]) for k in LIMB_KEYS if k in source.limbs and k in target.limbs]
    for key in FINGER_KEYS:  # twist bones are never paired: the retarget shares the limb's twist out to them
        pairs += _finger_pairs(source.fingers.get(key, []), target.fingers.get(key, []))
        if key in source.metacarpals and key in target.metacarpals:
            pairs.append((source.metacarpals[key], target.metacarpals[key]))
    rank = {target_rig.names[b]: i for i, b in enumerate(_depth_first(target_rig.parents))}
    seen, unique = set(), []
    for pair in sorted(pairs, key=lambda p: rank[p[1]]):
        if pair[1] not in seen:  # never drive one target bone twice
            seen.add(pair[1])
            unique.append(pair)
    return unique


def auto_map(source: Rig, target: Rig) -> list[tuple[str, str]]:
    """(source bone, target bone) pairs from classifying both rigs, in target depth-first order."""
    return _join(classify(source), classify(target), target)


@dataclass
class MapReport:
    """An automatic map and, by bone name, what it leaves out: for the caller to show, never to act on.

    target_unmapped: the target's body joints (hips, spine, neck, head, limb
    bones, each finger's first phalanx) that no pair drives; they keep their
    rest. A spine of three onto one of two leaves one here; so does a limb or
    finger the source lacks.
    target_unlabelled: target bones whose names read as body joints but that
    are none of the body's labels (Mixamo's Pelvis between the hips and the
    legs, CMU's LHipJoint, a clothing collar), so nothing maps onto them.
    source_unused: the source's body joints that drive nothing.
    """
    pairs: list[tuple[str, str]]
    target_unmapped: list[str] = field(default_factory=list)
    target_unlabelled: list[str] = field(default_factory=list)
    source_unused: list[str] = field(default_factory=list)

    def message(self) -> str:
        """One line naming what is left out ("" when nothing is)."""
        parts = [f"{what}: {', '.join(names)}" for what, names in (
            ("target body joints left unmapped", self.target_unmapped),
            ("target bones named as body joints but not mapped", self.target_unlabelled),
            ("source body joints unused", self.source_unused)) if names]
        return "; ".join(parts)


def body_joints(body: Body) -> list[str]:
    """The labelled body joints of a Body: hips, spine, neck, head, limb bones, each finger's first phalanx.

    Later phalanges and metacarpals are left out: the retarget moves the
    phalanges between a finger's paired first and last bones itself.
    """
    joints = [body.hips] + body.spine + body.neck + [body.head]
    joints += [body.limbs[k] for k in LIMB_KEYS if k in body.limbs]
    joints += [body.fingers[k][0] for k in FINGER_KEYS if body.fingers.get(k)]
    return [j for j in joints if j is not None]


def _unlabelled(rig: Rig, body: Body) -> list[str]:
    """Bones whose names read as body joints (not helpers) that the body does not label, depth first."""
    labelled = set(body_joints(body)) | {body.root} | {b for f in body.fingers.values() for b in f}
    order = [rig.names[i] for i in _depth_first(rig.parents)]
    return [n for n in order if n not in labelled and name_info(n).keys and not name_info(n).helper]


def auto_map_report(source: Rig, target: Rig) -> MapReport:
    """auto_map's pairs with what they leave out (MapReport)."""
    source_body, target_body = classify(source), classify(target)
    pairs = _join(source_body, target_body, target)
    driven, driving = {t for _, t in pairs}, {s for s, _ in pairs}
    order = {n: i for i, n in enumerate(target.names[i] for i in _depth_first(target.parents))}
    return MapReport(
        pairs,
        sorted((j for j in body_joints(target_body) if j not in driven), key=order.get),
        _unlabelled(target, target_body),
        [j for j in body_joints(source_body) if j not in driving])


def map_from_presets(source: Rig, source_scheme: str, target: Rig, target_scheme: str) -> list[tuple[str, str]]:
    """(source bone, target bone) pairs from two named scheme presets, in target depth-first order."""
    bodies = []
    for rig, scheme_id in ((source, source_scheme), (target, target_scheme)):
        body = _body_from_scheme(rig, scheme_id)
        if not body.how:
            raise ValueError(f"the rig has none of the bones of scheme {scheme_id!r}")
        _label_fingers_and_twists(body, rig)
        bodies.append(body)
    return _join(bodies[0], bodies[1], target)


# ---------------------------------------------------------------------------
# Map files

def _check_pairs(pairs, where: str) -> list[tuple[str, str]]:
    checked, targets = [], set()
    for pair in pairs:
        if (not isinstance(pair, (list, tuple)) or len(pair) != 2
                or not all(isinstance(n, str) and n for n in pair)):
            raise ValueError(f"{where}: each pair must be [source bone, target bone], not {pair!r}")
        if pair[1] in targets:
            raise ValueError(f"{where}: target bone {pair[1]!r} appears twice")
        targets.add(pair[1])
        checked.append((pair[0], pair[1]))
    return checked


def save_map(path, pairs, chains=None) -> None:
    """Writes pairs as a motionkit-bone-map JSON file, with the reference pose's chain modes where given
    ({chain: "KEEP" | "MATCH"}, core/chain_modes; version 2, version 1 without them)."""
    checked = _check_pairs(list(pairs), os.fspath(path))
    data = {"format": MAP_FORMAT, "version": 1, "pairs": [list(p) for p in checked]}
    if chains:
        data.update(version=2, chains=chain_modes.check_modes(chains))
    with open(path, "w", encoding="utf-8") as f:
        json.dump(data, f, indent=1)
        f.write("\n")


def _map_file(path) -> dict:
    where = os.fspath(path)
    data = _read_json(path, "a bone map")
    if not isinstance(data, dict) or data.get("format") != MAP_FORMAT:
        raise ValueError(f'{where}: not a MotionKit bone map ("format" is not "{MAP_FORMAT}")')
    if data.get("version") not in (1, 2):
        raise ValueError(f'{where}: unsupported bone map version {data.get("version")!r} '
                         f"(this MotionKit reads versions 1 and 2)")
    if not isinstance(data.get("pairs"), list):
        raise ValueError(f'{where}: "pairs" must be a list')
    return data


def load_map(path) -> list[tuple[str, str]]:
    """The pairs of a file written by save_map; ValueError naming the file if it is not one."""
    return _check_pairs(_map_file(path)["pairs"], os.fspath(path))


def load_chains(path) -> dict:
    """The reference pose's chain modes saved with a map ({} for a version 1 file); ValueError naming the file
    for a bad one."""
    chains = _map_file(path).get("chains", {})
    try:
        return chain_modes.check_modes(chains if isinstance(chains, dict) else [chains])
    except (ValueError, TypeError) as error:
        raise ValueError(f"{os.fspath(path)}: {error}") from None
