"""Automatic bone mapping (addon/bone_mapping.py) on rigs whose true labels are known.

The sample characters (blend_samples/characters.py) carry each bone's canonical
label, so every classification and every mapping is checked against ground
truth: with their own names, with the names hidden (shape alone), renamed to
other schemes (CMU, GAMES-105, Unreal with helpers), turned round and mirrored.
"""
import dataclasses
import itertools
import json

import numpy as np
import pytest

from core import bone_mapping as bm
import characters

SPECS = {s.name: s for s in characters.CHARACTERS}
SCHEME_OF = {"MixamoT": "mixamo", "RigifyA": "rigify_metarig", "UnrealA": "unreal"}


# ---------------------------------------------------------------------------
# Building rigs with known labels

@dataclasses.dataclass
class Known:
    """A Rig and each bone's canonical label ("hips", "spine.2", "thigh.L"...; None for extras)."""
    rig: bm.Rig
    canonical: dict

    def label(self, name):
        return self.canonical[name]

    def name(self, canonical):
        return next(n for n, c in self.canonical.items() if c == canonical)


def from_bones(bones, rename=None, transform=None, extra=()):
    """A Known from BoneSpecs plus extra (name, parent, head, tail) bones; rename(i, name) hides names."""
    rows = [(b.name, b.parent, b.head, b.tail, b.canonical) for b in bones]
    rows += [(name, parent, head, tail, None) for name, parent, head, tail in extra]
    new = {row[0]: (rename(i, row[0]) if rename else row[0]) for i, row in enumerate(rows)}
    move = transform or (lambda p: p)
    rig = bm.Rig.from_parent_names([new[r[0]] for r in rows], [new[r[1]] if r[1] else None for r in rows],
                                   [move(np.array(r[2], float)) for r in rows],
                                   [move(np.array(r[3], float)) for r in rows])
    return Known(rig, {new[r[0]]: r[4] for r in rows})


def anonymous(i, name):
    return f"bone_{i:03d}"


def sample(name, **kwargs):
    return from_bones(SPECS[name].bones, **kwargs)


def synthetic(scheme, spine_bones=3, neck_bones=1, base="MixamoT"):
    """The canonical humanoid with base's proportions and a naming scheme in characters.py's format."""
    proportions = dataclasses.replace(SPECS[base].proportions, spine_bones=spine_bones, neck_bones=neck_bones)
    return characters.build_bones(proportions, scheme, lambda key, side: 0.0)


def scheme_dict(spine, neck, **names):
    """A characters.py naming dict: spine/neck lists, the rest by canonical key."""
    out = {f"spine.{i + 1}": n for i, n in enumerate(spine)}
    out.update({f"neck.{i + 1}": n for i, n in enumerate(neck)})
    out.update(names)
    return out


CMU = scheme_dict(["LowerBack", "Spine", "Spine1"], ["Neck", "Neck1"], hips="Hips", head="Head",
                  shoulder="{Side}Shoulder", upper_arm="{Side}Arm", forearm="{Side}ForeArm", hand="{Side}Hand",
                  thigh="{Side}UpLeg", shin="{Side}Leg", foot="{Side}Foot", toe="{Side}ToeBase")
GAMES105 = scheme_dict(["pelvis_lowerback", "lowerback_torso"], [], hips="RootJoint", head="torso_head",
                       shoulder="{s}Torso_Clavicle", upper_arm="{s}Shoulder", forearm="{s}Elbow",
                       hand="{s}Wrist", thigh="{s}Hip", shin="{s}Knee", foot="{s}Ankle", toe="{s}ToeJoint")
UE5 = scheme_dict([f"spine_0{i}" for i in range(1, 6)], ["neck_01", "neck_02"], **{
    k: v for k, v in characters.UNREAL.items() if not k.startswith(("spine", "neck"))})
