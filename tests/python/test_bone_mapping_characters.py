"""Automatic bone maps between real Mixamo characters, which carry joints of their own beside the standard ones.

The rigs are fixtures under tests/python/data/rigs/ (dump_rigs.py wrote them in Blender 3.4):
- Aj and Kaya, MotionKit's import of ../shared/data/pairs/san/*/Running.bvh: a Pelvis between the hips and
  the legs, a facial-animation joint parked on the floor under the hips, pant legs, sleeves, hair, hats;
- girl1 (Mixamo's 65-bone skeleton, armature space Y up as Blender's FBX importer leaves it) and girl2 (its
  own 142-bone skeleton: "Left arm", "Left elbow", "Left knee"...), Blender's import of ../shared/data/pairs/fbx;
- six more characters of the SAN test set from the hierarchies the SAN repository publishes
  (data/rigs/san/*.txt): BigVegas's newVegas: prefix, capes, collars and belly; Goblin, Mousey, Mremireh and
  the Vampire's *_split shoulders and spines, HeadTop_End and Toe_End joints, Mousey's missing pinkies,
  Mremireh's three-bone fingers; SportyGranny's hood, whistle, butt and breast joints.

The truth is the joints' own names: Mixamo names the same body joint the same on every character of the set,
so each of the 22 main body joints (and each phalanx both hands have) must map onto its namesake, and nothing
else may be mapped. girl2's names are read by hand below.
"""
import itertools
import json
import os
import re

import numpy as np
import pytest

from core import bone_mapping as bm

RIGS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "rigs")
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PAIRS = os.path.join(os.path.dirname(ROOT), "shared", "data", "pairs")  # ../shared, as conftest.SHARED_BVH
SAN = ["Aj", "BigVegas", "Goblin_m", "Kaya", "Mousey_m", "Mremireh_m", "SportyGranny", "Vampire_m"]
BODY = ["Hips", "Spine", "Spine1", "Spine2", "Neck", "Head"] + [
    side + joint for side in ("Left", "Right")
    for joint in ("Shoulder", "Arm", "ForeArm", "Hand", "UpLeg", "Leg", "Foot", "ToeBase")]
PHALANGES = [f"{side}Hand{finger}{k}" for side in ("Left", "Right")
             for finger in ("Thumb", "Index", "Middle", "Ring", "Pinky") for k in (1, 2, 3)]


def load(name):
    with open(os.path.join(RIGS, f"{name}.json"), encoding="utf-8") as f:
        data = json.load(f)
    return bm.Rig(data["names"], data["parents"], data["heads"], data["tails"])


def base(name):
    return name.split(":")[-1]


def pairs_of(source, target, presets):
    if presets:
        return bm.auto_map(source, target)
    return bm._join(bm.classify(source, presets=False), bm.classify(target, presets=False), target)


def namesakes(source, target):
    """The (source, target) base names that must be paired: the body joints and phalanges both rigs have."""
    have = {base(n) for n in source.names} & {base(n) for n in target.names}
    return {(j, j) for j in BODY + PHALANGES if j in have}


@pytest.fixture(scope="module")
def san():
    return {name: load(name) for name in SAN}


@pytest.mark.parametrize("presets", [True, False], ids=["presets", "names-and-shape"])
@pytest.mark.parametrize("source, target", list(itertools.permutations(SAN, 2)))
def test_every_san_pair_maps_each_joint_onto_its_namesake_and_nothing_else(san, source, target, presets):
    pairs = pairs_of(san[source], san[target], presets)
    got = {(base(s), base(t)) for s, t in pairs}
    assert got == namesakes(san[source], san[target])
    assert len({t for _, t in pairs}) == len(pairs)  # no target bone driven twice


def test_the_set_has_what_the_names_promise(san):
    """The checks above cover what they claim: every rig has the 22 body joints and its own extras."""
    for name, rig in san.items():
        names = {base(n) for n in rig.names}
        assert set(BODY) <= names, name
    assert "BoyFacialAnim_Joint" in san["Aj"].names and "OccupyGuyFacialAnim_Joint" in san["Kaya"].names
    assert "Pelvis" in san["Aj"].names and "LeftShoulder_split" in san["Goblin_m"].names
    assert "newVegas:Hips" in san["BigVegas"].names and "Spine1_split" in san["Vampire_m"].names
    assert not any("Pinky" in n for n in san["Mousey_m"].names)


