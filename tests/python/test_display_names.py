"""Bone names in narrow lists: the prefix all names share, said once."""
from core import display_names
from core.display_names import SEPARATORS, shared_prefix, strip


def test_mixamo_prefix_is_said_once():
    names = ["mixamorig:Hips", "mixamorig:LeftForeArm", "mixamorig:RightUpLeg"]
    assert shared_prefix(names) == "mixamorig:"
    assert [strip(n, "mixamorig:") for n in names] == ["Hips", "LeftForeArm", "RightUpLeg"]


def test_prefix_is_cut_only_at_a_separator():
    assert shared_prefix(["LeftArm", "LeftLeg"]) == ""
    assert shared_prefix(["DEF-upper_arm.L", "DEF-upper_arm.R", "DEF-spine"]) == "DEF-"
    assert shared_prefix(["upper_arm.L", "upper_arm.R"]) == "upper_arm."


def test_no_prefix_for_one_name_for_a_name_that_is_only_the_prefix_or_for_none():
    assert shared_prefix(["mixamorig:Hips"]) == ""
    assert shared_prefix(["DEF-", "DEF-spine"]) == ""
    assert shared_prefix(["Hips", "Spine"]) == ""
    assert shared_prefix(["", "a:b", "a:c"]) == "a:"
    assert shared_prefix([]) == ""


def test_strip_leaves_other_names_alone():
    assert strip("root", "mixamorig:") == "root"
    assert strip("x", "") == "x"
    assert all(shared_prefix([f"a{sep}b", f"a{sep}c"]) == f"a{sep}" for sep in SEPARATORS)


def test_fit_cuts_long_names_in_the_middle_so_a_hands_rows_stay_apart():
    fingers = [f"LeftHand{f}{k}" for f in ("Thumb", "Index", "Middle", "Ring", "Pinky") for k in (1, 2, 3)]
    shown = [display_names.fit(n, 10) for n in fingers]
    assert len(set(shown)) == len(fingers)
    assert all(len(s) <= 10 and s.startswith("Left") and "\u2026" in s for s in shown)
    assert display_names.fit("LeftHandIndex1", 10) == "Left\u2026ndex1"
    assert display_names.fit("Hips", 10) == "Hips" and display_names.fit("LeftHand", 2) == "LeftHand"


def test_fit_width_cuts_to_the_room_the_letters_take():
    def text_width(text):  # a proportional font: narrow l and i, wide w and m
        return sum(3 if c in "li" else 10 if c in "wm" else 6 for c in text)
    assert display_names.fit_width("pelvis_lowerback", 200, text_width) == "pelvis_lowerback"
    shown = display_names.fit_width("pelvis_lowerback", 70, text_width)
    assert text_width(shown) <= 70 and text_width(display_names.fit("pelvis_lowerback", len(shown) + 1)) > 70
    assert shown.startswith("pel") and shown.endswith("ack") and "\u2026" in shown
    assert len(display_names.fit_width("l" * 30, 70, text_width)) > len(display_names.fit_width("w" * 30, 70, text_width))