RIGIFY_DEF = {k: "DEF-" + v for k, v in characters.RIGIFY.items()}
BANDAI = scheme_dict(["Spine", "Chest"], ["Neck"], root="joint_Root", hips="Hips", head="Head",
                     shoulder="Shoulder_{S}", upper_arm="UpperArm_{S}", forearm="LowerArm_{S}", hand="Hand_{S}",
                     thigh="UpperLeg_{S}", shin="LowerLeg_{S}", foot="Foot_{S}", toe="Toes_{S}")


def cmu_rig(**kwargs):
    """CMU's cgspeed skeleton: LHipJoint/RHipJoint connect the hips to the thighs."""
    bones = []
    for b in synthetic(CMU, neck_bones=2, base="RigifyA"):
        if b.canonical.startswith("thigh."):
            side = b.canonical[-1]
            hips = next(x for x in bones if x.canonical == "hips")
            bones.append(characters.BoneSpec(f"{side}HipJoint", None, hips.name, hips.head, b.head, 0.0))
            b = dataclasses.replace(b, parent=f"{side}HipJoint")
        bones.append(b)
    return from_bones(bones, **kwargs)


def split_limbs(bones):
    """Rigify's generated DEF rig: upper and lower limbs in two segments, name and name.001."""
    out = []
    for b in bones:
        key = b.canonical.split(".")[0]
        if key in ("upper_arm", "forearm", "thigh", "shin"):
            mid = tuple((np.array(b.head) + b.tail) / 2)
            first = dataclasses.replace(b, tail=mid)
            second = dataclasses.replace(b, name=b.name + ".001", canonical="", parent=b.name, head=mid)
            out += [first, second]
        else:
            parent = b.parent
            if parent is not None and any(x.name == parent + ".001" for x in out):
                parent += ".001"  # children hang from the last segment
            out.append(dataclasses.replace(b, parent=parent))
    return out


def unreal_like(**kwargs):
    """UnrealA under a root at the floor, with twist bones, fingers, heels and ik_ bones."""
    spec = SPECS["UnrealA"]
    bone = {b.canonical: b for b in spec.bones}
    extra = []
    bones = list(spec.bones)  # UnrealA has its root on the floor already

    def along(b, t):
        return tuple(np.array(b.head) + t * (np.array(b.tail) - b.head))

    for side in "lr":
        S = side.upper()
        for limb, twist in (("upper_arm", "upperarm"), ("forearm", "lowerarm"), ("thigh", "thigh"),
                            ("shin", "calf")):
            b = bone[f"{limb}.{S}"]
            extra.append((f"{twist}_twist_01_{side}", b.name, along(b, 0.5), along(b, 0.75)))
        hand = bone[f"hand.{S}"]
        for finger in ("thumb", "index", "middle", "ring", "pinky"):
            parent = hand.name
            for k in range(1, 4):
                name = f"{finger}_0{k}_{side}"
                extra.append((name, parent, along(hand, 1 + 0.3 * (k - 1)), along(hand, 1 + 0.3 * k)))
                parent = name
        foot = bone[f"foot.{S}"]
        x = foot.head[0]  # a heel on the floor, like the metarig's: farther from the hip than the toe is
        extra.append((f"heel_02_{side}", foot.name, (x - 0.04, 0.05, 0.0), (x + 0.04, 0.05, 0.0)))
        extra.append((f"ik_foot_{side}", "ik_foot_root", foot.head, foot.tail))
        extra.append((f"ik_hand_{side}", "ik_hand_gun", hand.head, hand.tail))
    extra[0:0] = [("ik_foot_root", "root", (0, 0, 0), (0, 0, 0.1)),
                  ("ik_hand_root", "root", (0, 0, 0), (0, 0, 0.1)),
                  ("ik_hand_gun", "ik_hand_root", bone["hand.R"].head, bone["hand.R"].tail)]
    return from_bones(bones, extra=extra, **kwargs)