@pytest.mark.parametrize("presets", [True, False], ids=["presets", "names-and-shape"])
def test_the_issue_cases(san, presets):
    """RightUpLeg onto the facial joint, LeftShoulder onto LeftShoulder_split: two maps once made so."""
    aj_kaya = dict((t, s) for s, t in pairs_of(san["Aj"], san["Kaya"], presets))
    assert aj_kaya["RightUpLeg"] == "RightUpLeg" and aj_kaya["LeftUpLeg"] == "LeftUpLeg"
    assert "OccupyGuyFacialAnim_Joint" not in aj_kaya and "BoyFacialAnim_Joint" not in aj_kaya.values()
    kaya_goblin = dict((t, s) for s, t in pairs_of(san["Kaya"], san["Goblin_m"], presets))
    assert kaya_goblin["LeftShoulder"] == "LeftShoulder" and "LeftShoulder_split" not in kaya_goblin
    assert kaya_goblin["Spine1"] == "Spine1" and "Spine1_split" not in kaya_goblin


# girl2's own names for girl1's (Mixamo's) joints, read off the two skeletons by hand. Chest is girl2's
# top spine bone (its arms and neck hang from it), so a three-bone spine's ends pair with its two.
GIRL2 = {
    "Hips": "Hips", "Spine": "Spine", "Spine2": "Chest", "Neck": "Neck", "Head": "Head",
    **{f"{side}{mixamo}": f"{side} {own}" for side in ("Left", "Right") for mixamo, own in (
        ("Shoulder", "shoulder"), ("Arm", "arm"), ("ForeArm", "elbow"), ("Hand", "wrist"), ("UpLeg", "leg"),
        ("Leg", "knee"), ("Foot", "ankle"), ("ToeBase", "toe"))},
    **{f"{side}Hand{mixamo}{k}": f"{own}{k - offset}_{side[0]}" for side in ("Left", "Right")
       for mixamo, own, offset in (("Thumb", "Thumb", 1), ("Index", "IndexFinger", 0),
                                   ("Middle", "MiddleFinger", 0), ("Ring", "RingFinger", 0),
                                   ("Pinky", "LittleFinger", 0)) for k in (1, 2, 3)},
}


@pytest.mark.parametrize("presets", [True, False], ids=["presets", "names-and-shape"])
def test_girl1_and_girl2(presets):
    girl1, girl2 = load("girl1"), load("girl2")
    assert len(girl1.names) == 65 and len(girl2.names) == 142
    forward = {(base(s), t) for s, t in pairs_of(girl1, girl2, presets)}
    assert forward == set(GIRL2.items())
    back = {(s, base(t)) for s, t in pairs_of(girl2, girl1, presets)}
    assert back == {(own, mixamo) for mixamo, own in GIRL2.items()}


def test_reports_name_what_the_map_leaves_out(san):
    girl1, girl2 = load("girl1"), load("girl2")
    report = bm.auto_map_report(girl2, girl1)
    assert report.pairs == bm.auto_map(girl2, girl1)
    assert report.target_unmapped == ["mixamorig:Spine1"]  # three spine bones driven by two
    assert report.source_unused == [] and report.target_unlabelled == []
    assert "mixamorig:Spine1" in report.message()
    assert bm.auto_map_report(girl1, girl2).source_unused == ["mixamorig:Spine1"]

    report = bm.auto_map_report(san["Aj"], san["Kaya"])
    assert (report.target_unmapped, report.source_unused) == ([], [])
    assert report.target_unlabelled == ["Pelvis"]  # a body word, between the hips and the legs, left at rest
    report = bm.auto_map_report(san["SportyGranny"], san["Mousey_m"])
    assert report.target_unmapped == [] and report.source_unused == ["LeftHandPinky1", "RightHandPinky1"]
    report = bm.auto_map_report(san["Mousey_m"], san["Mremireh_m"])
    assert report.target_unmapped == ["LeftHandPinky1", "RightHandPinky1"]
    assert bm.auto_map_report(san["Goblin_m"], san["Vampire_m"]).message() == ""


def test_body_joints_of_every_san_character_are_labelled(san):
    """No body joint silently out: every one of the 22 is labelled (and so in body_joints), per character."""
    for name, rig in san.items():
        joints = {base(j) for j in bm.body_joints(bm.classify(rig))}
        assert set(BODY) <= joints, name


@pytest.mark.parametrize("name", [
    "LeftShoulder_split", "Spine1_split", "BoyFacialAnim_Joint", "newVegas:ElvisFacialAnim_Joint",
    "LeftPantLeg", "newVegas:Left_PantLeg", "Left_ShortSleeve", "LSleeve", "LFootTongue", "Left_Butt",
    "Bind_Left_JacketString", "newVegas:Belly", "newVegas:Left_CapeA", "Hood1", "Whistle", "Visor", "Hat",
])
def test_mixamo_extras_are_helpers(name):
    info = bm.name_info(name)
    assert info.helper and info.keys == ()


def renamed(rig, rename):
    return bm.Rig(tuple(rename(n) for n in rig.names), rig.parents, rig.heads, rig.tails)


