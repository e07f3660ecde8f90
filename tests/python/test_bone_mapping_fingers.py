"""Fingers, metacarpals and twist bones in automatic bone mapping (addon/core/bone_mapping.py).

The sample characters (blend_samples/characters.py) get hands: fingers named
as each scheme names them, placed like a real hand's (continuing beyond the
hand bone's tail, spread across it, the thumb forward), so that each test
knows which bone is which finger and what auto_map must pair.
"""
import dataclasses

import numpy as np
import pytest

from core import bone_mapping as bm
import test_bone_mapping as tbm

FINGERS = bm.FINGERS
SIDE_WORD = {"L": "Left", "R": "Right"}
# Where each finger leaves the hand, across it (in hand lengths, towards the character's front).
SPREAD = {"index": 0.15, "middle": 0.05, "ring": -0.05, "pinky": -0.15}


# ---------------------------------------------------------------------------
# Naming schemes: phalanx(finger, k, side) names the k-th phalanx from the hand (k from 1)

def mixamo(prefix="mixamorig:"):
    return lambda f, k, s: f"{prefix}{SIDE_WORD[s]}Hand{f.capitalize()}{k}"


def mixamo_end(prefix="mixamorig:"):
    return lambda f, s: mixamo(prefix)(f, 4, s)  # the 4th bone: a leaf at the finger tip


def rigify(prefix=""):
    return lambda f, k, s: f"{prefix}{'thumb' if f == 'thumb' else 'f_' + f}.{k:02d}.{s}"


def rigify_palm(prefix=""):
    return lambda f, s: None if f == "thumb" else f"{prefix}palm.{FINGERS.index(f):02d}.{s}"


def unreal(f, k, s):
    return f"{f}_{k:02d}_{s.lower()}"


def unreal_metacarpal(f, s):
    return None if f == "thumb" else f"{f}_metacarpal_{s.lower()}"


CC_WORD = {"thumb": "Thumb", "index": "Index", "middle": "Mid", "ring": "Ring", "pinky": "Pinky"}


def character_creator(f, k, s):
    return f"CC_Base_{s}_{CC_WORD[f]}{k}"


def biped(f, k, s):
    return f"Bip01 {s} Finger{FINGERS.index(f)}{'' if k == 1 else k - 1}"


def biped_nub(f, s):
    return f"Bip01 {s} Finger{FINGERS.index(f)}Nub"


# ---------------------------------------------------------------------------
# Building hands

def unit(v):
    return v / np.linalg.norm(v)


def finger_rows(hand, side, phalanx, count=3, metacarpal=None, end=None, thumb_under=None, fingers=FINGERS):
    """(name, parent, head, tail) rows of fingers under hand (a BoneSpec).

    count: phalanges a finger (an int, or a dict by finger); metacarpal(finger,
    side) names a bone from the wrist to the finger's root (None: none);
    end(finger, side) names a leaf beyond the last phalanx (Mixamo's 4th
    bone); thumb_under: the finger whose metacarpal carries the thumb (Rigify's
    palm.01 carries thumb.01).
    """
    head, tail = np.array(hand.head, float), np.array(hand.tail, float)
    length = float(np.linalg.norm(tail - head))
    along = unit(tail - head)
    front = np.array([0.0, -1.0, 0.0])
    forward = unit(front - along * float(np.dot(front, along)))
    rows = []
    for finger in fingers:
        parent = hand.name
        if finger == "thumb":
            root, direction = head + 0.3 * length * along + 0.2 * length * forward, unit(along + forward)
        else:
            root, direction = tail + SPREAD[finger] * length * forward, along
        if metacarpal and metacarpal(finger, side):
            rows.append((metacarpal(finger, side), hand.name, tuple(head + 0.1 * length * along), tuple(root)))
            parent = metacarpal(finger, side)
        if finger == "thumb" and thumb_under:
            parent = metacarpal(thumb_under, side)
        n = count[finger] if isinstance(count, dict) else count
        step = 0.5 * length / n
        for k in range(1, n + 1):
            name = phalanx(finger, k, side)
            rows.append((name, parent, tuple(root + (k - 1) * step * direction),
                         tuple(root + k * step * direction)))
            parent = name
        if end:
            rows.append((end(finger, side), parent, tuple(root + n * step * direction),
                         tuple(root + (n + 0.4) * step * direction)))
    return rows


def hand_rows(bones, **finger_args):
    rows = []
    for side in bm.SIDES:
        hand = next(b for b in bones if b.canonical == f"hand.{side}")
        rows += finger_rows(hand, side, **finger_args)
    return rows


