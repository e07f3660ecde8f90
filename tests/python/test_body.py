"""core/body: which bones carry the body, and the body's signed distance from the real Mixamo meshes
(../shared/data/bodies), judged by the generalised winding number written apart in tests/common/bodies.py
and by posing the rig natively."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import bodies
from core import body as body_module
from core.rig_data import RigData
from core.skinned_mesh import SkinnedMesh

@pytest.fixture(scope="module")
def shared(shared_bodies):
    return shared_bodies


def test_each_bone_carries_the_part_of_the_nearest_labelled_bone_at_or_above_it(shared):
    rig, _ = bodies.load(shared, "AJ")
    names = [n.split(":")[1] for n in rig.names]
    # A belly under the chest and a hair bone under the head, as Big Vegas' and Sporty Granny's rigs have.
    parents = list(rig.parents) + [names.index("Spine1"), names.index("Head")]
    extra = np.array([[0.0, -0.1, 1.1], [0.0, 0.0, 1.7]])
    made = RigData("made", rig.names + ("mixamorig:Belly", "mixamorig:HairTop"), tuple(parents),
                   np.vstack([rig.rest, [[1.0, 0.0, 0.0, 0.0]] * 2]), np.vstack([rig.heads, extra]),
                   np.vstack([rig.tails, extra + [0.0, 0.0, 0.1]]), np.concatenate([rig.lengths, [0.1, 0.1]]),
                   rig.connected + (False, False))
    part = dict(zip([n.split(":")[1] for n in made.names], body_module.parts(made, made.body)))
    assert {n for n, p in part.items() if p == "trunk"} == {"Hips", "Spine", "Spine1", "Spine2", "Neck", "Belly"}
    assert {n for n, p in part.items() if p == "head"} == {"Head", "HairTop"}
    for side in ("Left", "Right"):
        assert (part[f"{side}UpLeg"], part[f"{side}Leg"], part[f"{side}Foot"]) == ("thigh", "leg", "leg")
        assert (part[f"{side}Shoulder"], part[f"{side}Arm"]) == ("upper_arm", "upper_arm")
        assert (part[f"{side}ForeArm"], part[f"{side}Hand"]) == ("forearm", "hand")


def _near_the_skin(body, count=1500, seed=1):
    """Points about 3 cm (one standard deviation) off the body bones' vertices."""
    rng = np.random.default_rng(seed)
    on = body.mesh.vertices[np.isin(body.mesh.bone, body.carriers)]
    return on[rng.integers(0, len(on), count)] + rng.normal(0.0, 0.03, (count, 3))


@pytest.mark.parametrize("character", bodies.CHARACTERS)
def test_the_field_is_inside_where_the_winding_number_is(shared, core_native, character):
    """Beyond one cell of the skin, the field's sign is the winding number's wherever that is clear (more
    than 0.2 from a half: Sporty Granny's hair is an open sheet, its winding half-way); nearer, trilinear
    reading of cells a cell apart decides, and the two differ on a few percent (measured 2-8 %)."""
    rig, mesh = bodies.load(shared, character)
    body = body_module.Body.of(rig, mesh)
    points = _near_the_skin(body)
    winding = bodies.winding_numbers(points, mesh.vertices, mesh.triangles)
    distance, _ = body.at_rest(points)
    clear = (np.abs(winding - 0.5) > 0.3) & (np.abs(distance) > body.spacing)
    assert clear.sum() > 500
    np.testing.assert_array_equal(distance[clear] < 0, winding[clear] > 0.5)
    assert np.mean((distance < 0) == (winding > 0.5)) > 0.9


def _surface_samples(mesh, per_edge=6):
    """Points over every triangle on a barycentric grid (per_edge steps a side)."""
    steps = [(i, j) for i in range(per_edge + 1) for j in range(per_edge + 1 - i)]
    w = np.array([(i, j, per_edge - i - j) for i, j in steps], dtype=np.float64) / per_edge
    corners = mesh.vertices[mesh.triangles]  # (T, 3, 3)
    return np.einsum("sk,tkd->tsd", w, corners).reshape(-1, 3)