def test_a_preset_matches_in_any_namespace():
    """A child character exported as mixamorig6: takes the Mixamo preset with its own names."""
    girl1 = load("girl1")
    child = renamed(girl1, lambda n: n.replace("mixamorig:", "mixamorig6:"))
    assert bm.detect_scheme(child) == "mixamo"
    body = bm.classify(child)
    assert body.how["thigh.R"] == "preset:mixamo" and body.limbs["thigh.R"] == "mixamorig6:RightUpLeg"
    assert bm.auto_map(girl1, child) == [(s, s.replace("mixamorig:", "mixamorig6:"))
                                         for s, _ in bm.auto_map(girl1, girl1)]
    # Two bones with one name past their namespaces: neither answers for the other.
    doubled = bm.Rig(child.names + ("other:Hips",), child.parents + (0,),
                     np.vstack([child.heads, child.heads[:1]]), np.vstack([child.tails, child.tails[:1]]))
    assert bm.detect_scheme(doubled) is None


def hierarchy_names(path):
    with open(path, encoding="utf-8") as f:
        head = f.read().split("MOTION")[0]
    return re.findall(r"(?:ROOT|JOINT)\s+(\S+)", head)


@pytest.mark.parametrize("name", ["Aj", "Kaya"])
def test_the_fixtures_are_the_shared_files(name):
    """The BVH fixtures hold the joints of ../shared's files, in the files' order."""
    path = os.path.join(PAIRS, "san", name, "Running.bvh")
    if not os.path.exists(path):
        if os.environ.get("CI") == "true":
            pytest.fail(f"{path} is missing, and CI=true requires it")
        pytest.skip(f"{path} is absent: this check needs ../shared")
    assert list(load(name).names) == hierarchy_names(path)


@pytest.mark.parametrize("name", ["Aj", "Kaya", "BigVegas", "SportyGranny"])
def test_a_joint_parked_on_the_floor_is_no_leg_whatever_its_name(san, name):
    """The facial-animation joint renamed to a word that says nothing: where it lies still keeps it off the legs."""
    rig = renamed(san[name], lambda n: "FloorJoint" if "FacialAnim" in n else n)
    assert "FloorJoint" in rig.names
    other = san["Goblin_m"]
    assert {(base(s), base(t)) for s, t in pairs_of(rig, other, presets=False)} == namesakes(rig, other)
    assert {(base(s), base(t)) for s, t in pairs_of(other, rig, presets=False)} == namesakes(other, rig)


LIMB_NAMES = {f"{key}.{side[0]}": side + joint for side in ("Left", "Right") for key, joint in (
    ("shoulder", "Shoulder"), ("upper_arm", "Arm"), ("forearm", "ForeArm"), ("hand", "Hand"),
    ("thigh", "UpLeg"), ("shin", "Leg"), ("foot", "Foot"), ("toe", "ToeBase"))}


@pytest.mark.parametrize("name", ["Aj", "Kaya", "BigVegas", "SportyGranny"])
def test_shape_alone_finds_the_legs_beside_a_joint_parked_on_the_floor(san, name):
    """Every name hidden: the Pelvis is passed through and the joint on the floor, far from the hip, is no leg."""
    rig = san[name]
    hidden = renamed(rig, lambda n: f"bone_{rig.names.index(n):03d}")
    body = bm.classify(hidden)
    real = dict(zip(hidden.names, rig.names))
    legs = {k: base(real[v]) for k, v in body.limbs.items() if k.split(".")[0] in bm.LEG_KEYS}
    assert legs == {k: v for k, v in LIMB_NAMES.items() if k.split(".")[0] in bm.LEG_KEYS}
    assert base(real[body.hips]) == "Hips"


def test_named_legs_win_over_a_longer_chain_from_the_hips(san):
    """A tail from the hips reaching lower than the feet (a cape, a tail) displaces no leg its names declare."""
    rig = san["Aj"]
    hips = rig.names.index("Hips")
    top, floor = rig.heads[hips], rig.heads[:, 2].min()
    mid, end = top + [0.0, 20.0, 0.6 * (floor - top[2])], top + [0.0, 30.0, floor - top[2] - 10.0]
    tail = bm.Rig(rig.names + ("Tail1", "Tail2"), rig.parents + (hips, len(rig.names)),
                  np.vstack([rig.heads, top, mid]), np.vstack([rig.tails, mid, end]))
    shape = bm._Shape(tail)
    assert shape.bottom[len(rig.names)] < min(shape.bottom[rig.names.index(n)] for n in ("LeftUpLeg", "RightUpLeg"))
    other = san["Kaya"]
    assert {(base(s), base(t)) for s, t in pairs_of(tail, other, presets=False)} == namesakes(tail, other)
