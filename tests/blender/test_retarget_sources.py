"""A retarget's source read from a file (features/retarget_sources.py): a BVH stood as tall as the target,
judged by Blender's evaluation of both armatures' rest points in the world, and what becomes of the import."""
import importlib

import bpy
import pytest

import characters
import generate


@pytest.fixture()
def sources(mk):
    return importlib.import_module(mk.__name__ + ".features.retarget_sources")


def _height(obj):
    bpy.context.view_layer.update()
    world = obj.matrix_world
    z = [(world @ b.head_local).z for b in obj.data.bones] + [(world @ b.tail_local).z for b in obj.data.bones]
    return max(z) - min(z)


def test_a_bvh_stands_as_tall_as_the_target(sources, walk60):
    target = generate.build_armature(characters.MIXAMO_T)
    target.scale = (1.7, 1.7, 1.7)
    imported = sources.import_source(walk60, target, "auto")
    # Both heights from float32 world points (Blender's): a few units of the last place of a float32.
    assert abs(_height(imported.obj) / _height(target) - 1.0) < 1e-6
    imported.finish("hide")
    assert imported.obj.hide_get() and imported.obj.hide_render
    name = imported.obj.name
    imported.finish("remove")
    assert name not in bpy.data.objects


def test_a_bvh_scaled_as_asked(sources, walk60):
    target = generate.build_armature(characters.MIXAMO_T)
    once = sources.import_source(walk60, target, 1.0)
    tall = _height(once.obj)
    once.remove()
    twice = sources.import_source(walk60, target, 2.0)
    assert abs(_height(twice.obj) / tall - 2.0) < 1e-6


@pytest.mark.parametrize("bad, message", [
    (dict(bvh_scale=0.0), r"bvh_scale must be 'auto' or a positive number, not 0\.0"),
    (dict(bvh_scale="big"), r"bvh_scale must be 'auto' or a positive number, not 'big'"),
    (dict(imported_source="burn"), r"unknown imported_source \(bvh_source\) 'burn'"),
    (dict(imported_source="keep", bvh_source="remove"), r"imported_source and its older name bvh_source say different"),
])
def test_bad_source_options_are_refused_before_any_import(mk, walk60, bad, message):
    target = generate.build_armature(characters.MIXAMO_T)
    before = set(bpy.data.objects)
    with pytest.raises(ValueError, match=message):
        mk.retarget(walk60, target, **bad)
    assert set(bpy.data.objects) == before
