"""Finding a label in the words tesseract read off a screenshot, as a person finds it: the whole label, not
a part of a longer one. No bpy here: the scenarios (in the windowed Blender) and test_ui.py share it.

A read word is a dict: 'text', its centre 'x' and 'y', its width 'w' and height 'h' in window pixels (y up),
and the 'block' tesseract put it in.

The rule, in three parts:
- Labels. Words on one line (centres within 6 px of its mean height) belong to one label when tesseract
  put them in one block and the space between them is at most LABEL_GAP. Measured on Blender 3.4's
  screenshots at its factory UI scale: the words of one label stand 2-8 px apart, a label and the next
  widget (a field, a button, a shortcut) 9 px or more, and tesseract puts those at 9 px in blocks of their
  own. A phrase is found only as a whole label: "Retarget" is not in "Retarget Library", nor "Keys" in
  "Reduce Keys".
- Icons. Blender draws an icon 16 px square left of many labels, and tesseract reads it now and then as one
  or two letters ('me' for the folder icon, 'W' for a checkbox) in a box ICON_HEIGHT px tall or more
  (Blender's text stands at most 12 px from its capitals to its descenders), or with a typographic mark
  ('“of' for a panel's arrow and checkbox), or ICON_GAP px or more before the text (a space is 2-5 px),
  or as marks alone ('|', '~', '@'): such a word is no part of a label, and parts labels.
- Letters. The label's text and the phrase are compared letter by letter (case, spaces and punctuation
  aside: tesseract splits and joins words, reads 'Hips.' and '‘Solve'): each letter or digit read
  stands for one of the phrase, a misread one ('BYH' for 'BVH', 'lterations') costing a slip, or a pair
  stands for one, or one for a pair, from tesseract's known glyph confusions ('Onentation': 'ri' read
  'n'), costing a slip. One slip is allowed in five letters. No letter may be missing or added: "Solve"
  is not "Solver", "Iteratio" not "Iterations". A period or ellipsis never stands for a letter, and a
  label holding Blender's ellipsis (cut, "Iteratio..." or "lowe...torso") is never found.
  Bone names are no words tesseract knows, and it drops a thin letter of them now and then ('Shoulder'
  for 'lShoulder'): with name=True one letter may be missing or added, never the last one, as a slip.
"""
from __future__ import annotations

import re

# Blender's ellipsis glyph, as tesseract reads it: the glyph itself, three dots or two.
_ELLIPSIS = re.compile(r"\u2026|\.\.")
LABEL_GAP = 9.0
ICON_GAP = 6.0
ICON_HEIGHT = 13.0
# A glyph and the pair of glyphs tesseract reads for it, or the other way round, in Blender's UI font.
CONFUSED = {"m": ("rn", "in", "nn"), "n": ("ri", "ii"), "d": ("cl",), "w": ("vv",), "u": ("ii",), "h": ("li",)}
_PAIRS = {(one, pair) for one, pairs in CONFUSED.items() for pair in pairs}
_NEVER = float("inf")


def is_cut(word: str) -> bool:
    """Whether a read word shows Blender's mark of a cut label: an ellipsis. A label cut by a letter or two
    would otherwise pass as a slip of the reading ("Iteratio..." as "Iterations")."""
    return bool(_ELLIPSIS.search(word))


def _as_words(words) -> list[dict]:
    """Plain strings (as some reports give them) as words of one line, one label each."""
    if words and isinstance(words[0], str):
        return [{"text": w, "x": 100 * i, "y": 0, "w": 1} for i, w in enumerate(words)]
    return list(words)


def cut_words(words) -> list[tuple[str, list[str]]]:
    """Each read word that carries an ellipsis, with its readings joined to the word before and after it on
    its line (tesseract may split a name cut in the middle at the ellipsis or an underscore: "lowe..."
    "torso"): (word, [word, before + word, word + after])."""
    out = []
    for line in _lines(_as_words(words)):
        texts = [w["text"] for w in line]
        for i, text in enumerate(texts):
            if is_cut(text):
                joined = [text] + ([texts[i - 1] + text] if i else []) + \
                         ([text + texts[i + 1]] if i + 1 < len(texts) else [])
                out.append((text, joined))
    return out


def _alnum(text: str) -> str:
    return "".join(c for c in text.lower() if c.isalnum())


def _lines(words: list[dict]) -> list[list[dict]]:
    """Words grouped into lines (centres within a few pixels of the line's mean height: a descender moves a
    word's centre by two or three), each left to right."""
    lines: list[list[dict]] = []
    for word in sorted(words, key=lambda w: (-w["y"], w["x"])):
        if word["text"].strip():
            if lines and abs(sum(w["y"] for w in lines[-1]) / len(lines[-1]) - word["y"]) < 6:
                lines[-1].append(word)
            else:
                lines.append([word])
    return [sorted(line, key=lambda w: w["x"]) for line in lines]