def read_bvh_rig(native, path):
    """The file's joints as bones (end sites are tails), Y-up metres turned into Blender's Z up."""
    skeleton, _ = native.read_bvh(path)
    parents, offsets = list(skeleton.parents), np.asarray(skeleton.offsets, dtype=float)
    ends = list(skeleton.end_sites)
    pos = np.zeros_like(offsets)
    for i, p in enumerate(parents):
        pos[i] = offsets[i] if p < 0 else pos[p] + offsets[i]
    pos = pos[:, [0, 2, 1]] * [1.0, -1.0, 1.0]  # (x, y, z) -> (x, -z, y)
    joints = [i for i in range(len(parents)) if not ends[i]]
    tails = []
    for i in joints:
        kids = [k for k in range(len(parents)) if parents[k] == i]
        incoming = pos[i] - pos[parents[i]] if parents[i] >= 0 else np.array([0.0, 0.0, 1.0])
        best = max(kids, key=lambda k: np.dot(pos[k] - pos[i], incoming) / np.linalg.norm(pos[k] - pos[i]))
        tails.append(pos[best])
    names = [skeleton.names[i] for i in joints]
    parent_names = [skeleton.names[parents[i]] if parents[i] >= 0 else None for i in joints]
    return bm.Rig.from_parent_names(names, parent_names, pos[joints], tails)


# ---------------------------------------------------------------------------
# Checking a classification against the truth

TRUNK = ("hips", "spine", "neck", "head")


def labels_of(known, body):
    return {
        "hips": known.label(body.hips) if body.hips else None,
        "spine": [known.label(n) for n in body.spine],
        "neck": [known.label(n) for n in body.neck],
        "head": known.label(body.head) if body.head else None,
        "limbs": {k: known.label(v) for k, v in body.limbs.items()},
    }


def assert_correct(known, body, neck=True):
    """Every limb bone, the hips, the spine chain and the head carry their true labels."""
    got = labels_of(known, body)
    spines = sorted(c for c in known.canonical.values() if c and c.startswith("spine."))
    necks = sorted(c for c in known.canonical.values() if c and c.startswith("neck."))
    assert got["limbs"] == {k: k for k in bm.LIMB_KEYS}
    assert got["hips"] == "hips" and got["head"] == "head"
    assert got["spine"] == spines
    if neck:
        assert got["neck"] == necks
    assert set(body.how) >= set(bm.LIMB_KEYS) | {"hips", "spine", "head"}


def depth_first(rig):
    children = {i: [c for c, p in enumerate(rig.parents) if p == i] for i in range(-1, len(rig.names))}

    def walk(i):
        yield i
        for c in children[i]:
            yield from walk(c)

    return [rig.names[i] for root in children[-1] for i in walk(root)]


def expected_pairs(src, tgt):
    """Canonical key to canonical key, with the chain rules of the mapping policy."""
    def chain(known, prefix):
        return [known.name(c) for c in sorted(c for c in known.canonical.values() if c and c.startswith(prefix))]

    pairs = [(src.name(k), tgt.name(k)) for k in ("hips", "head") + bm.LIMB_KEYS]
    if "root" in src.canonical.values() and "root" in tgt.canonical.values():
        pairs.append((src.name("root"), tgt.name("root")))  # floor roots pair with each other, never with hips
    s, t = chain(src, "spine."), chain(tgt, "spine.")
    if len(s) == len(t):
        pairs += list(zip(s, t))
    elif 1 in (len(s), len(t)):
        pairs.append((s[-1], t[-1]))
    else:
        pairs += [(s[0], t[0]), (s[-1], t[-1])]
    s, t = chain(src, "neck."), chain(tgt, "neck.")
    if s and t:
        pairs += list(zip(s, t)) if len(s) == len(t) else [(s[0], t[0])]
    order = {n: i for i, n in enumerate(depth_first(tgt.rig))}
    return sorted(pairs, key=lambda p: order[p[1]])


# ---------------------------------------------------------------------------
# The sample characters

@pytest.mark.parametrize("presets", [True, False], ids=["presets", "names"])
@pytest.mark.parametrize("name", list(SPECS))
def test_classify_labels_every_sample_bone(name, presets):
    known = sample(name)
    body = bm.classify(known.rig, presets=presets)
    assert_correct(known, body)
    if presets:
        assert set(body.how.values()) == {f"preset:{SCHEME_OF[name]}"}
    else:
        assert {body.how[k] for k in bm.LIMB_KEYS} == {"name"}