def with_hands(bones, extra=(), **finger_args):
    """A Known: bones plus fingers under both hands (finger_rows' arguments) plus extra rows."""
    bones = list(bones)
    return tbm.from_bones(bones, extra=hand_rows(bones, **finger_args) + list(extra))


def mixamo_bones(prefix="mixamorig:"):
    def rename(name):
        return None if name is None else name.replace("mixamorig:", prefix)
    return [dataclasses.replace(b, name=rename(b.name), parent=rename(b.parent))
            for b in tbm.SPECS["MixamoT"].bones]


def mixamo_rig(prefix="mixamorig:", **finger_args):
    args = dict(phalanx=mixamo(prefix), end=mixamo_end(prefix))
    args.update(finger_args)
    return with_hands(mixamo_bones(prefix), **args)


def rigify_metarig():
    return with_hands(tbm.SPECS["RigifyA"].bones, phalanx=rigify(), metacarpal=rigify_palm(), thumb_under="index")


def rigify_def_rig(decoys=True):
    """A generated Rigify rig's deform skeleton; with decoys, its hands laid out as Blender 3.4's Rigify
    generates them from the human metarig.

    There DEF-hand.L holds ORG-palm.01.L, which holds ORG-f_index.01.L -> .02 -> .03, DEF-f_index.01.L ->
    .02 -> .03, DEF-palm.01.L, f_index.01_master.L, MCH-f_index.01.L and the controls
    MCH-f_index.01_drv.L -> f_index.01.L -> MCH-f_index.02_drv.L -> f_index.02.L (holding MCH-f_index.02.L)
    -> ... -> f_index.03.L (holding MCH-f_index.03.L and the tip control f_index.01.L.001); the thumb's
    bones hang from ORG-palm.01.L too; palm.L (a control) from the hand.
    """
    bones = tbm.split_limbs(tbm.synthetic(tbm.RIGIFY_DEF, neck_bones=2))
    if not decoys:
        return tbm.from_bones(bones, extra=hand_rows(bones, phalanx=rigify("DEF-"), metacarpal=rigify_palm("DEF-"),
                                                     thumb_under="index"))
    org = hand_rows(bones, phalanx=rigify("ORG-"), metacarpal=rigify_palm("ORG-"), thumb_under="index")
    rows = list(org)  # the ORG- bones come first, as in a generated rig
    for name, parent, head, tail in org:
        base = name[len("ORG-"):]
        if base.startswith("palm"):
            rows.append(("DEF-" + base, name, head, tail))
            continue
        stem, k, side = base.rsplit(".", 2)  # f_index, 01, L
        rows.append(("DEF-" + base, parent if k == "01" else "DEF-" + parent[len("ORG-"):], head, tail))
        rows.append((f"MCH-{stem}.{k}_drv.{side}", parent if k == "01" else parent[len("ORG-"):], head, tail))
        rows.append((base, f"MCH-{stem}.{k}_drv.{side}", head, tail))
        if k == "01":
            rows += [(f"{stem}.01_master.{side}", parent, head, tail),
                     (f"MCH-{stem}.01.{side}", parent, head, tail)]
        else:
            rows.append((f"MCH-{stem}.{k}.{side}", base, head, tail))
        if k == "03":
            rows.append((f"{stem}.01.{side}.001", base, tail, tuple(np.array(tail) + np.subtract(tail, head))))
    for side in bm.SIDES:
        hand = next(b for b in bones if b.canonical == f"hand.{side}")
        rows.append((f"palm.{side}", hand.name, hand.head, hand.tail))
    return tbm.from_bones(bones, extra=rows)


TWISTS = (("upper_arm", "upperarm"), ("forearm", "lowerarm"), ("thigh", "thigh"), ("shin", "calf"))


def unreal_rig(metacarpals=True, twists=True, **finger_args):
    """UnrealA with UE5's hands (metacarpals under the hand, the thumb straight on it) and twist bones."""
    bones = list(tbm.SPECS["UnrealA"].bones)
    extra = []
    if twists:
        for side in bm.SIDES:
            for key, word in TWISTS:
                limb = next(b for b in bones if b.canonical == f"{key}.{side}")
                mid = tuple((np.array(limb.head) + limb.tail) / 2)
                extra.append((f"{word}_twist_01_{side.lower()}", limb.name, limb.head, mid))
                extra.append((f"{word}_twist_02_{side.lower()}", limb.name, mid, limb.tail))
    args = dict(phalanx=unreal, metacarpal=unreal_metacarpal if metacarpals else None)
    args.update(finger_args)
    return with_hands(bones, extra=extra, **args)


def unreal_twists():
    return {f"{word}_twist_0{i}_{side.lower()}": f"{key}.{side}"
            for side in bm.SIDES for key, word in TWISTS for i in (1, 2)}