def _gap(left: dict, right: dict) -> float:
    return (right["x"] - right["w"] / 2) - (left["x"] + left["w"] / 2)


def _is_icon(word: dict, after: dict | None) -> bool:
    """Whether a read word is an icon or a widget's edge read as text: no letter or digit ('|', '~'), or at
    most two in a box as tall as an icon, or with a mark no label of Blender's has ('“of': a panel's
    arrow and checkbox), or standing ICON_GAP to LABEL_GAP before the next word of its block."""
    letters = len(_alnum(word["text"]))
    if letters == 0:
        return True
    if letters > 2:
        return False
    if word.get("h", 0) >= ICON_HEIGHT or any(ord(c) > 127 and not c.isalnum() for c in word["text"]):
        return True
    return after is not None and after.get("block") == word.get("block") and \
        ICON_GAP <= _gap(word, after) <= LABEL_GAP


def labels(words) -> list[list[dict]]:
    """The read words grouped into labels (see the module's rule), top to bottom, left to right; icons
    read as text are left out, and part labels."""
    out = []
    for line in _lines(_as_words(words)):
        current: list[dict] = []
        for i, word in enumerate(line):
            after = line[i + 1] if i + 1 < len(line) else None
            if _is_icon(word, after):
                current = []
                continue
            if current and (word.get("block") != current[-1].get("block") or _gap(current[-1], word) > LABEL_GAP):
                current = []
            if not current:
                out.append(current)
            current.append(word)
    return out


def _step_cost(read: str, meant: str) -> float:
    """One read character standing for one of the phrase's."""
    if read == meant or not (read.isalnum() or meant.isalnum()):
        return 0
    if read in ".\u2026":
        return _NEVER
    return 1


def count_slips(read: str, phrase: str, name: bool = False) -> float:
    """The slips that make the read text the phrase under the module's rule (infinite where no reading
    does). Both compared in lower case, spaces out."""
    a, b = "".join(read.lower().split()), "".join(phrase.lower().split())
    last_a = max((i for i, c in enumerate(a) if c.isalnum()), default=-1)
    last_b = max((i for i, c in enumerate(b) if c.isalnum()), default=-1)
    cost = [[_NEVER] * (len(b) + 1) for _ in range(len(a) + 1)]
    cost[0][0] = 0
    for i in range(len(a) + 1):
        for j in range(len(b) + 1):
            best = cost[i][j]
            if i and not a[i - 1].isalnum():
                best = min(best, cost[i - 1][j])  # a mark read that the phrase does not have
            if j and not b[j - 1].isalnum():
                best = min(best, cost[i][j - 1])  # the phrase's mark, not read
            if i and j:
                best = min(best, cost[i - 1][j - 1] + _step_cost(a[i - 1], b[j - 1]))
            if i >= 2 and j and (b[j - 1], a[i - 2:i]) in _PAIRS:
                best = min(best, cost[i - 2][j - 1] + 1)
            if i and j >= 2 and (a[i - 1], b[j - 2:j]) in _PAIRS:
                best = min(best, cost[i - 1][j - 2] + 1)
            if name and i and a[i - 1].isalnum() and i - 1 != last_a:
                best = min(best, cost[i - 1][j] + 1)  # a letter of a name read twice or from a neighbour
            if name and j and b[j - 1].isalnum() and j - 1 != last_b:
                best = min(best, cost[i][j - 1] + 1)  # a thin letter of a name lost
            cost[i][j] = best
    return cost[len(a)][len(b)]


def _allowed(phrase: str, slips: int | None, name: bool) -> int:
    if slips is not None:
        return slips
    return 1 if name else len(_alnum(phrase)) // 5


def find_words(words: list[dict], phrase: str, slips: int | None = None, name: bool = False) -> list[dict]:
    """The read words that make up phrase as one whole label (see the module's rule), the first such label
    from the top; [] when the phrase is not on screen whole. slips: the slips allowed instead of one in five
    letters; name: the phrase is a bone's name (a thin letter may be lost)."""
    if not _alnum(phrase):
        return []
    allowed = _allowed(phrase, slips, name)
    for label in labels(words):
        if not any(is_cut(w["text"]) for w in label) and \
                count_slips("".join(w["text"] for w in label), phrase, name) <= allowed:
            return label
    return []


def missing(words: list[dict], phrases, slips: int | None = None, name: bool = False) -> list[str]:
    """The phrases not found whole (see find_words)."""
    return [phrase for phrase in phrases if not find_words(words, phrase, slips, name)]