@pytest.mark.parametrize("name", list(SPECS))
def test_shape_alone_labels_every_sample_bone(name):
    known = sample(name, rename=anonymous)
    body = bm.classify(known.rig)
    assert_correct(known, body)
    assert set(body.how.values()) == {"structure"}


@pytest.mark.parametrize("source, target", list(itertools.permutations(SPECS, 2)) + [(n, n) for n in SPECS])
def test_auto_map_between_samples_gives_exactly_the_true_pairs(source, target):
    src, tgt = sample(source), sample(target)
    pairs = bm.auto_map(src.rig, tgt.rig)
    assert pairs == expected_pairs(src, tgt)
    assert len({t for _, t in pairs}) == len(pairs)
    if "RigifyA" in (source, target) and source != target:  # 2 neck bones against 1: first to first
        assert (src.name("neck.1"), tgt.name("neck.1")) in pairs
        assert not any(tgt.canonical[t] == "neck.2" or src.canonical[s] == "neck.2" for s, t in pairs)


@pytest.mark.parametrize("source, target", list(itertools.permutations(SPECS, 2)))
def test_auto_map_without_names_gives_the_same_pairs(source, target):
    src, tgt = sample(source, rename=anonymous), sample(target, rename=anonymous)
    assert bm.auto_map(src.rig, tgt.rig) == expected_pairs(src, tgt)


def test_parents_in_any_order():
    known = sample("UnrealA")
    rig = known.rig
    perm = np.random.default_rng(7).permutation(len(rig.names))
    where = {int(old): new for new, old in enumerate(perm)}
    shuffled = bm.Rig(tuple(rig.names[i] for i in perm),
                      tuple(-1 if rig.parents[i] < 0 else where[rig.parents[i]] for i in perm),
                      rig.heads[perm], rig.tails[perm])
    assert any(shuffled.parents[i] > i for i in range(len(perm)))
    for presets in (True, False):
        assert_correct(known, bm.classify(shuffled, presets=presets))
    anon = bm.Rig(tuple(f"b{i}" for i in range(len(perm))), shuffled.parents, shuffled.heads, shuffled.tails)
    body = bm.classify(anon)
    assert {k: shuffled.names[int(v[1:])] for k, v in body.limbs.items()} == \
        {k: known.name(k) for k in bm.LIMB_KEYS}


# ---------------------------------------------------------------------------
# Other schemes, helpers, sides

@pytest.mark.parametrize("how", ["presets", "names", "shape"])
def test_cmu_skeleton_hip_joints_are_connectors(how):
    known = cmu_rig(rename=anonymous if how == "shape" else None)
    body = bm.classify(known.rig, presets=how == "presets")
    assert_correct(known, body)
    assert bm.detect_scheme(known.rig) == ("cmu" if how != "shape" else None)
    if how == "names":
        assert body.limbs["thigh.L"] == "LeftUpLeg" and body.how["thigh.L"] == "name"
    tgt = sample("MixamoT")
    assert bm.auto_map(known.rig, tgt.rig) == expected_pairs(known, tgt)


@pytest.mark.parametrize("how", ["presets", "names", "shape"])
def test_games105_synthetic(how):
    known = from_bones(synthetic(GAMES105, spine_bones=2, neck_bones=0),
                       rename=anonymous if how == "shape" else None)
    body = bm.classify(known.rig, presets=how == "presets")
    assert_correct(known, body)
    assert body.neck == []
    if how == "names":
        assert body.limbs["upper_arm.L"] == "lShoulder" and body.limbs["shoulder.L"] == "lTorso_Clavicle"
        assert body.limbs["thigh.R"] == "rHip" and body.limbs["forearm.R"] == "rElbow"
    for target in SPECS:
        tgt = sample(target)
        assert bm.auto_map(known.rig, tgt.rig) == expected_pairs(known, tgt)