CC = tbm.scheme_dict(["CC_Base_Waist", "CC_Base_Spine01", "CC_Base_Spine02"], ["CC_Base_NeckTwist01"],
                     hips="CC_Base_Hip", head="CC_Base_Head", shoulder="CC_Base_{S}_Clavicle",
                     upper_arm="CC_Base_{S}_Upperarm", forearm="CC_Base_{S}_Forearm", hand="CC_Base_{S}_Hand",
                     thigh="CC_Base_{S}_Thigh", shin="CC_Base_{S}_Calf", foot="CC_Base_{S}_Foot",
                     toe="CC_Base_{S}_ToeBase")
BIPED = tbm.scheme_dict(["Bip01 Spine", "Bip01 Spine1", "Bip01 Spine2"], ["Bip01 Neck"], hips="Bip01 Pelvis",
                        head="Bip01 Head", shoulder="Bip01 {S} Clavicle", upper_arm="Bip01 {S} UpperArm",
                        forearm="Bip01 {S} Forearm", hand="Bip01 {S} Hand", thigh="Bip01 {S} Thigh",
                        shin="Bip01 {S} Calf", foot="Bip01 {S} Foot", toe="Bip01 {S} Toe0")


def cc_rig():
    """Character Creator: CC_Base_L_Mid1 is the middle finger; two twist bones on each arm bone."""
    bones = list(tbm.synthetic(CC))
    extra = []
    for side in bm.SIDES:
        for key, word in (("upper_arm", "Upperarm"), ("forearm", "Forearm"), ("thigh", "Thigh"), ("shin", "Calf")):
            limb = next(b for b in bones if b.canonical == f"{key}.{side}")
            mid = tuple((np.array(limb.head) + limb.tail) / 2)
            extra.append((f"CC_Base_{side}_{word}Twist01", limb.name, limb.head, mid))
            extra.append((f"CC_Base_{side}_{word}Twist02", limb.name, mid, limb.tail))
    return with_hands(bones, extra=extra, phalanx=character_creator)


def biped_rig():
    return with_hands(tbm.synthetic(BIPED), phalanx=biped, end=biped_nub)


def cmu_hands_rig():
    """CMU's cgspeed hands: LeftHand -> LeftFingerBase -> LeftHandIndex1 (all four fingers), LeftHand -> LThumb."""
    known = tbm.cmu_rig()
    rows = []
    for side in bm.SIDES:
        word = SIDE_WORD[side]
        hand = known.name(f"hand.{side}")
        i = known.rig.names.index(hand)
        head, tail = known.rig.heads[i], known.rig.tails[i]
        along = tail - head
        forward = np.array([0.0, -0.03, 0.0])
        rows += [(f"{word}FingerBase", hand, tuple(tail), tuple(tail + 0.3 * along)),
                 (f"{word}HandIndex1", f"{word}FingerBase", tuple(tail + 0.3 * along), tuple(tail + 0.8 * along)),
                 (f"{side}Thumb", hand, tuple(head + 0.3 * along + forward),
                  tuple(head + 0.7 * along + 2 * forward))]
    return tbm.cmu_rig(extra=rows)


# ---------------------------------------------------------------------------
# Expectations

def chains(phalanx, count=3, fingers=FINGERS):
    """The Body.fingers a hand named by phalanx should get."""
    return {f"{f}.{s}": [phalanx(f, k, s) for k in range(1, (count[f] if isinstance(count, dict) else count) + 1)]
            for s in bm.SIDES for f in fingers}


def finger_pairs(source_chains, target_chains):
    pairs = []
    for key in set(source_chains) & set(target_chains):
        s, t = source_chains[key], target_chains[key]
        pairs += list(zip(s, t)) if len(s) == len(t) else [(s[0], t[0]), (s[-1], t[-1])]
    return pairs


def expected(src, tgt, extra_pairs):
    """The body's true pairs (test_bone_mapping.expected_pairs) plus extra_pairs, in target depth-first order."""
    order = {n: i for i, n in enumerate(tbm.depth_first(tgt.rig))}
    return sorted(tbm.expected_pairs(src, tgt) + list(extra_pairs), key=lambda p: order[p[1]])


def body_labels(body):
    """Everything classify labels but the fingers."""
    return (body.hips, body.spine, body.neck, body.head, body.limbs, body.root)


def finger_how_keys(body):
    return set(body.fingers) | {f"{k.split('.')[0]}_metacarpal.{k.split('.')[1]}" for k in body.metacarpals}


def assert_fingers(body, expected_chains, expected_metacarpals=None):
    assert body.fingers == expected_chains
    assert body.metacarpals == (expected_metacarpals or {})
    assert {k: body.how[k] for k in finger_how_keys(body)} == {k: "name" for k in finger_how_keys(body)}


