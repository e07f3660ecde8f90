"""How the UI tests find a label in the words read off a screenshot (tests/blender/ui/screen_text.py): whole,
as a person reads it. Words here are laid out as tesseract reports them on Blender 3.4's sidebar: letters
6 px wide, 9 px tall, 4 px between the words of a label."""
import json
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "blender", "ui"))
from screen_text import count_slips, cut_words, find_words, labels, missing  # noqa: E402


def line(*texts, y=100, gap=4, x=10, block=1, h=9):
    """Words of one line, each `gap` px after the one before; a (text, gap) pair sets that word's own gap
    before it, a dict is taken as it is."""
    words, left = [], x
    for item in texts:
        text, before = item if isinstance(item, tuple) else (item, gap)
        if words:
            left += before
        width = 6 * len(text)
        words.append({"text": text, "x": left + width / 2, "y": y, "w": width, "h": h, "block": block})
        left += width
    return words


def texts(found):
    return [w["text"] for w in found]


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


def test_a_label_cut_without_its_ellipsis_read_is_not_found():
    """tesseract may read Blender's ellipsis as one period or lose it: the letters left are still too few."""
    assert missing(line("Iteratio."), ["Iterations"]) == ["Iterations"]
    assert missing(line("Iteratio"), ["Iterations"]) == ["Iterations"]
    assert missing(line("Iteration."), ["Iterations"]) == ["Iterations"]
    assert missing(line("Iteration"), ["Iterations"]) == ["Iterations"]
    assert missing(line("lterations"), ["Iterations"]) == []  # a capital I read as a small l


def test_a_word_is_not_found_inside_a_longer_one():
    assert missing(line("Solver"), ["Solve"]) == ["Solve"]
    assert missing(line("Solve"), ["Solver"]) == ["Solver"]
    assert texts(find_words(line("Solver", y=200) + line("\u2018Solve", y=100), "Solve")) == ["\u2018Solve"]
    assert texts(find_words(line("Solve", y=200) + line("Solver", y=100), "Solver")) == ["Solver"]


def test_a_button_is_not_found_in_a_longer_label_holding_its_words():
    library = line("Retarget", "Library")
    assert missing(library, ["Retarget", "Library"]) == ["Retarget", "Library"]
    assert missing(library, ["Retarget Library"]) == []
    assert missing(line("Reduce", "Keys"), ["Keys", "Reduce"]) == ["Keys", "Reduce"]
    assert missing(line("Reduce", "Keys", "[MotionKit]"), ["Reduce Keys"]) == ["Reduce Keys"]
    # The button of its own, on another line, or beside another widget on its line.
    assert texts(find_words(library + line("Retarget", y=300), "Retarget")) == ["Retarget"]
    assert missing(line("Keys", ("Every", 17), "Frame"), ["Keys", "Every Frame"]) == []
    assert missing(line("Resample", ("Reduce", 40)), ["Resample", "Reduce"]) == []


def test_labels_part_where_tesseract_parts_blocks():
    words = line("Space", block=1) + line("Channels", x=10 + 30 + 9, block=2)
    assert [texts(label) for label in labels(words)] == [["Space"], ["Channels"]]
    assert missing(words, ["Space"]) == []
    assert missing(line("Space", ("Channels", 9)), ["Space"]) == ["Space"]  # 9 px, one block: one label


def test_an_icon_read_as_letters_is_no_part_of_the_label():
    """Blender's folder icon read 'me' 7 px before "Load", a checkbox read 'W' (an icon's 15 px box) 3 px
    before "Change Rate", a panel's arrow read as a mark."""
    folder = {"text": "me", "x": 18, "y": 100, "w": 16, "h": 17, "block": 1}
    assert texts(find_words([folder] + line("Load", x=10 + 16 + 7), "Load")) == ["Load"]
    checkbox = {"text": "W", "x": 60, "y": 100, "w": 15, "h": 15, "block": 1}
    words = line("Scene", x=10) + [checkbox] + line("Change", "Rate", x=70.5)
    assert missing(words, ["Scene", "Change Rate"]) == []
    assert missing(line("\u201c", "Retarget"), ["Retarget"]) == []
    assert missing(line("Output:", "|", "Keep", "Actions"), ["Output", "Keep Actions"]) == []


def test_a_short_word_of_a_label_is_not_taken_for_an_icon():
    floor = line("On", "the", "Floor")
    assert missing(floor, ["On the Floor"]) == []
    assert missing(floor, ["the Floor"]) == ["the Floor"]
    assert missing(line("Height", "In", ("0.060", 44)), ["Height In"]) == []
    assert missing(line("Height", "In", ("0.060", 44)), ["Height"]) == ["Height"]


def test_a_state_is_not_mistaken_for_another():
    assert missing(line("Live:", "Off"), ["Live: On"]) == ["Live: On"]
    assert missing(line("Live:", "On"), ["Live: Off"]) == ["Live: Off"]
    assert missing(line("Live:", "off"), ["Live: Off"]) == []
    assert missing(line("Orienta..."), ["Orientation"]) == ["Orientation"]


