"""Bone names in narrow lists: the prefix all names share, said once."""
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