# ---------------------------------------------------------------------------
# Mixamo, Rigify, Unreal

PREFIXES = ["mixamorig:", "mixamorig6:", ""]


@pytest.mark.parametrize("presets", [True, False], ids=["presets", "names"])
@pytest.mark.parametrize("prefix", PREFIXES)
def test_mixamo_fingers_leave_out_the_end_bones(prefix, presets):
    known = mixamo_rig(prefix)
    body = bm.classify(known.rig, presets=presets)
    tbm.assert_correct(known, body)
    assert_fingers(body, chains(mixamo(prefix)))
    assert not any(n.endswith("4") for chain in body.fingers.values() for n in chain)
    assert body.twists == {}
    if presets and prefix == "mixamorig:":
        assert body.how["hips"] == "preset:mixamo"


@pytest.mark.parametrize("source", PREFIXES)
@pytest.mark.parametrize("target", PREFIXES)
def test_mixamo_to_mixamo_pairs_all_thirty_phalanges(source, target):
    src, tgt = mixamo_rig(source), mixamo_rig(target)
    pairs = bm.auto_map(src.rig, tgt.rig)
    fingers = finger_pairs(chains(mixamo(source)), chains(mixamo(target)))
    assert len(fingers) == 30  # 5 fingers x 3 phalanges x 2 hands
    assert pairs == expected(src, tgt, fingers)
    assert not any(s.endswith("4") or t.endswith("4") for s, t in pairs)


def test_mixamo_and_the_rigify_metarig():
    mix, meta = mixamo_rig(), rigify_metarig()
    body = bm.classify(meta.rig)
    tbm.assert_correct(meta, body)
    assert_fingers(body, chains(rigify()), {f"{f}.{s}": rigify_palm()(f, s) for s in bm.SIDES for f in FINGERS[1:]})
    assert body.metacarpals["index.L"] == "palm.01.L" and body.metacarpals["pinky.R"] == "palm.04.R"
    assert body.fingers["thumb.L"] == ["thumb.01.L", "thumb.02.L", "thumb.03.L"]  # under palm.01.L
    for src, tgt, s, t in ((mix, meta, mixamo(), rigify()), (meta, mix, rigify(), mixamo())):
        fingers = finger_pairs(chains(s), chains(t))
        assert len(fingers) == 30
        assert bm.auto_map(src.rig, tgt.rig) == expected(src, tgt, fingers)  # no metacarpals on Mixamo


@pytest.mark.parametrize("presets", [True, False], ids=["presets", "names"])
def test_rigify_def_fingers_and_not_the_controls(presets):
    known = rigify_def_rig()
    assert bm.detect_scheme(known.rig) == "rigify_def"
    body = bm.classify(known.rig, presets=presets)
    tbm.assert_correct(known, body)
    assert_fingers(body, chains(rigify("DEF-")),
                   {f"{f}.{s}": rigify_palm("DEF-")(f, s) for s in bm.SIDES for f in FINGERS[1:]})
    assert body_labels(body) == body_labels(bm.classify(rigify_def_rig(decoys=False).rig, presets=presets))


def test_mixamo_and_rigify_def_with_decoys():
    mix, rig = mixamo_rig("mixamorig6:"), rigify_def_rig()
    decoys = [n for n in rig.rig.names if rig.canonical[n] is None and not n.startswith("DEF-")]
    # a hand: 4 ORG- palms, 15 ORG- phalanges, a finger's 3 controls, 3 _drv, 3 MCH-, a master and a tip; palm.L
    assert len(decoys) == 2 * (4 + 15 + 5 * 11 + 1)
    assert {"thumb.01_master.L", "MCH-thumb.01.L", "ORG-thumb.01.L", "thumb.01.L",
            "f_pinky.01.R.001"} <= set(decoys)
    for src, tgt, s, t in ((mix, rig, mixamo("mixamorig6:"), rigify("DEF-")),
                           (rig, mix, rigify("DEF-"), mixamo("mixamorig6:"))):
        pairs = bm.auto_map(src.rig, tgt.rig)
        assert pairs == expected(src, tgt, finger_pairs(chains(s), chains(t)))
        assert not any(n in decoys for pair in pairs for n in pair)


def test_rigify_metarig_and_def_pair_their_metacarpals():
    meta, rig = rigify_metarig(), rigify_def_rig()
    palms = [(rigify_palm()(f, s), rigify_palm("DEF-")(f, s)) for s in bm.SIDES for f in FINGERS[1:]]
    fingers = finger_pairs(chains(rigify()), chains(rigify("DEF-")))
    assert bm.auto_map(meta.rig, rig.rig) == expected(meta, rig, fingers + palms)
    assert bm.map_from_presets(meta.rig, "rigify_metarig", rig.rig, "rigify_def") == expected(
        meta, rig, fingers + palms)