GAMES105_TRUTH = {
    "hips": "RootJoint", "spine": ["pelvis_lowerback", "lowerback_torso"], "neck": [], "head": "torso_head",
    "limbs": {f"{k}.{s}": s.lower() + v for s in "LR" for k, v in (
        ("shoulder", "Torso_Clavicle"), ("upper_arm", "Shoulder"), ("forearm", "Elbow"), ("hand", "Wrist"),
        ("thigh", "Hip"), ("shin", "Knee"), ("foot", "Ankle"), ("toe", "ToeJoint"))},
}


@pytest.mark.parametrize("how", ["presets", "names", "shape"])
def test_games105_real_file(native, shared_files, how):
    walk = [p for p in shared_files if p.endswith("walk60.bvh")][0]
    rig = read_bvh_rig(native, walk)
    if how == "shape":
        hidden = bm.Rig(tuple(f"joint{i}" for i in range(len(rig.names))), rig.parents, rig.heads, rig.tails)
        body = bm.classify(hidden)
        rename = dict(zip(hidden.names, rig.names))
        body = bm.Body(rename[body.hips], [rename[n] for n in body.spine], [rename[n] for n in body.neck],
                       rename[body.head], {k: rename[v] for k, v in body.limbs.items()}, body.how)
    else:
        body = bm.classify(rig, presets=how == "presets")
    assert {"hips": body.hips, "spine": body.spine, "neck": body.neck, "head": body.head,
            "limbs": body.limbs} == GAMES105_TRUTH
    assert bm.detect_scheme(rig) == "games105"
    tgt = sample("RigifyA")
    pairs = dict((t, s) for s, t in bm.auto_map(rig, tgt.rig))
    assert pairs[tgt.name("spine.1")] == "pelvis_lowerback" and pairs[tgt.name("spine.3")] == "lowerback_torso"
    assert tgt.name("spine.2") not in pairs and tgt.name("neck.1") not in pairs
    assert pairs[tgt.name("head")] == "torso_head" and pairs["upper_arm.L"] == "lShoulder"


@pytest.mark.parametrize("how", ["presets", "names", "shape"])
def test_unreal_with_root_twist_fingers_heels_and_ik_bones(how):
    known = unreal_like(rename=anonymous if how == "shape" else None)
    body = bm.classify(known.rig, presets=how == "presets")
    assert_correct(known, body)
    assert bm.detect_scheme(known.rig) == (None if how == "shape" else "unreal")
    labelled = set(body.limbs.values()) | {body.hips, body.head} | set(body.spine) | set(body.neck)
    assert not any(known.label(n) is None for n in labelled)  # no root, twist, finger, heel or ik_ bone


def test_ue5_spine_and_neck_preset():
    known = from_bones(synthetic(UE5, spine_bones=5, neck_bones=2, base="UnrealA"))
    assert bm.detect_scheme(known.rig) == "unreal"
    for presets in (True, False):
        body = bm.classify(known.rig, presets=presets)
        assert_correct(known, body)
        assert body.spine[-1] == "spine_05" and body.neck == ["neck_01", "neck_02"]
    tgt = sample("MixamoT")
    assert bm.auto_map(known.rig, tgt.rig) == expected_pairs(known, tgt)  # 5 spine to 3: ends only


def test_rigify_def_maps_the_first_limb_segments():
    known = from_bones(split_limbs(synthetic(RIGIFY_DEF, neck_bones=2)))
    assert bm.detect_scheme(known.rig) == "rigify_def"
    for presets in (True, False):
        body = bm.classify(known.rig, presets=presets)
        assert body.limbs["upper_arm.L"] == "DEF-upper_arm.L" and body.limbs["shin.R"] == "DEF-shin.R"
        assert_correct(known, body)


