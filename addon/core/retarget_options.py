"""The retarget's options as one value: RetargetOptions, which the Retarget panel fills and
motionkit.retarget / retargeting.plan take (their keywords build or replace its fields).

Plain data, no Blender: validate() refuses a bad value with a ValueError naming the option and the
value, before any rig or file is read, so that a mistake leaves the scene as it was. The bone map and
the frame range are the call's data, not options: they stay arguments of the call (check_frame_range
checks the latter's form; whether it holds frames of the action is for the caller to see).
"""
from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass

import numpy as np

from . import channel_carry, retarget_parts
from .chain_modes import check_modes
from .props import SPACES
from .foot_contacts import ContactSettings
from .root_motion import FLOOR_ROOTS

# Blender EnumProperty items (id, name, description): the panel shows these, validate() accepts the ids.
FLOOR_FITS = (
    ("legs", "Hips and Legs",
     "The hips' height and, where the rigs' legs differ, the legs put each foot where the source's stands above "
     "its floor (scaled), never into the ground"),
    ("hips", "Hips",
     "Only the hips' height: the legs point exactly as the source's, a foot may stand a little off the floor"),
    ("off", "Off", "The hips at the source's height above its floor, scaled; nothing else"),
    ("first_frame", "First Frame",
     "The whole clip moved once so that the target's lowest point touches its floor on the first frame: the "
     "clip's own heights kept, no frame's feet fitted apart"),
)
ROOT_MOTIONS = (
    ("scaled", "Scaled", "Translation scaled by the ratio of how high the rigs' hips stand"),
    ("in_place", "In place", "Keep only the vertical motion (scaled)"),
    ("offset", "Offset Height",
     "Horizontal translation scaled, vertical as the source's plus the difference in hip height"),
    ("none", "None", "The root stays where the match pose has it"),
)
SOURCE_MATCHES = (
    ('REST', "Rest pose", "The source's rest pose is its reference pose"),
    ('FRAME', "Frame", "The source's pose on a frame (say a T-pose on frame 0) is its reference pose"),
)
# Where the target's travel goes (RetargetOptions.root_motion_onto): game engines take root motion from a root
# bone (Unreal) or from the object; the ids are what validate() accepts.
ROOT_MOTION_ONTO = (
    ("auto", "Auto", "As the floor root option says: the hips carry the motion, a root bone above them as chosen"),
    ("hips", "Hips", "The hips carry all the motion; a root bone above them stays still"),
    ("root", "Root Bone",
     "The root bone above the hips follows the hips' ground path and heading, smoothed, on the floor and "
     "unrotated about the other axes (Unreal's root motion); the hips keep the rest"),
    ("object", "Object",
     "The armature object is keyed with the hips' ground path and heading, smoothed; the hips keep the rest, "
     "so the world pose is the same"),
)
# What root_motion_onto leaves the floor root (FLOOR_ROOTS) free to be: "auto" any, the others their own.
_ONTO_FLOOR_ROOT = {"hips": "still", "root": "extract", "object": "still"}
# Whether the target's forearms and hands are kept out of its own body (RetargetOptions.body; docs/body.md).
BODY_MODES = (
    ("auto", "Auto",
     "Where the target has a skinned mesh, a forearm or hand that would go into its own body (the trunk, head "
     "or thighs) is swung out at the shoulder and elbow, the hand's direction kept"),
    ("off", "Off", "The bones only, whatever the mesh"),
)
TARGET_MATCHES = (
    ('REST', "Rest pose", "The target's rest pose is its reference pose"),
    ('CURRENT', "Current pose", "The target's current pose, set to stand like the source's reference pose"),
)

# The options the reference pose depends on (RetargetOptions.reference): what Auto decides per chain,
# and which bones keep their posture, read from these alone.
REFERENCE = ("source_match", "match_frame", "target_match", "align_facing", "chain_modes")


