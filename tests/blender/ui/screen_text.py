"""Finding a label in the words tesseract read off a screenshot, as a person finds it: whole, its words side
by side in order. No bpy here: the scenarios (in the windowed Blender) and test_ui.py share it."""
from __future__ import annotations

import re


# Blender's ellipsis glyph, as tesseract reads it: the glyph itself, three dots or two.
_ELLIPSIS = re.compile(r"\u2026|\.\.")


def is_cut(word: str) -> bool:
    """Whether a read word shows Blender's mark of a cut label: an ellipsis. A label cut by a letter or two
    would otherwise pass as a slip of the reading ("Iteratio..." as "Iterations")."""
    return bool(_ELLIPSIS.search(word))


def cut_words(words) -> list[tuple[str, list[str]]]:
    """Each read word that carries an ellipsis, with its readings joined to the word before and after it on
    its line (tesseract may split a name cut in the middle at the ellipsis or an underscore: "lowe..."
    "torso"): (word, [word, before + word, word + after]). words: dicts with positions or plain strings
    (read in order, as one line)."""
    if words and isinstance(words[0], str):
        words = [{"text": w, "x": i, "y": 0} for i, w in enumerate(words)]
    out = []
    for line in _lines(words):
        texts = [w["text"] for w in line]
        for i, text in enumerate(texts):
            if is_cut(text):
                joined = [text] + ([texts[i - 1] + text] if i else []) + \
                         ([text + texts[i + 1]] if i + 1 < len(texts) else [])
                out.append((text, joined))
    return out


def _norm(word: str) -> str:
    return re.sub(r"[^0-9a-z]", "", word.lower())


def _lines(words: list[dict]) -> list[list[dict]]:
    """Words grouped into lines (centres within a few pixels of the line's mean height: a descender moves a
    word's centre by two or three), each left to right."""
    lines: list[list[dict]] = []
    for word in sorted(words, key=lambda w: (-w["y"], w["x"])):
        if _norm(word["text"]):
            if lines and abs(sum(w["y"] for w in lines[-1]) / len(lines[-1]) - word["y"]) < 6:
                lines[-1].append(word)
            else:
                lines.append([word])
    return [sorted(line, key=lambda w: w["x"]) for line in lines]


def _distance(a: str, b: str) -> int:
    """Levenshtein: the letters inserted, removed or changed to make a into b."""
    row = list(range(len(b) + 1))
    for i, ca in enumerate(a, 1):
        previous, row[0] = row[0], i
        for j, cb in enumerate(b, 1):
            previous, row[j] = row[j], min(row[j] + 1, row[j - 1] + 1, previous + (ca != cb))
    return row[len(b)]


def find_words(words: list[dict], phrase: str, slips: int | None = None) -> list[dict]:
    """The read words that make up phrase: consecutive words of one line whose letters and digits, joined,
    differ from the phrase's by at most one letter in five whole ones (OCR misreads a letter now and then, 'BYH'
    or 'Onentation', and splits or joins words at '_' or spaces; 'Live: On' is not 'Live: Off'). A word with
    an ellipsis is never part of a match: Blender cut that label.
    [] when the phrase is not on screen whole. slips: the letters allowed to differ, instead."""
    wanted = _norm(phrase)
    if not wanted:
        return []
    allowed = len(wanted) // 5 if slips is None else slips
    for line in _lines(words):
        names = [_norm(w["text"]) for w in line]
        for i in range(len(line)):
            joined = ""
            for j in range(i, len(line)):
                if is_cut(line[j]["text"]):
                    break
                joined += names[j]
                if len(joined) > len(wanted) + 3:
                    break
                if _distance(joined, wanted) <= allowed:
                    return line[i:j + 1]
    return []


def missing(words: list[dict], phrases, slips: int | None = None) -> list[str]:
    """The phrases not found whole; words may be dicts with positions or, as reported, plain strings (read
    left to right, top to bottom)."""
    if words and isinstance(words[0], str):
        words = [{"text": w, "x": i, "y": 0} for i, w in enumerate(words)]
    return [phrase for phrase in phrases if not find_words(words, phrase, slips)]


