"""Left and right bone names (addon/core/side_names.py): each marker scheme flips, centre bones stay, a
marker without its partner is refused naming both, and explicit pairs override the names."""
import pytest

from core import side_names

FLIPS = [
    ("hand.L", "hand.R"), ("hand.R", "hand.L"), ("upperarm_l", "upperarm_r"), ("upperarm_r", "upperarm_l"),
    ("foot.l", "foot.r"), ("foot_L", "foot_R"), ("shin-L", "shin-R"), ("arm L", "arm R"),
    ("thigh.L.001", "thigh.R.001"), ("finger_r.012", "finger_l.012"),
    ("L_hand", "R_hand"), ("r_foot", "l_foot"), ("L.arm", "R.arm"), ("l.arm", "r.arm"),
    ("lHip", "rHip"), ("rTorso_Clavicle", "lTorso_Clavicle"),
    ("mixamorig:LeftHandIndex1", "mixamorig:RightHandIndex1"), ("mixamorig:RightUpLeg", "mixamorig:LeftUpLeg"),
    ("LeftArm", "RightArm"), ("hand_left", "hand_right"), ("right_toe", "left_toe"), ("HandRight", "HandLeft"),
    ("LEFT_ARM", "RIGHT_ARM"), ("ARM_RIGHT", "ARM_LEFT"), ("leftHand", "rightHand"),
    ("Left", "Right"), ("Bip01 L Thigh", "Bip01 R Thigh"),
]
CENTRES = ["hips", "Spine1", "mixamorig:Hips", "head", "Bright", "Leftover", "UPRIGHT", "upright", "root.001",
           "L", "Lamp", "Rig", "RootJoint", "lowerback_torso", "LHand"]


@pytest.mark.parametrize("name, partner", FLIPS)
def test_markers_flip_both_ways(name, partner):
    assert side_names.flip_name(name) == partner
    assert side_names.flip_name(partner) == name
    assert side_names.has_side(name)


@pytest.mark.parametrize("name", CENTRES)
def test_names_without_a_marker_are_their_own_partner(name):
    assert side_names.flip_name(name) == name
    assert not side_names.has_side(name)


def test_the_marker_at_the_end_counts_first():
    assert side_names.flip_name("L_hand.R") == "L_hand.L"
    assert side_names.flip_name("Left_arm.L") == "Left_arm.R"


def test_partners_pairs_a_whole_armature():
    names = ["hips", "spine", "thigh.L", "thigh.R", "mixamorig:LeftHand", "mixamorig:RightHand"]
    assert side_names.partners(names) == {"hips": "hips", "spine": "spine", "thigh.L": "thigh.R",
                                          "thigh.R": "thigh.L", "mixamorig:LeftHand": "mixamorig:RightHand",
                                          "mixamorig:RightHand": "mixamorig:LeftHand"}


def test_an_unpaired_marker_names_the_bone_and_the_partner_it_expects():
    with pytest.raises(ValueError, match=r"'hand\.L'.*'hand\.R' is missing.*unpaired side marker"):
        side_names.partners(["hips", "hand.L", "foot.L", "foot.R"])


def test_pairs_override_the_names():
    names = ["hips", "hand.L", "glove_right", "prop"]
    got = side_names.partners(names, pairs=[("hand.L", "glove_right")])
    assert got == {"hips": "hips", "hand.L": "glove_right", "glove_right": "hand.L", "prop": "prop"}
    assert side_names.partners(["hips", "hand.L"], pairs=[("hand.L", "hand.L")])["hand.L"] == "hand.L"


@pytest.mark.parametrize("pairs, message", [
    ([("hand.L", "nothing")], "no bone named 'nothing'"),
    ([("hand.L", "hand.R"), ("hand.L", "hips")], "'hand.L' is paired twice"),
    ([("hand.L", "hips")], "'hand.R' pairs with 'hand.L', but 'hand.L' pairs with 'hips'"),
])
def test_bad_pairs_are_refused(pairs, message):
    with pytest.raises(ValueError, match=message.replace(".", r"\.")):
        side_names.partners(["hips", "hand.L", "hand.R"], pairs=pairs)
