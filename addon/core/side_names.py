"""Left and right bone names: which bones pair across a character's plane of symmetry (pure Python).

A name carries a side marker, checked in this order, the first that applies counting:
- a single L, R, l or r after a separator (. _ - or a space) at the end: `hand.L`, `upperarm_l`, `foot R`,
  also before a `.001` style number, as Blender numbers copies (`thigh.L.001`);
- the same letter before a separator at the start: `L_hand`, `r_foot`, `L.arm`, or a lower-case l or r
  before a capital, as BVH captures name joints: `lHip`, `rShoulder`;
- the same letter between two separators, as 3ds Max's Biped names bones: `Bip01 L Thigh`;
- the word Left or Right, spelt `Left`, `left` or `LEFT` (or Right alike), anywhere: `mixamorig:LeftHand`,
  `hand_left`, `LEFT_ARM`. The word stands alone so that `Bright`, `Leftover` or `UPRIGHT` carry none:
  `left` with no letter either side, `Left` with no lower-case letter after it, `LEFT` with no capital
  either side.
Blender's own rule (bpy.utils.flip_name) is the same for the first two; it takes Left and Right only at
the start or the end of a name, which misses Mixamo's `mixamorig:LeftHandIndex1`.

flip_name gives the partner's name, the name itself for a centre bone (no marker). partners pairs a whole
armature and refuses a marker whose partner is missing.
"""
from __future__ import annotations

import re

SEPARATORS = "._- "
_LETTER = {"L": "R", "R": "L", "l": "r", "r": "l"}
_WORD = {"Left": "Right", "Right": "Left", "left": "right", "right": "left", "LEFT": "RIGHT", "RIGHT": "LEFT"}
_WORDS = re.compile(r"(?<![A-Za-z])(?:left|right)(?![a-z])|(?:Left|Right)(?![a-z])|(?<![A-Z])(?:LEFT|RIGHT)(?![A-Z])")
_NUMBER = re.compile(r"\.\d+$")
_INNER_LETTER = re.compile(f"(?<=[{re.escape(SEPARATORS)}])[LRlr](?=[{re.escape(SEPARATORS)}])")


def flip_name(name: str) -> str:
    """The name of the bone on the other side: the first side marker (see the module) swapped; the name
    itself when it has none."""
    number = _NUMBER.search(name)
    base, tail = (name[:number.start()], name[number.start():]) if number else (name, "")
    if len(base) > 1 and base[-2] in SEPARATORS and base[-1] in _LETTER:
        return base[:-1] + _LETTER[base[-1]] + tail
    if len(name) > 1 and name[0] in _LETTER and (name[1] in SEPARATORS or (name[0].islower() and name[1].isupper())):
        return _LETTER[name[0]] + name[1:]
    letter = _INNER_LETTER.search(base)
    if letter is not None:
        return base[:letter.start()] + _LETTER[letter.group()] + base[letter.end():] + tail
    word = _WORDS.search(base)
    if word is not None:
        return base[:word.start()] + _WORD[word.group()] + base[word.end():] + tail
    return name


def has_side(name: str) -> bool:
    """Whether the name carries a side marker."""
    return flip_name(name) != name


def partners(names, pairs=None) -> dict[str, str]:
    """{name: its partner's name} for every name, a centre bone its own partner.

    pairs: (a, b) name pairs that override the markers, each bone in at most one pair ((a, a) mirrors a
    onto itself). Raises ValueError naming the bone and the partner it expects when a bone has a side
    marker but no bone of that name is among names (an unpaired side marker scheme), or when pairs name a
    bone that is not there, name one twice, or leave a bone whose partner pairs with another.
    """
    names = list(names)
    present = set(names)
    chosen: dict[str, str] = {}
    for a, b in pairs or ():
        for name in {a, b}:
            if name not in present:
                raise ValueError(f"pairs: there is no bone named '{name}'")
            if name in chosen:
                raise ValueError(f"pairs: bone '{name}' is paired twice")
        chosen[a], chosen[b] = b, a
    out = {}
    for name in names:
        partner = chosen.get(name, flip_name(name))
        if partner not in present:
            raise ValueError(f"bone '{name}' has a side marker but its partner '{partner}' is missing (an unpaired "
                             f"side marker scheme): rename one of them, or pair them with pairs=[('{name}', ...)]")
        out[name] = partner
    for name, partner in out.items():
        if out[partner] != name:
            raise ValueError(f"bone '{name}' pairs with '{partner}', but '{partner}' pairs with "
                             f"'{out[partner]}': give both in pairs")
    return out