@dataclass
class RetargetOptions:
    """How the source's motion is laid on the target (see motionkit.retarget for the whole story)."""
    # How the hips travel (ROOT_MOTIONS): "scaled" by the ratio of how high each rig's hips stand,
    # "in_place" (only the vertical motion), "offset" (vertical as the source's plus the difference in
    # hip height) or "none" (the root stays where the match pose has it).
    root: str = "scaled"
    # The travel across the floor ("scaled", "offset") times this, on top of the rigs' ratio: for a character
    # whose stride its proportions do not give (Mixamo's path scales by a factor of each character's own that
    # no skeleton measure gives, docs/benchmarks.md); Unreal's "Scale Horizontal". The height is not touched.
    scale_horizontal: float = 1.0
    # The poses in which the two rigs stand alike: the source's 'REST' pose or its pose on match_frame
    # ('FRAME'), and the target's 'REST' or 'CURRENT' pose (SOURCE_MATCHES, TARGET_MATCHES).
    source_match: str = 'REST'
    match_frame: float | None = None
    target_match: str = 'REST'
    # Turn the motion so that each rig walks the way it faces.
    align_facing: bool = True
    # What a target's bone on the floor above the hips (Unreal's root) does (FLOOR_ROOTS): "auto",
    # "still", "copy" or "extract"; root_smoothing: seconds of Gaussian smoothing for "extract".
    floor_root: str = "auto"
    root_smoothing: float = 0.25
    # Where the target's travel ends up (ROOT_MOTION_ONTO): "auto" (floor_root decides), "hips", "root" (the
    # root bone above the hips, extracted) or "object" (the armature object keyed, the hips the rest);
    # anything but "auto" sets the floor root's motion itself (floor_root then "auto" or that same motion).
    root_motion_onto: str = "auto"
    # Feet that stand still in the source stay planted on the target (contacts detected on the source,
    # held by full-body IK): None plants where both rigs have two labelled legs, True requires them,
    # False never; contact_settings tunes the detection (None: foot_contacts.ContactSettings()).
    plant_feet: bool | None = None
    contact_settings: ContactSettings | None = None
    # The floors' world Z heights; None: each rig's rest soles (see core/floor.py).
    source_floor: float | None = None
    target_floor: float | None = None
    # How the feet are put on the target's floor where the source's stand on its own (FLOOR_FITS):
    # "legs" (hips and legs), "hips" (the legs keep the source's directions exactly), "off", or
    # "first_frame" (the whole clip moved once so that the target's lowest point touches its floor on the
    # first frame, the clip's heights kept: what the keyword ground=True asked for).
    floor_fit: str = "legs"
    # {chain: "KEEP" | "MATCH"} (core/chain_modes.CHAINS): whether the target keeps its own posture (its
    # spine's curve, its knees' bend) or takes the source's direction; None or a chain left out: Auto.
    chain_modes: dict | None = None
    # Which parts of the target are written (retarget_parts: a preset such as "arms", or a list of PARTS),
    # or bones, the target bones by name (given, it replaces parts): the others keep their own keys.
    parts: str | tuple = "whole"
    # A prop under one hand that the source's other hand holds (a rifle): the target's other hand put where
    # the source's holds it, relative to the prop and scaled (core.two_hands), whatever its arms' lengths.
    two_hands: bool = True
    # How a mapped bone that is no body part (a prop) moves (core.props.SPACES): "bone" as any mapped bone,
    # or as the source's moves in its "hand", about its "root" (the hips) or in the "world" (its armature).
    prop_space: str = "bone"
    # A forearm or hand that goes into the target's own body brought back out (BODY_MODES): "auto" where
    # the target has a skinned mesh, "off"; body_strength the share of that correction applied (0..1).
    # body_touches: where the source's hand touches its own body (both rigs skinned), the target's is
    # brought onto its own.
    body: str = "auto"
    body_strength: float = 1.0
    body_touches: bool = True
    bones: tuple | None = None
    # Where the keys go (retarget_parts.INTO): a "new" action, the target's "current" action over the clip's
    # frames, or an "nla" track above it, its blend ("replace" or "add") and influence (0..1).
    into: str = "new"
    blend: str = "replace"
    influence: float = 1.0
    # What is carried besides the bones' rotations and the root's path (channel_carry.CHANNELS): "scale" (each
    # mapped bone's), "properties" (animated custom properties of the mapped bones and of the object) and
    # "shape_keys" (the values of the source's meshes' shape keys); () carries none of them. Each goes where the
    # target has one of the same name, channel_map's {source name: target name} renaming properties and shape
    # keys; the others are left out and reported (Plan.channels_left_out).
    channels: tuple = channel_carry.IDS
    channel_map: dict | None = None

    def validate(self) -> RetargetOptions:
        """self, every value checked: a ValueError naming the option and the value."""
        for name, value, known in (("floor_fit", self.floor_fit, FLOOR_FITS),
                                   ("root motion", self.root, ROOT_MOTIONS),
                                   ("floor root motion", self.floor_root, FLOOR_ROOTS),
                                   ("root_motion_onto", self.root_motion_onto, ROOT_MOTION_ONTO),
                                   ("body", self.body, BODY_MODES)):
            if value not in [k[0] for k in known]:
                raise ValueError(f"unknown {name} {value!r}; expected one of {[k[0] for k in known]}")
        implied = _ONTO_FLOOR_ROOT.get(self.root_motion_onto)
        if implied is not None and self.floor_root not in ("auto", implied):
            raise ValueError(f"root_motion_onto {self.root_motion_onto!r} moves the floor root itself "
                             f"({implied!r}): floor_root must be 'auto' or {implied!r}, not {self.floor_root!r}")
        stride = self.scale_horizontal
        if not (is_number(stride) and np.isfinite(stride) and stride >= 0):
            raise ValueError(f"scale_horizontal must be a non-negative number, not {self.scale_horizontal!r}")
        smoothing = self.root_smoothing
        if not (is_number(smoothing) and np.isfinite(smoothing) and smoothing >= 0):
            raise ValueError(f"root_smoothing must be a non-negative number of seconds, not {smoothing!r}")
        for name, value, known in (("source_match", self.source_match, SOURCE_MATCHES),
                                   ("target_match", self.target_match, TARGET_MATCHES)):
            if value not in [k[0] for k in known]:
                raise ValueError(f"unknown match pose {name} {value!r}; expected one of {[k[0] for k in known]}")
        if self.match_frame is not None and not (is_number(self.match_frame) and np.isfinite(self.match_frame)):
            raise ValueError(f"match_frame must be a frame number or None, not {self.match_frame!r}")
        if self.source_match == 'FRAME' and self.match_frame is None:
            raise ValueError("a source match pose on a frame needs match_frame")
        if not isinstance(self.plant_feet, (bool, np.bool_, type(None))):
            raise ValueError(f"plant_feet must be True, False or None, not {self.plant_feet!r}")
        for name, value in (("align_facing", self.align_facing), ("two_hands", self.two_hands),
                            ("body_touches", self.body_touches)):
            if not isinstance(value, (bool, np.bool_)):
                raise ValueError(f"{name} must be True or False, not {value!r}")
        for name, value in (("source_floor", self.source_floor), ("target_floor", self.target_floor)):
            if value is not None and not (is_number(value) and np.isfinite(value)):
                raise ValueError(f"{name} must be a height in metres or None, not {value!r}")
        if self.contact_settings is not None and not isinstance(self.contact_settings, ContactSettings):
            raise ValueError(f"contact_settings must be a ContactSettings, not {self.contact_settings!r}")
        check_modes(self.chain_modes)
        self._validate_output()
        return self

    def _validate_output(self) -> None:
        retarget_parts.check_parts(self.parts)
        if self.bones is not None and (isinstance(self.bones, str) or not all(isinstance(b, str) for b in self.bones)
                                       or not len(self.bones)):
            raise ValueError(f"bones must be a non-empty list of target bone names or None, not {self.bones!r}")
        for name, value, known in (("into", self.into, retarget_parts.INTO), ("prop_space", self.prop_space, SPACES),
                                   ("blend", self.blend, retarget_parts.BLENDS)):
            if value not in [k[0] for k in known]:
                raise ValueError(f"unknown {name} {value!r}; expected one of {[k[0] for k in known]}")
        for name in ("influence", "body_strength"):
            value = getattr(self, name)
            if not (is_number(value) and 0.0 <= value <= 1.0):
                raise ValueError(f"{name} must be a number from 0 to 1, not {value!r}")
        channel_carry.check_channels(self.channels)
        channel_carry.check_channel_map(self.channel_map)

    def reference(self) -> RetargetOptions:
        """These options as the reference pose sees them: its own (REFERENCE) kept, the others the
        defaults, so that the chains decided never depend on options that only move the clip."""
        return RetargetOptions(**{name: getattr(self, name) for name in REFERENCE})


