"""How the UI tests find a label in the words read off a screenshot (tests/blender/ui/screen_text.py)."""
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "blender", "ui"))
from screen_text import cut_words, find_words, missing  # noqa: E402


def line(*texts, y=100):
    return [{"text": t, "x": 10 + 40 * i, "y": y} for i, t in enumerate(texts)]


def test_a_label_cut_by_blender_is_not_found():
    assert missing(line("Source", "Ar..."), ["Source Armature"]) == ["Source Armature"]
    assert missing(line("Regularis..."), ["Regularisation"]) == ["Regularisation"]


def test_an_ellipsis_marks_a_cut_label_however_little_is_cut():
    """One or two letters cut would pass as a slip of the reading; the ellipsis says Blender cut it."""
    assert missing(line("Iteratio\u2026"), ["Iterations"]) == ["Iterations"]
    assert missing(line("Iteration..."), ["Iterations"]) == ["Iterations"]
    assert missing(line("Natural", "Default..."), ["Natural Defaults"]) == ["Natural Defaults"]
    assert missing(line("Iterations"), ["Iterations"]) == []
    assert [w for w, _ in cut_words(line("Solver", "Iteratio\u2026", "Dam...ing", "Move", "Sm..g"))] == \
        ["Iteratio\u2026", "Dam...ing", "Sm..g"]
    assert cut_words(["(.bvh)", "Key.", "1.00"]) == []


def test_a_cut_word_is_read_with_its_neighbours_on_its_line():
    """tesseract splits a name cut in the middle at the ellipsis or an underscore: "lowe..." "torso"."""
    words = line("lowe...", "torso") + line("Spine2", y=80)
    assert cut_words(words) == [("lowe...", ["lowe...", "lowe...torso"])]
    assert cut_words(line("pelv", "...rback")) == [("...rback", ["...rback", "pelv...rback"])]


def test_a_state_is_not_mistaken_for_another():
    assert missing(line("Live:", "Off"), ["Live: On"]) == ["Live: On"]
    assert missing(line("Solve"), ["Solver"], slips=0) == ["Solver"]
    assert missing(line("Orienta..."), ["Orientation"]) == ["Orientation"]


def test_ocr_slips_are_forgiven_one_letter_in_five():
    words = line("Motion", "Capture", "(.bvh)", "[MotionkKit]")
    assert [w["text"] for w in find_words(words, "Motion Capture (.bvh) [MotionKit]")] == \
        ["Motion", "Capture", "(.bvh)", "[MotionkKit]"]
    assert missing(line("torso", "head"), ["torso_head"]) == []
    assert missing(line("SamplesperFrame_"), ["Samples per Frame"]) == []
    assert missing(line("Rotation", "Tolerence"), ["Rotation Tolerance"]) == []
    assert missing(line("Position", "Onentation"), ["Orientation"]) == []
    assert missing(line("Armature", "BYH", "File"), ["BVH File"]) == []


def test_words_must_be_side_by_side_on_one_line():
    words = line("Feet", "On", "the", "Floor", y=100) + line("Plant", y=300)
    assert missing(words, ["Plant Feet"]) == ["Plant Feet"]
    assert [w["y"] for w in find_words(words, "Feet")] == [100]
