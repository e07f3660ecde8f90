"""core/retarget_parts: a body cut into parts by its labels, and the presets, on the sample characters."""
import dataclasses

import pytest

import characters
from core import retarget_parts as rp
from plain_rigs import from_spec


def _parts(spec):
    rig = from_spec(spec)
    return rig, dict(zip(rig.names, rp.part_of_bones(rig.names, rig.parents, rig.body)))


def test_each_canonical_bone_has_its_part():
    """The parts read off the sample's own canonical names (written by hand, not by the labels' code)."""
    expected = {"hips": "hips", "spine": "spine", "neck": "spine", "head": "spine", "shoulder": "arm",
                "upper_arm": "arm", "forearm": "arm", "hand": "hand", "thigh": "leg", "shin": "leg",
                "foot": "leg", "toe": "leg", "root": "hips"}
    for spec in characters.CHARACTERS:
        _, parts = _parts(spec)
        for bone in spec.bones:
            kind, _, side = bone.canonical.partition(".")
            want = expected[kind] + (f".{side}" if side in ("L", "R") else "")
            assert parts[bone.name] == want, (spec.name, bone.name)


def test_unlabelled_bones_take_their_ancestors_part_and_a_loose_one_is_other():
    spec = characters.UNREAL_A
    hand = next(b for b in spec.bones if b.canonical == "hand.R")
    extra = [characters.BoneSpec("weapon_r", "weapon", hand.name, hand.tail, (hand.tail[0], hand.tail[1] - 0.2,
                                                                             hand.tail[2]), 0.0),
             characters.BoneSpec("prop", "prop", None, (0.5, 0, 0), (0.5, 0, 0.2), 0.0)]
    rig, parts = _parts(dataclasses.replace(spec, bones=spec.bones + tuple(extra)))
    assert parts["weapon_r"] == "hand.R" and parts["prop"] == "other"
    arms = {rig.names[b] for b in rp.chosen_bones("arms", rig.names, rig.parents, rig.body)}
    assert "weapon_r" in arms and "prop" not in arms
    assert "prop" in {rig.names[b] for b in rp.chosen_bones("whole", rig.names, rig.parents, rig.body)}


@pytest.mark.parametrize("preset", [p[0] for p in rp.PRESETS])
def test_presets_choose_their_parts(preset):
    rig, parts = _parts(characters.MIXAMO_T)
    chosen = {rig.names[b] for b in rp.chosen_bones(preset, rig.names, rig.parents, rig.body)}
    assert chosen == {n for n, p in parts.items() if p in rp.PRESET_PARTS[preset]}
    assert chosen  # every preset picks something on a humanoid


def test_a_list_of_parts_and_bad_ones():
    rig, parts = _parts(characters.RIGIFY_A)
    left = {rig.names[b] for b in rp.chosen_bones(["arm.L", "hand.L"], rig.names, rig.parents, rig.body)}
    assert left == {n for n, p in parts.items() if p in ("arm.L", "hand.L")}
    with pytest.raises(ValueError, match="unknown body part 'wing'"):
        rp.check_parts(["arm.L", "wing"])
    with pytest.raises(ValueError, match="preset's name or a list"):
        rp.check_parts(3)