@pytest.mark.parametrize("presets", [True, False], ids=["presets", "names"])
def test_unreal_fingers_metacarpals_and_twists(presets):
    known = unreal_rig()
    body = bm.classify(known.rig, presets=presets)
    tbm.assert_correct(known, body)
    assert_fingers(body, chains(unreal),
                   {f"{f}.{s}": unreal_metacarpal(f, s) for s in bm.SIDES for f in FINGERS[1:]})
    assert body.how["index_metacarpal.L"] == "name" and "thumb_metacarpal.L" not in body.how
    assert body.twists == unreal_twists()


def test_mixamo_and_unreal_pair_phalanges_but_not_twists_or_lone_metacarpals():
    mix, ue = mixamo_rig(), unreal_rig()
    twists = set(unreal_twists())
    metacarpals = {unreal_metacarpal(f, s) for s in bm.SIDES for f in FINGERS[1:]}
    for src, tgt, s, t in ((mix, ue, mixamo(), unreal), (ue, mix, unreal, mixamo())):
        fingers = finger_pairs(chains(s), chains(t))
        assert len(fingers) == 30
        pairs = bm.auto_map(src.rig, tgt.rig)
        assert pairs == expected(src, tgt, fingers)
        assert not any(n in twists | metacarpals for pair in pairs for n in pair)
    assert bm.map_from_presets(mix.rig, "mixamo", ue.rig, "unreal") == bm.auto_map(mix.rig, ue.rig)


def test_unreal_to_unreal_pairs_metacarpals_never_twists():
    src, tgt = unreal_rig(), unreal_rig()
    metacarpals = [(unreal_metacarpal(f, s),) * 2 for s in bm.SIDES for f in FINGERS[1:]]
    fingers = finger_pairs(chains(unreal), chains(unreal))
    pairs = bm.auto_map(src.rig, tgt.rig)
    assert pairs == expected(src, tgt, fingers + metacarpals)
    assert not any(n in unreal_twists() for pair in pairs for n in pair)


def test_unreal_like_sample_of_test_bone_mapping_has_its_fingers():
    body = bm.classify(tbm.unreal_like().rig)
    assert body.fingers == chains(unreal) and body.metacarpals == {}
    assert body.twists == {f"{word}_twist_01_{s.lower()}": f"{key}.{s}" for s in bm.SIDES for key, word in TWISTS}


# ---------------------------------------------------------------------------
# Fingers of different lengths, missing fingers

def test_three_bone_and_two_bone_fingers_pair_first_and_last():
    mix = mixamo_rig()
    two = unreal_rig(metacarpals=False, twists=False, count=2)
    assert bm.classify(two.rig).fingers == chains(unreal, count=2)
    src_to_tgt = [(mixamo()(f, 1, s), unreal(f, 1, s)) for s in bm.SIDES for f in FINGERS] + \
                 [(mixamo()(f, 3, s), unreal(f, 2, s)) for s in bm.SIDES for f in FINGERS]
    assert bm.auto_map(mix.rig, two.rig) == expected(mix, two, src_to_tgt)
    tgt_to_src = [(t, s) for s, t in src_to_tgt]
    assert bm.auto_map(two.rig, mix.rig) == expected(two, mix, tgt_to_src)
    assert mixamo()("index", 2, "L") not in {n for pair in bm.auto_map(two.rig, mix.rig) for n in pair}


def test_fingers_of_mixed_lengths():
    count = {"thumb": 2, "index": 3, "middle": 3, "ring": 2, "pinky": 1}
    mixed = unreal_rig(metacarpals=False, twists=False, count=count)
    mix = mixamo_rig()
    assert bm.classify(mixed.rig).fingers == chains(unreal, count=count)
    pairs = bm.auto_map(mix.rig, mixed.rig)
    want = []
    for s in bm.SIDES:
        want += [(mixamo()("thumb", 1, s), unreal("thumb", 1, s)), (mixamo()("thumb", 3, s), unreal("thumb", 2, s))]
        want += [(mixamo()(f, k, s), unreal(f, k, s)) for f in ("index", "middle") for k in (1, 2, 3)]
        want += [(mixamo()("ring", 1, s), unreal("ring", 1, s)), (mixamo()("ring", 3, s), unreal("ring", 2, s))]
        want += [(mixamo()("pinky", 1, s), unreal("pinky", 1, s))]  # a one-bone finger is the whole finger
    assert pairs == expected(mix, mixed, want)