def test_ocr_slips_are_forgiven_one_letter_in_five():
    words = line("Motion", "Capture", "(.bvh)", "[MotionkKit]")
    assert texts(find_words(words, "Motion Capture (.bvh) [MotionKit]")) == \
        ["Motion", "Capture", "(.bvh)", "[MotionkKit]"]
    assert missing(line("torso", "_head"), ["torso_head"]) == []
    assert missing(line("SamplesperFrame_"), ["Samples per Frame"]) == []
    assert missing(line("Clean", "Keyfra", "mes."), ["Clean Keyframes"]) == []
    assert missing(line("Rotation", "Tolerence"), ["Rotation Tolerance"]) == []
    assert missing(line("Onentation"), ["Orientation"]) == []  # 'ri' read as 'n'
    assert missing(line("Armature") + line("BYH", "File", x=100), ["BVH File"]) == []
    assert missing(line("Rotation", "Tolerence"), ["Rotation Tolerance"], slips=0) == ["Rotation Tolerance"]
    assert missing(line("Keys"), ["Keyx"]) == ["Keyx"]  # under five letters, none may be misread


def test_a_bone_name_may_lose_a_thin_letter_but_not_its_last():
    assert missing(line("Shoulder"), ["lShoulder"], name=True) == []
    assert missing(line("Shoulder"), ["lShoulder"]) == ["lShoulder"]
    assert missing(line("Spinez"), ["Spine2"], name=True) == []
    assert missing(line("lShoulde"), ["lShoulder"], name=True) == ["lShoulder"]
    assert missing(line("Solve"), ["Solver"], name=True) == ["Solver"]
    assert missing(line("Shoulde"), ["lShoulder"], name=True) == ["lShoulder"]  # two slips


def test_the_slips_counted():
    assert count_slips("BYH", "BVH") == 1
    assert count_slips("Onentation", "Orientation") == 1
    assert count_slips("\u2018Solve", "Solve") == 0
    assert count_slips("Solver", "Solve") == float("inf")
    assert count_slips("Iteratio.", "Iterations") == float("inf")
    assert count_slips("Iteratio", "Iterations") == float("inf")
    assert count_slips("Shoulder", "lShoulder", name=True) == 1


def test_a_cut_word_is_read_with_its_neighbours_on_its_line():
    """tesseract splits a name cut in the middle at the ellipsis or an underscore: "lowe..." "torso"."""
    words = line("lowe...", "torso") + line("Spine2", y=80)
    assert cut_words(words) == [("lowe...", ["lowe...", "lowe...torso"])]
    assert cut_words(line("pelv", "...rback")) == [("...rback", ["...rback", "pelv...rback"])]


def test_words_must_be_side_by_side_on_one_line():
    words = line("Feet", ("On", 27), "the", "Floor", y=100) + line("Plant", y=300)
    assert missing(words, ["Plant Feet"]) == ["Plant Feet"]
    assert [w["y"] for w in find_words(words, "Feet")] == [100]


def test_a_panels_arrow_and_checkbox_read_as_letters_are_no_part_of_its_title():
    """'“of' 5.5 px before "Plant Feet": a mark no label of Blender's has."""
    words = line("\u201cof", ("Plant", 5.5), "Feet")
    assert texts(find_words(words, "Plant Feet")) == ["Plant", "Feet"]
    assert missing(line("of", ("Plant", 5.5), "Feet"), ["Plant Feet"]) == ["Plant Feet"]


# What tesseract read on Blender 3.4's MotionKit sidebar (out/ui/3.4/panels.json, sidebar-object.words): the
# rule on a real reading, and on the same reading with a lone label taken away.
SIDEBAR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "ui_sidebar_words_3.4.json")


def sidebar_without(text, beside=None):
    """The sidebar's words without those reading text (marks aside), but where a word reading beside
    stands on their line (the longer label holding them)."""
    with open(SIDEBAR) as f:
        words = json.load(f)

    def in_longer(word):
        return beside is not None and any(w["text"] == beside and abs(w["y"] - word["y"]) < 3 for w in words)
    return [w for w in words if w["text"].strip("\u2018\u201c") != text or in_longer(w)]


def test_on_a_real_sidebar_each_label_is_found_whole():
    words = sidebar_without(None)
    assert missing(words, ["Retarget", "Retarget Library", "Keys", "Reduce Keys", "Solve", "Solver", "Iterations",
                           "Plant Feet", "Bones (no control rig)", "Live: Off", "Height In", "Keyed as 0/1 curves",
                           "Load", "Save", "Auto-map"]) == []
    assert missing(words, ["Live: On", "Iteration", "Retarget Libraries"]) == ["Live: On", "Iteration",
                                                                              "Retarget Libraries"]


def test_on_a_real_sidebar_a_lone_label_taken_away_is_missed():
    assert missing(sidebar_without("Retarget", beside="Library"), ["Retarget", "Retarget Library"]) == ["Retarget"]
    assert missing(sidebar_without("Keys", beside="Reduce"), ["Keys", "Reduce Keys"]) == ["Keys"]
    assert missing(sidebar_without("Solve"), ["Solve", "Solver"]) == ["Solve"]
    iteratio = [dict(w, text="Iteratio.") if w["text"] in ("lterations", "Iterations") else w
                for w in sidebar_without(None)]
    assert missing(iteratio, ["Iterations"]) == ["Iterations"]