NAMES = tuple(f.name for f in dataclasses.fields(RetargetOptions))


def from_keywords(options: RetargetOptions | None = None, **keywords) -> RetargetOptions:
    """options (default: the defaults) with keywords replacing its fields; not validated (validate() is
    the caller's, where it wants the error). An unknown keyword is a TypeError naming it, as a call's."""
    if isinstance(options, str):  # scripts pass the root motion fifth: plan(source, target, map, range, "none")
        options, keywords = None, {"root": options, **keywords}
    if options is not None and not isinstance(options, RetargetOptions):
        raise TypeError(f"options must be a RetargetOptions, not {options!r}")
    if "ground" in keywords:
        keywords = _without_ground(keywords)
    unknown = sorted(set(keywords) - set(NAMES))
    if unknown:
        raise TypeError(f"unknown retarget option {unknown[0]!r}; expected one of {list(NAMES)}")
    return dataclasses.replace(options or RetargetOptions(), **keywords)


def _without_ground(keywords: dict) -> dict:
    """keywords with the old ground= said as floor_fit (ground=True is floor_fit="first_frame"), and a
    DeprecationWarning that says so; a ValueError where it is no bool or floor_fit says otherwise."""
    keywords = dict(keywords)
    ground = keywords.pop("ground")
    if not isinstance(ground, (bool, np.bool_)):
        raise ValueError(f"ground must be True or False, not {ground!r}")
    warnings.warn("retarget option ground= is floor_fit= now: ground=True is floor_fit='first_frame', "
                  "ground=False the floor_fit given (default 'legs')", DeprecationWarning, stacklevel=3)
    if ground:
        if keywords.get("floor_fit", "first_frame") != "first_frame":
            raise ValueError(f"ground=True and floor_fit={keywords['floor_fit']!r} say different things: "
                             "ground=True is floor_fit='first_frame'; give floor_fit alone")
        keywords["floor_fit"] = "first_frame"
    return keywords


def check_frame_range(frame_range) -> None:
    """frame_range's form: None or (first, last) finite frame numbers."""
    if frame_range is not None and not (isinstance(frame_range, (tuple, list)) and len(frame_range) == 2
                                        and all(is_number(f) and np.isfinite(f) for f in frame_range)):
        raise ValueError(f"frame_range must be (first, last) frames, not {frame_range!r}")


def is_number(value) -> bool:
    """A real number, a bool excepted (True is no number of seconds or metres)."""
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))
