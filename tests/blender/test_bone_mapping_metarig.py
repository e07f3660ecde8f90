"""Bone mapping on Rigify's real human metarig, built by the Rigify add-on that ships with Blender."""
import importlib

import addon_utils
import bpy
import numpy as np
import pytest

import conftest  # noqa: F401  (puts blend_samples on sys.path)
import characters

LIMBS = ("shoulder", "upper_arm", "forearm", "hand", "thigh", "shin", "foot", "toe")


@pytest.fixture(scope="module")
def bone_mapping(mk):
    return importlib.import_module(mk.__name__ + ".core.bone_mapping")


@pytest.fixture
def metarig(empty_scene):
    """The human metarig's rest pose as an armature object (Rigify is still the module "rigify" in 5.x)."""
    was_enabled = addon_utils.check("rigify")[1]
    errors = []
    if not addon_utils.enable("rigify", default_set=True, handle_error=errors.append):
        pytest.fail(f"the bundled Rigify add-on did not enable: {errors}")
    if bpy.context.object and bpy.context.object.mode != 'OBJECT':
        bpy.ops.object.mode_set(mode='OBJECT')
    assert bpy.ops.object.armature_human_metarig_add() == {'FINISHED'}
    yield bpy.context.object
    if not was_enabled:
        addon_utils.disable("rigify", default_set=True)


def rig_from_armature(bone_mapping, armature):
    bones = list(armature.bones)
    index = {b.name: i for i, b in enumerate(bones)}
    return bone_mapping.Rig(
        tuple(b.name for b in bones),
        tuple(index[b.parent.name] if b.parent else -1 for b in bones),
        np.array([b.head_local for b in bones]),
        np.array([b.tail_local for b in bones]))


def rig_from_spec(bone_mapping, spec):
    return bone_mapping.Rig.from_parent_names(
        [b.name for b in spec.bones], [b.parent for b in spec.bones],
        [b.head for b in spec.bones], [b.tail for b in spec.bones])


def expected_limbs():
    return {f"{key}.{side}": f"{key}.{side}" for side in "LR" for key in LIMBS}


@pytest.mark.parametrize("presets", [True, False], ids=["presets", "names-and-shape"])
def test_classify_finds_the_metarig_bones(bone_mapping, metarig, presets):
    rig = rig_from_armature(bone_mapping, metarig.data)
    assert len(rig.names) > 100  # the full metarig: face, fingers, palms, heels, breasts
    assert bone_mapping.detect_scheme(rig) == "rigify_metarig"
    body = bone_mapping.classify(rig, presets=presets)
    assert body.limbs == expected_limbs()
    assert body.hips == "spine" and body.head == "spine.006"
    assert body.spine == ["spine.001", "spine.002", "spine.003"]  # spine.003 is the chest
    assert body.neck == ["spine.004", "spine.005"]


def test_the_metarig_without_names_by_shape(bone_mapping, metarig):
    """The metarig's shape alone (names hidden): fingers, heels, face and breasts are not limbs."""
    rig = rig_from_armature(bone_mapping, metarig.data)
    hidden = bone_mapping.Rig(tuple(f"bone_{i:03d}" for i in range(len(rig.names))),
                              rig.parents, rig.heads, rig.tails)
    body = bone_mapping.classify(hidden)
    named = {k: rig.names[int(v[5:])] for k, v in body.limbs.items()}
    assert named == expected_limbs()
    assert rig.names[int(body.hips[5:])] == "spine" and rig.names[int(body.spine[-1][5:])] == "spine.003"


@pytest.mark.parametrize("name", [s.name for s in characters.CHARACTERS])
def test_auto_map_from_each_sample_onto_the_metarig(bone_mapping, metarig, name):
    spec = next(s for s in characters.CHARACTERS if s.name == name)
    source = rig_from_spec(bone_mapping, spec)
    target = rig_from_armature(bone_mapping, metarig.data)
    pairs = bone_mapping.auto_map(source, target)
    by_target = {t: s for s, t in pairs}
    for key in expected_limbs():
        assert by_target[key] == spec.canonical[key]
    assert by_target["spine"] == spec.canonical["hips"] and by_target["spine.006"] == spec.canonical["head"]
    assert by_target["spine.003"] == spec.canonical["spine.3"]
    assert by_target["spine.004"] == spec.canonical["neck.1"]
    assert len(by_target) == len(pairs)
    assert [t for _, t in pairs] == sorted((t for _, t in pairs), key=depth_first(target).index)


def depth_first(rig):
    """Bone names parents first, each bone's children in the order of the armature's bone list."""
    children = {i: [c for c, p in enumerate(rig.parents) if p == i] for i in range(-1, len(rig.names))}
    order, stack = [], list(reversed(children[-1]))
    while stack:
        i = stack.pop()
        order.append(rig.names[i])
        stack.extend(reversed(children[i]))
    return order