@pytest.mark.parametrize("count", [3, 2])
def test_a_hand_with_only_thumb_and_index(count):
    two = unreal_rig(metacarpals=False, twists=False, fingers=("thumb", "index"), count=count)
    body = bm.classify(two.rig)
    tbm.assert_correct(two, body)
    assert body.fingers == chains(unreal, count=count, fingers=("thumb", "index"))
    assert set(body.how) - set(bm.classify(tbm.sample("UnrealA").rig).how) == {
        "thumb.L", "index.L", "thumb.R", "index.R"}
    mix = mixamo_rig()
    fingers = finger_pairs(chains(mixamo()), chains(unreal, count=count, fingers=("thumb", "index")))
    assert len(fingers) == 4 * (3 if count == 3 else 2)
    assert bm.auto_map(mix.rig, two.rig) == expected(mix, two, fingers)
    assert bm.auto_map(two.rig, mix.rig) == expected(two, mix, [(t, s) for s, t in fingers])


# ---------------------------------------------------------------------------
# Other naming schemes

@pytest.mark.parametrize("presets", [True, False], ids=["presets", "names"])
def test_character_creator(presets):
    known = cc_rig()
    body = bm.classify(known.rig, presets=presets)
    tbm.assert_correct(known, body)
    assert_fingers(body, chains(character_creator))
    assert body.fingers["middle.L"] == ["CC_Base_L_Mid1", "CC_Base_L_Mid2", "CC_Base_L_Mid3"]
    assert body.twists == {f"CC_Base_{s}_{word}Twist0{i}": f"{key}.{s}" for s in bm.SIDES for i in (1, 2)
                           for key, word in (("upper_arm", "Upperarm"), ("forearm", "Forearm"),
                                             ("thigh", "Thigh"), ("shin", "Calf"))}
    assert "CC_Base_NeckTwist01" not in body.twists  # a twist word on the neck, not under a limb
    mix = mixamo_rig()
    fingers = finger_pairs(chains(mixamo()), chains(character_creator))
    assert len(fingers) == 30
    assert bm.auto_map(mix.rig, known.rig) == expected(mix, known, fingers)


@pytest.mark.parametrize("presets", [True, False], ids=["presets", "names"])
def test_3ds_max_biped(presets):
    known = biped_rig()
    body = bm.classify(known.rig, presets=presets)
    tbm.assert_correct(known, body)
    assert_fingers(body, chains(biped))
    assert body.fingers["thumb.L"] == ["Bip01 L Finger0", "Bip01 L Finger01", "Bip01 L Finger02"]
    assert body.fingers["index.R"] == ["Bip01 R Finger1", "Bip01 R Finger11", "Bip01 R Finger12"]
    assert body.fingers["pinky.L"][0] == "Bip01 L Finger4"
    mix = mixamo_rig()
    fingers = finger_pairs(chains(biped), chains(mixamo()))
    assert len(fingers) == 30
    assert bm.auto_map(known.rig, mix.rig) == expected(known, mix, fingers)


@pytest.mark.parametrize("presets", [True, False], ids=["presets", "names"])
def test_cmu_one_bone_fingers(presets):
    known = cmu_hands_rig()
    body = bm.classify(known.rig, presets=presets)
    tbm.assert_correct(known, body)
    assert body.fingers == {"thumb.L": ["LThumb"], "index.L": ["LeftHandIndex1"],
                            "thumb.R": ["RThumb"], "index.R": ["RightHandIndex1"]}
    assert body.metacarpals == {}  # LeftFingerBase carries four fingers: no one finger's metacarpal
    mix = mixamo_rig()
    fingers = [(f"{side}Thumb", mixamo()("thumb", 1, side)) for side in bm.SIDES] + \
              [(f"{SIDE_WORD[side]}HandIndex1", mixamo()("index", 1, side)) for side in bm.SIDES]
    assert bm.auto_map(known.rig, mix.rig) == expected(known, mix, fingers)


def rokoko(f, k, s):
    return f"{SIDE_WORD[s]}Finger{FINGERS.index(f) + 1}{('Proximal', 'Medial', 'Distal')[k - 1]}"


def numbered_with_thumb(f, k, s):
    return f"{SIDE_WORD[s]}Thumb{k}" if f == "thumb" else f"{SIDE_WORD[s]}Finger{FINGERS.index(f)}_{k}"