def test_one_spine_bone_drives_the_chest():
    one = from_bones(synthetic(scheme_dict(["torso"], ["neck"], **{
        k: v for k, v in characters.MIXAMO.items() if not k.startswith(("spine", "neck"))}), spine_bones=1))
    for other in SPECS:
        tgt = sample(other)
        pairs = bm.auto_map(one.rig, tgt.rig)
        assert pairs == expected_pairs(one, tgt)
        assert ("torso", tgt.name("spine.3")) in pairs and tgt.name("spine.1") not in dict(
            (t, s) for s, t in pairs)


def turned(p):
    return np.array([-p[0], -p[1], p[2]])  # 180 degrees about Z: facing +Y, left at -X


def mirrored(p):
    return np.array([-p[0], p[1], p[2]])


@pytest.mark.parametrize("name", list(SPECS))
def test_sides_without_side_names_come_from_the_feet(name):
    known = sample(name, rename=anonymous, transform=turned)
    assert_correct(known, bm.classify(known.rig))
    # Mirrored, the canonical left limbs are on the character's right.
    known = sample(name, rename=anonymous, transform=mirrored)
    body = bm.classify(known.rig)
    swap = {"L": "R", "R": "L"}
    assert {k: known.label(v) for k, v in body.limbs.items()} == {k: k[:-1] + swap[k[-1]] for k in bm.LIMB_KEYS}


def test_side_names_win_over_geometry():
    known = sample("MixamoT", transform=mirrored)  # LeftArm now on the character's right
    body = bm.classify(known.rig, presets=False)
    assert_correct(known, body)
    assert body.limbs["hand.L"] == "mixamorig:LeftHand"


def test_names_that_contradict_the_shape_lose():
    """A leg bone named as an arm bone (and the reverse) is labelled by its place in the skeleton."""
    swap = {"calf_l": "lowerarm_l", "lowerarm_l": "calf_l"}
    known = sample("UnrealA", rename=lambda i, name: swap.get(name, name))
    assert bm.detect_scheme(known.rig) == "unreal"  # every name exists: the preset is taken as it is
    body = bm.classify(known.rig, presets=False)
    assert_correct(known, body)
    assert body.limbs["shin.L"] == "lowerarm_l" and body.how["shin.L"] == "structure"
    assert body.limbs["forearm.L"] == "calf_l" and body.how["forearm.L"] == "structure"
    assert body.how["thigh.L"] == body.how["hips"] == body.how["spine"] == "name"


@pytest.mark.parametrize("name, side, keys", [
    ("mixamorig:LeftUpLeg", "L", ("thigh",)), ("mixamorig1:RightForeArm", "R", ("forearm",)),
    ("mixamorig:LeftShoulder", "L", ("shoulder", "upper_arm")), ("LeftToeBase", "L", ("toe",)),
    ("lShoulder", "L", ("shoulder", "upper_arm")), ("lTorso_Clavicle", "L", ("shoulder",)),
    ("rElbow", "R", ("forearm",)), ("lWrist", "L", ("hand",)), ("lHip", "L", ("thigh", "connector")),
    ("LHipJoint", "L", ("thigh", "connector")), ("rKnee", "R", ("shin",)), ("lAnkle", "L", ("foot",)),
    ("lToeJoint", "L", ("toe",)), ("RootJoint", None, ("hips",)), ("pelvis_lowerback", None, ("spine",)),
    ("lowerback_torso", None, ("spine",)), ("torso_head", None, ("head",)), ("LowerBack", None, ("spine",)),
    ("Neck1", None, ("neck",)), ("pelvis", None, ("hips",)), ("spine.003", None, ("spine",)),
    ("DEF-upper_arm.L.001", "L", ("upper_arm",)), ("ORG-shin.R", "R", ("shin",)),
    ("clavicle_l", "L", ("shoulder",)), ("upperarm_r", "R", ("upper_arm",)), ("lowerarm_l", "L", ("forearm",)),
    ("calf_r", "R", ("shin",)), ("ball_l", "L", ("toe",)), ("Bip01 L Thigh", "L", ("thigh",)),
    ("left_hand", "L", ("hand",)), ("l_foot", "L", ("foot",)), ("Foot_R", "R", ("foot",)),
    ("leftupleg", "L", ("thigh",)), ("UpperLeg.L", "L", ("thigh",)), ("LowerLeg_R", "R", ("shin",)),
    ("UpperArm_L", "L", ("upper_arm",)), ("collar.R", "R", ("shoulder",)), ("Chest", None, ("spine",)),
])
def test_names(name, side, keys):
    info = bm.name_info(name)
    assert (info.side, info.keys, info.helper) == (side, keys, False)


