"""blender/body_reads: the meshes an armature deforms, read as plain data, against the files they were made
from (../shared/data/bodies) and against Blender's own Armature modifier on a posed frame."""
import importlib
import os

import numpy as np
import pytest

import bodies
import body_scene
import mixamo_pairs as mp

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SHARED = os.path.join(os.path.dirname(ROOT), "shared")


@pytest.fixture(scope="module")
def reads(mk):
    return importlib.import_module(mk.__name__ + ".blender.body_reads")


@pytest.fixture(scope="module")
def core(mk):
    return importlib.import_module(mk.__name__ + ".core.body"), importlib.import_module(mk.__name__ + ".core.rig_data")


def _rig(mk, armature):
    return importlib.import_module(mk.__name__ + ".blender.pose_channels").read_rig(armature)


@pytest.fixture()
def aj(shared_dir):
    if not os.path.isdir(os.path.join(SHARED, "data", "bodies")):
        pytest.fail("../shared/data/bodies is missing")
    armature = mp.import_bvh(mp.san_path(SHARED, "Aj", "Jumping"))
    return armature, body_scene.skin(armature, SHARED, "AJ")


def test_a_skinned_mesh_reads_as_the_file_it_was_made_from(mk, reads, aj):
    armature, obj = aj
    rig = _rig(mk, armature)
    mesh = reads.read(armature, rig)
    data = np.load(bodies.mesh_path(SHARED, "AJ"))
    hips = armature.data.bones[body_scene.bone_of(armature, "Hips")].head_local
    want = np.asarray(data["rest_vertices"], dtype=np.float64) @ bodies.TO_BLENDER.T + np.array(hips)
    # Blender stores vertices in float32: a metre's 6e-8, ten times over.
    np.testing.assert_allclose(mesh.vertices, want, atol=1e-6)
    assert sorted(map(tuple, np.sort(mesh.triangles, axis=1))) == sorted(
        map(tuple, np.sort(data["rest_faces"], axis=1)))
    weights = np.asarray(data["skinning_weights"])
    names = [str(n) for n in data["joint_names"]]
    heaviest = [rig.index(body_scene.bone_of(armature, names[k])) for k in np.argmax(weights, axis=1)]
    np.testing.assert_array_equal(mesh.bone, heaviest)
    np.testing.assert_allclose(mesh.weight, weights.max(axis=1), atol=1e-7)
    assert mesh.source == obj.name


def test_an_armature_that_deforms_no_mesh_reads_none(mk, reads, aj):
    armature, obj = aj
    obj.modifiers[0].object = None
    assert reads.read(armature, _rig(mk, armature)) is None


def test_the_body_read_where_blender_deforms_it_on_a_frame(mk, reads, core, aj):
    """Jumping, frame 40: each vertex Blender's Armature modifier carries on one body bone alone (weight
    1) reads, posed through the pose bones' matrices as Blender evaluates them, the distance it has at rest:
    the body moves part by part as the mesh does."""
    body_module, _ = core
    armature, obj = aj
    rig = _rig(mk, armature)
    body = body_module.Body.of(rig, reads.read(armature, rig))
    frame = 40
    world = body_scene.evaluated_vertices(obj, frame)
    inverse = np.linalg.inv(np.array(armature.matrix_world))
    posed = world @ inverse[:3, :3].T + inverse[:3, 3]
    orientations, heads = _blender_pose(armature, rig)
    rigid = np.isin(body.mesh.bone, body.carriers) & (body.mesh.weight > 0.999)
    assert rigid.sum() > 300
    at_rest, owner = body.at_rest(body.mesh.vertices[rigid])
    mine = owner == body.mesh.bone[rigid]
    read = body.posed(posed[rigid][mine][None], orientations, heads)[0]
    # Blender's float32 deform (a metre's 1e-7, through a few matrices) against the field's doubles; a
    # nearer reading only where another part's place at rest is reached.
    assert np.all(read <= at_rest[mine] + 1e-5)
    assert np.mean(np.abs(read - at_rest[mine]) < 1e-5) > 0.9


def _blender_pose(armature, rig):
    """(1, 4B) orientations and (1, 3B) heads of every bone as Blender evaluates the pose (pose_bone.matrix)."""
    from scipy.spatial.transform import Rotation
    orientations, heads = np.empty((1, 4 * len(rig))), np.empty((1, 3 * len(rig)))
    for b, name in enumerate(rig.names):
        matrix = np.array(armature.pose.bones[name].matrix)
        rotation = matrix[:3, :3] / np.linalg.norm(matrix[:3, :3], axis=0)
        orientations[0, 4 * b:4 * b + 4] = np.roll(Rotation.from_matrix(rotation).as_quat(), 1)
        heads[0, 3 * b:3 * b + 3] = matrix[:3, 3]
    return orientations, heads