@pytest.mark.parametrize("character", ["Big_Vegas", "Mousey"])
def test_the_field_s_distance_is_the_distance_to_the_skin(shared, core_native, character):
    """|distance| against the nearest of the skin's points sampled six a triangle's side (so within a
    sixth of an edge, 0.2-0.7 cm, above the true distance): a distance changes by no more than the points
    move (1-Lipschitz), so a trilinear reading of the cells' exact values is within half a cell's diagonal
    of it, sqrt(3)/2 of a cell (0.9-1.4 cm here; measured 0.47 of a cell at worst)."""
    rig, mesh = bodies.load(shared, character)
    body = body_module.Body.of(rig, mesh)
    points = _near_the_skin(body, count=400, seed=2)
    distance, _ = body.at_rest(points)
    surface = _surface_samples(mesh)
    nearest = np.array([np.sqrt(((surface - p) ** 2).sum(axis=1).min()) for p in points])
    edge = np.median(np.linalg.norm(mesh.vertices[mesh.triangles[:, 0]] - mesh.vertices[mesh.triangles[:, 1]],
                                    axis=1))
    error = np.abs(distance) - nearest
    bound = np.sqrt(3.0) / 2.0 * body.spacing
    assert error.max() < edge / 6 + bound and error.min() > -bound


def test_a_part_s_distance_moves_with_its_bone(shared, core_native):
    """Posed (native armature pose: the head turned 45 degrees, a thigh 50 across and out, the spine 18),
    points the head and the thigh carry rigidly read the distance they read at rest, to the doubles'
    rounding, but where a part comes into another's place at rest (then nearer); the rest pose reads as
    the rest."""
    rig, mesh = bodies.load(shared, "Mousey")
    body = body_module.Body.of(rig, mesh)
    turns = {"Head": [-0.3, 0.6, 0.2], "LeftUpLeg": [0.3, 0.1, -0.8], "Spine": [0.2, 0.0, 0.25]}
    rotations = np.tile([1.0, 0.0, 0.0, 0.0], (1, len(rig)))
    for name, rotvec in turns.items():
        b = rig.index("mixamorig:" + name)
        rotations[0, 4 * b:4 * b + 4] = np.roll(Rotation.from_rotvec(rotvec).as_quat(), 1)
    posed = core_native.armature_pose(rig.native, rotations, np.zeros((1, 3 * len(rig))))
    orientations, heads = posed[0], posed[1]
    rest = core_native.armature_pose(rig.native, np.tile([1.0, 0.0, 0.0, 0.0], (1, len(rig))),
                                     np.zeros((1, 3 * len(rig))))
    points = _near_the_skin(body, count=3000, seed=3)
    at_rest, owner = body.at_rest(points)
    on_body = np.isin(owner, body.carriers)  # the others are cells the arms and shins carry
    assert on_body.mean() > 0.8
    np.testing.assert_allclose(body.posed(points[None], *rest)[0][on_body], at_rest[on_body], atol=1e-12)
    for name in ("Head", "LeftUpLeg"):
        b = rig.index("mixamorig:" + name)
        # Points in the part's own cells, carried by the bone.
        mine = owner == b
        carried = points[mine]
        g = Rotation.from_quat(np.roll(orientations[0, 4 * b:4 * b + 4], -1))
        r = Rotation.from_quat(np.roll(rig.unit_rest[b], -1))
        moved = (g * r.inv()).apply(carried - rig.heads[b]) + heads[0, 3 * b:3 * b + 3]
        read = body.posed(moved[None], orientations, heads)[0]
        assert mine.sum() > 50
        # The nearest of the carriers that accept a point: its own bone's reading, or one nearer.
        # Another part reads a point only where it carries the cell the point maps to, and then nearer:
        # near the hip joint the thigh's points turn into the hips' place (measured 8 % of them).
        assert np.all(read <= at_rest[mine] + 1e-12)
        assert np.mean(np.abs(read - at_rest[mine]) < 1e-12) > 0.85


def test_a_mesh_not_on_the_body_is_refused_by_name(shared, core_native):
    rig, mesh = bodies.load(shared, "AJ")
    hand = rig.index("mixamorig:LeftHand")
    off = SkinnedMesh(mesh.vertices, mesh.triangles, np.full(len(mesh.bone), hand), mesh.weight, "Gloves")
    with pytest.raises(ValueError, match="mesh 'Gloves': no vertex is weighted to the trunk, head or thighs"):
        body_module.Body.of(rig, off)
    with pytest.raises(ValueError, match="mesh 'x': triangle 0 names vertex 9 of 3"):
        SkinnedMesh(np.zeros((3, 3)), [[0, 1, 9]], [0, 0, 0], [1.0, 1.0, 1.0], "x")