@pytest.mark.parametrize("name", [
    "upperarm_twist_01_l", "thigh_twist_01_r", "ik_foot_l", "ik_hand_gun", "ik_foot_root", "thumb_01_l",
    "index_02_r", "f_index.01.L", "palm.01.L", "heel.02.L", "breast.L", "pelvis.L", "mixamorig:HeadTop_End",
    "mixamorig:LeftHandIndex1", "LeftForeArmRoll", "LThumb", "LeftFingerBase", "jaw", "eye.L", "lid.T.L",
    "upperarm_correctiveRoot_l", "LeftToe_End", "hand_pole.L",
])
def test_helper_names_are_never_limbs(name):
    info = bm.name_info(name)
    assert info.helper and info.keys == ()


# ---------------------------------------------------------------------------
# Presets and map files

SCHEME_RIGS = {
    "mixamo": lambda: sample("MixamoT"),
    "rigify_metarig": lambda: sample("RigifyA"),
    "unreal": lambda: sample("UnrealA"),
    "cmu": cmu_rig,
    "games105": lambda: from_bones(synthetic(GAMES105, spine_bones=2, neck_bones=0)),
    "rigify_def": lambda: from_bones(split_limbs(synthetic(RIGIFY_DEF, neck_bones=2))),
    "bandai": lambda: from_bones(synthetic(BANDAI, spine_bones=2, neck_bones=1, base="UnrealA")),
}


def test_the_shipped_schemes():
    found = bm.schemes()
    assert set(found) == set(SCHEME_RIGS)
    for scheme_id, scheme in found.items():
        assert scheme["format"] == "motionkit-bone-scheme" and scheme["version"] == 1
        assert scheme["id"] == scheme_id and scheme["label"]
        floor_root = {"root"} if scheme_id in ("unreal", "bandai") else set()
        assert set(scheme["bones"]) == {"hips", "spine", "neck", "head"} | set(bm.LIMB_KEYS) | floor_root
    found["mixamo"]["bones"]["hips"] = "changed"
    assert bm.schemes()["mixamo"]["bones"]["hips"] == "mixamorig:Hips"  # callers get copies


@pytest.mark.parametrize("scheme_id", list(SCHEME_RIGS))
def test_each_scheme_is_detected_and_labels_its_rig(scheme_id):
    known = SCHEME_RIGS[scheme_id]()
    assert bm.detect_scheme(known.rig) == scheme_id
    body = bm.classify(known.rig)
    assert_correct(known, body)
    assert set(body.how.values()) == {f"preset:{scheme_id}"}


def test_no_scheme_for_hidden_names():
    assert bm.detect_scheme(sample("MixamoT", rename=anonymous).rig) is None


@pytest.mark.parametrize("source, target", list(itertools.permutations(SCHEME_RIGS, 2)))
def test_preset_maps_round_trip_through_files(tmp_path, source, target):
    src, tgt = SCHEME_RIGS[source](), SCHEME_RIGS[target]()
    pairs = bm.map_from_presets(src.rig, source, tgt.rig, target)
    assert pairs == expected_pairs(src, tgt) == bm.auto_map(src.rig, tgt.rig)
    path = tmp_path / f"{source}-{target}.json"
    bm.save_map(path, pairs)
    data = json.loads(path.read_text())
    assert data["format"] == "motionkit-bone-map" and data["version"] == 1
    assert data["pairs"] == [list(p) for p in pairs]
    assert bm.load_map(path) == pairs
    assert bm.load_map(str(path)) == pairs