NAMINGS = {
    "daz": lambda f, k, s: f"{s.lower()}{CC_WORD[f]}{k}",
    "unreal_upper": lambda f, k, s: f"{f.upper()}_0{k}_{s}",
    "synonyms": lambda f, k, s: f"{SIDE_WORD[s]}" + {"thumb": "Thumb", "index": "Forefinger", "middle": "Mid",
                                                     "ring": "Ring", "pinky": "Pinkie"}[f] + str(k),
    "little_pointer": lambda f, k, s: f"hand_{s}_" + {"thumb": "thumb", "index": "pointer", "middle": "middle",
                                                      "ring": "ring", "pinky": "little"}[f] + f"_{k}",
    "rokoko": rokoko,
    "numbered_with_thumb": numbered_with_thumb,
    "vrm": lambda f, k, s: f"{SIDE_WORD[s]}{f.capitalize()}{('Proximal', 'Intermediate', 'Distal')[k - 1]}",
}


@pytest.mark.parametrize("naming", list(NAMINGS))
def test_finger_names_under_a_mixamo_body(naming):
    known = with_hands(mixamo_bones(), phalanx=NAMINGS[naming])
    body = bm.classify(known.rig)
    tbm.assert_correct(known, body)
    assert_fingers(body, chains(NAMINGS[naming]))


def test_biped_four_fingers_without_a_thumb_count_from_finger0():
    """Biped numbers the fingers it has from Finger0: with Finger0 present, Finger1 is still the index."""
    known = with_hands(tbm.synthetic(BIPED), phalanx=biped, fingers=("thumb", "index"))
    assert bm.classify(known.rig).fingers == chains(biped, fingers=("thumb", "index"))


def test_unsided_finger_names_take_their_hand_side():
    """Blender names the mirrored copy thumb_01.001: neither says a side, the hand does."""
    bones = list(tbm.SPECS["UnrealA"].bones)
    rows = []
    for side, suffix in (("L", ""), ("R", ".001")):
        hand = next(b for b in bones if b.canonical == f"hand.{side}")
        rows += finger_rows(hand, side, lambda f, k, s, x=suffix: f"{f}_0{k}{x}")
    known = tbm.from_bones(bones, extra=rows)
    body = bm.classify(known.rig)
    tbm.assert_correct(known, body)
    assert body.fingers["thumb.L"] == ["thumb_01", "thumb_02", "thumb_03"]
    assert body.fingers["pinky.R"] == ["pinky_01.001", "pinky_02.001", "pinky_03.001"]
    assert len(body.fingers) == 10


def test_fingers_follow_their_hand_where_names_and_positions_disagree():
    """Body bones without names, mirrored: the hand labelled R by position holds the fingers named Left."""
    bones = [dataclasses.replace(b, name=f"bone_{i:02d}", parent=None if b.parent is None else
                                 f"bone_{[x.name for x in mixamo_bones()].index(b.parent):02d}")
             for i, b in enumerate(mixamo_bones())]
    known = tbm.from_bones(bones, extra=hand_rows(bones, phalanx=mixamo(), end=mixamo_end()),
                           transform=tbm.mirrored)
    body = bm.classify(known.rig)
    assert body.limbs["hand.R"] == known.name("hand.L")
    assert body.fingers["thumb.R"] == [mixamo()("thumb", k, "L") for k in (1, 2, 3)]
    assert body.fingers["pinky.L"] == [mixamo()("pinky", k, "R") for k in (1, 2, 3)]
    assert len(body.fingers) == 10


@pytest.mark.parametrize("name, finger, segment, metacarpal", [
    ("mixamorig:LeftHandThumb1", "thumb", 1, False), ("mixamorig6:RightHandPinky4", "pinky", 4, False),
    ("DEF-f_middle.02.L", "middle", 2, False), ("ORG-thumb.03.R", "thumb", 3, False),
    ("palm.01.L", "index", None, True), ("DEF-palm.04.R", "pinky", None, True),
    ("ring_metacarpal_r", "ring", None, True), ("index_02_l", "index", 2, False),
    ("CC_Base_R_Mid2", "middle", 2, False), ("lPinky3", "pinky", 3, False), ("LThumb", "thumb", None, False),
    ("LeftHandLittle1", "pinky", 1, False), ("LeftForefinger2", "index", 2, False),
    ("LeftIndexDistal", "index", 3, False), ("LeftInHandMiddle", "middle", None, True),
    ("Bip01 L Finger2", None, None, False), ("Bip01 R Finger42", None, 3, False),
])
def test_finger_names(name, finger, segment, metacarpal):
    found = bm._finger_name(name)
    assert (found.finger, found.segment, found.metacarpal) == (finger, segment, metacarpal)
    assert bm.name_info(name).helper  # so the shape rules leave the fingers out


@pytest.mark.parametrize("name", [
    "thumb.01_master.L", "MCH-f_index.01.L", "MCH-thumb.02.R", "f_ring.01_ik.L", "index_twist_l",
    "LeftFingerBase", "palm.L", "mixamorig:LeftHand", "mixamorig:LeftForeArm", "upperarm_twist_01_l",
])
def test_names_that_are_no_phalanx(name):
    assert bm._finger_name(name) is None


