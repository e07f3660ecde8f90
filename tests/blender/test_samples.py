"""The sample characters and their walk, checked against Blender's own evaluation."""
import math

import bpy
import numpy as np
import pytest

import conftest  # (also puts blend_samples on sys.path)
import characters
import generate
import walk
from rotations import quaternion_angles

SPEC = {s.name: s for s in characters.CHARACTERS}


@pytest.fixture(scope="module")
def samples(animdata):
    """The three characters, built once for the module: its tests only read them (and the determinism test
    removes only what it builds itself)."""
    scene = bpy.context.scene
    kept = (scene.render.fps, scene.render.fps_base, scene.frame_start, scene.frame_end)
    conftest.clear_scene()
    yield generate.build_all(animdata, walk_on=tuple(SPEC))
    conftest.clear_scene()
    scene.render.fps, scene.render.fps_base, scene.frame_start, scene.frame_end = kept


@pytest.fixture(autouse=True)
def empty_scene():
    """conftest's empty scene between tests would remove the module's samples: here only the frame the tests
    set is put back."""
    frame = bpy.context.scene.frame_current
    yield
    bpy.context.scene.frame_set(frame)


def _rest_armature_space(obj, spec, canonical):
    bone = obj.data.bones[spec.canonical[canonical]]
    return bone.head_local, bone.tail_local


@pytest.mark.parametrize("name", list(SPEC))
def test_armature_matches_its_spec(samples, name):
    obj, spec = samples[name], SPEC[name]
    assert sorted(b.name for b in obj.data.bones) == sorted(b.name for b in spec.bones)
    for bone_spec in spec.bones:
        bone = obj.data.bones[bone_spec.name]
        np.testing.assert_allclose(bone.head_local, bone_spec.head, atol=1e-6)
        np.testing.assert_allclose(bone.tail_local, bone_spec.tail, atol=1e-6)
        assert (bone.parent.name if bone.parent else None) == bone_spec.parent
    body = obj.children[0]
    assert {m.type for m in body.modifiers} == {'ARMATURE', 'SUBSURF'}
    fleshed = {name for key, name in spec.canonical.items() if key != "root"}  # a floor root has no flesh
    assert {g.name for g in body.vertex_groups} == fleshed


def test_rolls_give_different_local_axes(samples):
    """The same canonical bone has differently oriented local axes on each rig."""
    x_axes = []
    for name, obj in samples.items():
        rest = obj.data.bones[SPEC[name].canonical["forearm.L"]].matrix_local
        x_axes.append(np.array(rest.col[0][:3]))
    for i in range(3):
        for j in range(i + 1, 3):
            assert np.dot(x_axes[i], x_axes[j]) < 0.9  # opposite axes (±90°) differ too


def test_t_and_a_pose_in_blender(samples):
    head, tail = _rest_armature_space(samples["MixamoT"], SPEC["MixamoT"], "upper_arm.L")
    assert (tail - head).normalized().z == pytest.approx(0.0, abs=1e-6)
    head, tail = _rest_armature_space(samples["RigifyA"], SPEC["RigifyA"], "upper_arm.L")
    assert math.degrees(math.asin(-(tail - head).normalized().z)) == pytest.approx(45.0, abs=1e-4)


@pytest.mark.parametrize("name", list(SPEC))
def test_walk_evaluates_to_the_authored_pose(samples, name):
    """Blender's depsgraph pose equals Q_i = G_i B_i on every bone, whatever the rolls."""
    obj, spec = samples[name], SPEC[name]
    rest = generate.rest_orientations(obj, spec)
    hips = spec.canonical["hips"]
    for frame in (1, 8, 17, 30, 44, 61):
        bpy.context.scene.frame_set(frame)
        G, offset = walk.global_rotations(spec, np.array([(frame - 1) / generate.FPS]))
        for bone in spec.bones:
            got = np.array(obj.pose.bones[bone.name].matrix.to_quaternion())
            want = walk.mul(G[bone.canonical][0], rest[bone.canonical])
            assert quaternion_angles(got, want) < 1e-6, (frame, bone.name)  # radians; Blender's floats
        np.testing.assert_allclose(obj.pose.bones[hips].matrix.translation,
                                   np.add(spec.bone("hips").head, offset[0]), atol=1e-5)


def test_feet_alternate_and_the_walker_advances(samples):
    obj, spec = samples["MixamoT"], SPEC["MixamoT"]
    left, right = spec.canonical["foot.L"], spec.canonical["foot.R"]
    ys = []
    for frame in range(1, 62, 3):
        bpy.context.scene.frame_set(frame)
        ys.append((obj.pose.bones[left].head.y, obj.pose.bones[right].head.y,
                   obj.pose.bones[spec.canonical["hips"]].head.y))
    ys = np.array(ys)
    lead = np.sign(ys[:, 0] - ys[:, 1])
    assert (lead > 0).any() and (lead < 0).any()  # each foot takes the lead in turn
    assert ys[-1, 2] - ys[0, 2] == pytest.approx(-2 * walk.SPEED, abs=0.05)


def test_generation_is_deterministic(animdata):
    def snapshot():
        before = set(bpy.data.objects)
        objs = generate.build_all(animdata, walk_on=("RigifyA",))
        obj = objs["RigifyA"]
        keys = [animdata.read_keys(fc)[1] for fc in animdata.fcurves(animdata.assigned_action(obj), obj)]
        body = obj.children[0].data
        co = np.empty(3 * len(body.vertices), dtype=np.float32)
        body.vertices.foreach_get("co", co)
        for item in set(bpy.data.objects) - before:
            bpy.data.objects.remove(item)
        return np.concatenate(keys), co
    keys_a, co_a = snapshot()
    keys_b, co_b = snapshot()
    # Bit for bit when run alone; after the rest of the suite, 142 of 5,795 keys near zero (|v| < 1e-15) came
    # out 1.1e-16 apart (numpy's SIMD loops round a sine's last bit by where its array lies in memory): ten times
    # that, far below a float32 key's resolution anywhere it is not zero.
    np.testing.assert_allclose(keys_a, keys_b, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(co_a, co_b)
