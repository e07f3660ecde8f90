"""Which part of the target a retarget writes, and where it writes it (numpy, no bpy).

A body is cut into parts by its labels (core.bone_mapping.Body): the hips (with a floor root and anything
above them), the spine (up to the head), each arm (shoulder to forearm), each hand (the hand and its
fingers) and each leg (thigh to toe); a bone without a label takes its nearest labelled ancestor's part (a
twist bone its limb's), and a mapped bone under none (a prop) is "other". A retarget computes the whole
body, so that a part moves as it would in a whole-body retarget, and writes only the parts chosen.
"""
from __future__ import annotations

from . import bone_mapping

PARTS = ("hips", "spine", "arm.L", "arm.R", "hand.L", "hand.R", "leg.L", "leg.R", "other")
# Blender EnumProperty items (id, name, description) for the presets, and the parts each names.
PRESETS = (
    ("whole", "Whole Body", "Every mapped bone"),
    ("upper", "Upper Body", "The spine, neck and head, the arms and the hands; the hips and legs keep theirs"),
    ("arms", "Arms", "Both arms and hands, from the shoulders"),
    ("legs", "Legs", "Both legs, from the thighs to the toes"),
    ("hands", "Hands", "Both hands and their fingers"),
)
PRESET_PARTS = {
    "whole": PARTS,
    "upper": ("spine", "arm.L", "arm.R", "hand.L", "hand.R"),
    "arms": ("arm.L", "arm.R", "hand.L", "hand.R"),
    "legs": ("leg.L", "leg.R"),
    "hands": ("hand.L", "hand.R"),
}
# Where the keys go (Blender EnumProperty items): a new action, the target's own action over the clip's
# frames, or a new action on an NLA track above the target's own.
INTO = (
    ("new", "New Action", "A new action; the bones not retargeted keep the target's own keys in it"),
    ("current", "Current Action",
     "Into the target's own action over the clip's frames; its other keys and bones stay as they are"),
    ("nla", "NLA Track", "A new action on an NLA track above the target's own, blended by influence"),
)
BLENDS = (
    ("replace", "Replace", "The track replaces the bones' motion below it, by its influence"),
    ("add", "Add", "The track's rotations and moves are added on top of the motion below (Blender's Combine)"),
)


def check_parts(parts) -> tuple[str, ...]:
    """parts as a tuple of PARTS: a preset's id (PRESETS) or an iterable of parts; a ValueError names a bad
    one."""
    if isinstance(parts, str):
        if parts not in PRESET_PARTS:
            raise ValueError(f"unknown body parts preset {parts!r}; expected one of {list(PRESET_PARTS)} "
                             f"or a list of {list(PARTS)}")
        return PRESET_PARTS[parts]
    try:
        chosen = tuple(parts)
    except TypeError:
        raise ValueError(f"parts must be a preset's name or a list of body parts, not {parts!r}") from None
    unknown = [p for p in chosen if p not in PARTS]
    if unknown or not chosen:
        raise ValueError(f"unknown body part {unknown[0]!r}; expected some of {list(PARTS)}" if unknown else
                         "parts is empty: nothing would be retargeted")
    return chosen


def _labels(body: bone_mapping.Body) -> dict:
    """{bone name: part} for a body's labelled bones."""
    out = {name: "spine" for name in [*body.spine, *body.neck, body.head] if name}
    for key, name in body.limbs.items():
        slot, _, side = key.partition(".")
        out[name] = (("hand." if slot == "hand" else "arm.") if slot in bone_mapping.ARM_KEYS else "leg.") + side
    for key, names in [*body.fingers.items(), *((k, [n]) for k, n in body.metacarpals.items())]:
        for name in names:
            out[name] = "hand." + key.partition(".")[2]
    for name in (body.root, body.hips):
        if name:
            out[name] = "hips"
    return out


def part_of_bones(names, parents, body: bone_mapping.Body) -> list[str]:
    """Each bone's part (PARTS), bones parents first: its label's, else its nearest labelled ancestor's
    (twist bones hang from their limb), else "other"; bones above the hips are the hips'."""
    labels, out = _labels(body), []
    above_hips = set()
    if body.hips in names:
        b = parents[list(names).index(body.hips)]
        while b >= 0:
            above_hips.add(b)
            b = parents[b]
    for b, name in enumerate(names):
        part = "hips" if b in above_hips else labels.get(name)
        if part is None and parents[b] >= 0:
            part = out[parents[b]]
        out.append(part or "other")
    return out


def chosen_bones(parts, names, parents, body: bone_mapping.Body) -> list[int]:
    """The bones (indices, ascending) of the parts chosen (check_parts' forms)."""
    wanted = set(check_parts(parts))
    return [b for b, part in enumerate(part_of_bones(names, parents, body)) if part in wanted]
