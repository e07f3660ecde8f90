"""Bone names as a narrow list shows them: a prefix every name shares ("mixamorig:", "DEF-") is said once
above the list instead of on every row, so that the part that differs fits the sidebar. No bpy here."""
from __future__ import annotations

from collections.abc import Callable, Iterable

# A shared prefix is only cut at one of these, so "LeftArm"/"LeftLeg" keep "Left".
SEPARATORS = ":-_.|/"


def shared_prefix(names: Iterable[str]) -> str:
    """The longest prefix, ending in a separator, that every non-empty name has and none is wholly made of;
    '' for fewer than two names."""
    names = [n for n in names if n]
    if len(names) < 2:
        return ""
    first, last = min(names), max(names)
    common = 0
    while common < min(len(first), len(last)) and first[common] == last[common]:
        common += 1
    cut = max((first.rfind(sep, 0, common) for sep in SEPARATORS), default=-1) + 1
    if cut == 0 or any(len(n) <= cut for n in names):
        return ""
    return first[:cut]


def strip(name: str, prefix: str) -> str:
    return name[len(prefix):] if prefix and name.startswith(prefix) else name



def fit(name: str, width: int) -> str:
    """name in at most width characters: cut in the middle, where an ellipsis says so, keeping its start and
    its end (the part that tells "LeftHandIndex1" from "LeftHandIndex2": "Left\u2026ndex1" in 10)."""
    if width < 3 or len(name) <= width:
        return name
    tail = (width - 1) // 2 + 1
    return name[:width - 1 - tail] + "\u2026" + name[len(name) - tail:]


def fit_width(name: str, width: float, text_width: Callable[[str], float]) -> str:
    """name cut in the middle (as fit) to the most characters whose drawn width, by text_width, is within
    width: a column's room is in pixels, and a 'w' takes twice an 'l'."""
    chars = len(name)
    shown = name
    while chars >= 3 and text_width(shown) > width:
        chars -= 1
        shown = fit(name, chars)
    return shown