# ---------------------------------------------------------------------------
# Twist bones

def test_twist_bones_only_as_leaves_or_twist_chains_under_a_limb_bone():
    bones = list(tbm.SPECS["UnrealA"].bones)
    extra = [
        ("upperarm_twist_01_l", "upperarm_l", (0.3, 0, 1.4), (0.35, 0, 1.35)),   # a leaf: yes
        ("lowerarm_twist_01_l", "lowerarm_l", (0.4, 0, 1.3), (0.45, 0, 1.25)),   # only twists below: yes
        ("lowerarm_twist_02_l", "lowerarm_twist_01_l", (0.45, 0, 1.25), (0.5, 0, 1.2)),  # parent not a limb
        ("thigh_twist_01_l", "thigh_l", (0.12, 0, 0.9), (0.12, 0, 0.8)),         # a non-twist bone below: no
        ("thigh_bulge_l", "thigh_twist_01_l", (0.12, 0, 0.8), (0.12, -0.05, 0.8)),
        ("hand_twist_r", "hand_r", (-0.6, 0, 1.1), (-0.65, 0, 1.05)),            # under a hand: no
        ("calf_twist_01_r", "calf_r", (-0.12, 0, 0.4), (-0.12, 0, 0.3)),
    ]
    known = tbm.from_bones(bones, extra=extra)
    for presets in (True, False):
        body = bm.classify(known.rig, presets=presets)
        tbm.assert_correct(known, body)
        assert body.twists == {"upperarm_twist_01_l": "upper_arm.L", "lowerarm_twist_01_l": "forearm.L",
                               "calf_twist_01_r": "shin.R"}


@pytest.mark.parametrize("prefix", ["", "DEF-"])
def test_rigify_style_twist_bones(prefix):
    bones = tbm.split_limbs(tbm.synthetic({k: prefix + v for k, v in tbm.characters.RIGIFY.items()}, neck_bones=2))
    limb = {b.canonical: b for b in bones}
    extra = [(f"{prefix}{key}_twist.{s}", limb[f"{key}.{s}"].name, limb[f"{key}.{s}"].head, limb[f"{key}.{s}"].tail)
             for s in bm.SIDES for key in ("upper_arm", "forearm")]
    known = tbm.from_bones(bones, extra=extra)
    body = bm.classify(known.rig)
    tbm.assert_correct(known, body)
    assert body.twists == {f"{prefix}{key}_twist.{s}": f"{key}.{s}"
                           for s in bm.SIDES for key in ("upper_arm", "forearm")}


# ---------------------------------------------------------------------------
# Nothing else changes

HANDS = {
    "MixamoT": dict(phalanx=mixamo(), end=mixamo_end()),
    "RigifyA": dict(phalanx=rigify(), metacarpal=rigify_palm(), thumb_under="index"),
    "UnrealA": dict(phalanx=unreal, metacarpal=unreal_metacarpal),
}


@pytest.mark.parametrize("presets", [True, False], ids=["presets", "names"])
@pytest.mark.parametrize("name", list(tbm.SPECS))
def test_fingers_leave_the_body_labels_as_they_were(name, presets):
    plain = bm.classify(tbm.sample(name).rig, presets=presets)
    known = with_hands(tbm.SPECS[name].bones, **HANDS[name])
    body = bm.classify(known.rig, presets=presets)
    assert body_labels(body) == body_labels(plain)
    assert {k: v for k, v in body.how.items() if k in plain.how} == plain.how
    assert set(body.how) - set(plain.how) == finger_how_keys(body)
    assert len(body.fingers) == 10
    assert plain.fingers == {} and plain.metacarpals == {} and plain.twists == {}


@pytest.mark.parametrize("source", list(tbm.SPECS))
@pytest.mark.parametrize("target", list(tbm.SPECS))
def test_samples_with_hands_pair_body_and_fingers(source, target):
    src = with_hands(tbm.SPECS[source].bones, **HANDS[source])
    tgt = with_hands(tbm.SPECS[target].bones, **HANDS[target])
    s_chains, t_chains = chains(HANDS[source]["phalanx"]), chains(HANDS[target]["phalanx"])
    pairs = finger_pairs(s_chains, t_chains)
    s_meta, t_meta = HANDS[source].get("metacarpal"), HANDS[target].get("metacarpal")
    if s_meta and t_meta:
        pairs += [(s_meta(f, s), t_meta(f, s)) for s in bm.SIDES for f in FINGERS[1:]]
    assert bm.auto_map(src.rig, tgt.rig) == expected(src, tgt, pairs)