def test_map_from_presets_rejects_unknown_and_foreign_schemes():
    rig = sample("MixamoT").rig
    with pytest.raises(ValueError, match="unknown bone scheme 'maya'"):
        bm.map_from_presets(rig, "maya", rig, "mixamo")
    with pytest.raises(ValueError, match="none of the bones of scheme 'unreal'"):
        bm.map_from_presets(rig, "mixamo", rig, "unreal")


@pytest.mark.parametrize("content, message", [
    ("not json at all", "cannot read a bone map"),
    ('{"format": "something-else", "version": 1, "pairs": []}', "not a MotionKit bone map"),
    ('[["a", "b"]]', "not a MotionKit bone map"),
    ('{"format": "motionkit-bone-map", "version": 3, "pairs": []}', "unsupported bone map version 3"),
    ('{"format": "motionkit-bone-map", "version": 1, "pairs": {"a": "b"}}', '"pairs" must be a list'),
    ('{"format": "motionkit-bone-map", "version": 1, "pairs": [["a"]]}', "must be \\[source bone, target"),
    ('{"format": "motionkit-bone-map", "version": 1, "pairs": [["a", "x"], ["b", "x"]]}',
     "target bone 'x' appears twice"),
])
def test_bad_map_files_raise_naming_the_file(tmp_path, content, message):
    path = tmp_path / "broken-map.json"
    path.write_text(content)
    with pytest.raises(ValueError, match=message) as error:
        bm.load_map(path)
    assert str(path) in str(error.value)


def test_missing_map_file_names_the_file(tmp_path):
    with pytest.raises(ValueError, match="no-such-map.json"):
        bm.load_map(tmp_path / "no-such-map.json")


def test_save_map_refuses_a_target_twice(tmp_path):
    path = tmp_path / "twice.json"
    with pytest.raises(ValueError, match="target bone 'hand.L' appears twice"):
        bm.save_map(path, [("LeftHand", "hand.L"), ("LeftForeArm", "hand.L")])
    assert not path.exists()


def test_bad_scheme_preset_names_the_file(tmp_path, monkeypatch):
    bad = tmp_path / "broken.json"
    bad.write_text(json.dumps({"format": "motionkit-bone-scheme", "version": 1, "id": "broken",
                               "bones": {"hips": "Hips", "tail": "Tail"}}))
    monkeypatch.setattr(bm, "PRESETS_DIR", str(tmp_path))
    bm._load_schemes.cache_clear()
    try:
        with pytest.raises(ValueError, match='broken.json: not a valid motionkit-bone-scheme preset: '
                                             'unknown bone key "tail"'):
            bm.schemes()
    finally:
        bm._load_schemes.cache_clear()


def test_rig_checks_its_input():
    heads = np.zeros((2, 3))
    with pytest.raises(ValueError, match="appear twice: a"):
        bm.Rig(("a", "a"), (-1, 0), heads, heads)
    with pytest.raises(ValueError, match="cycle"):
        bm.Rig(("a", "b"), (1, 0), heads, heads)
    with pytest.raises(ValueError, match="shape"):
        bm.Rig(("a", "b"), (-1, 0), np.zeros((3, 3)), heads)
    with pytest.raises(ValueError, match="invalid parent index 5"):
        bm.Rig(("a", "b"), (-1, 5), heads, heads)


def test_a_rig_without_legs_falls_back_on_names():
    spec = SPECS["MixamoT"]
    upper = [b for b in spec.bones if not b.canonical.startswith(("thigh", "shin", "foot", "toe"))]
    known = from_bones(upper)
    body = bm.classify(known.rig, presets=False)
    assert body.hips == "mixamorig:Hips" and body.head == "mixamorig:Head"
    assert body.limbs["hand.R"] == "mixamorig:RightHand" and "thigh.L" not in body.limbs
    pairs = bm.auto_map(known.rig, sample("RigifyA").rig)
    assert ("mixamorig:Hips", "spine") in pairs and ("mixamorig:LeftHand", "hand.L") in pairs
    assert not any(t.startswith(("thigh", "shin")) for _, t in pairs)
