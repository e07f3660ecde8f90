"""The Mixamo characters' skinned meshes of ../shared/data/bodies (README there) as the tests use them:
the mesh and its 22-joint skeleton as plain data (a RigData and a SkinnedMesh, in Blender's axes and
metres, as Blender's BVH importer stands the same characters), and an inside test written apart from the
add-on's field: the generalised winding number (Jacobson et al. 2013), exact for a closed mesh and
robust to holes, in numpy."""
from __future__ import annotations

import os

import numpy as np

CHARACTERS = ("AJ", "Kaya", "Big_Vegas", "Mousey", "Sporty_Granny")
# Mixamo's 22 body joints, each with its parent (the files' joint_names order).
PARENTS = {"Hips": None, "Spine": "Hips", "Spine1": "Spine", "Spine2": "Spine1", "Neck": "Spine2",
           "Head": "Neck", "LeftUpLeg": "Hips", "LeftLeg": "LeftUpLeg", "LeftFoot": "LeftLeg",
           "LeftToeBase": "LeftFoot", "RightUpLeg": "Hips", "RightLeg": "RightUpLeg", "RightFoot": "RightLeg",
           "RightToeBase": "RightFoot", "LeftShoulder": "Spine2", "LeftArm": "LeftShoulder",
           "LeftForeArm": "LeftArm", "LeftHand": "LeftForeArm", "RightShoulder": "Spine2",
           "RightArm": "RightShoulder", "RightForeArm": "RightArm", "RightHand": "RightForeArm"}
# The files' cm, Y up, to Blender's metres, Z up (as io_anim_bvh stands a Y-up file).
TO_BLENDER = 0.01 * np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def mesh_path(shared: str, character: str) -> str:
    return os.path.join(shared, "data", "bodies", "meshes", f"{character}.npz")


def load(shared: str, character: str, prefix: str = "mixamorig:"):
    """(RigData, SkinnedMesh): the character's skeleton (its 22 joints as bones: each to its child, the
    ends along their parent bone) and its skin, in metres, Z up, its hips where the file puts them. For
    the tests outside Blender (the add-on's core on the path as `core`)."""
    from core.rig_data import RigData
    from core.skinned_mesh import SkinnedMesh
    from plain_rigs import bone_rest
    data = np.load(mesh_path(shared, character))
    names = [str(n) for n in data["joint_names"]]
    offsets = np.asarray(data["skeleton"], dtype=np.float64)
    joints = {}
    for k, name in enumerate(names):
        parent = PARENTS[name]
        joints[name] = offsets[k] + (joints[parent] if parent else 0.0)
    heads = np.array([joints[n] for n in names]) @ TO_BLENDER.T
    child = {PARENTS[n]: n for n in names if PARENTS[n]}
    child["Hips"], child["Spine2"] = "Spine", "Neck"  # the spine goes on, not a leg or a shoulder
    tails = []
    for k, name in enumerate(names):
        if name in child:
            tails.append(heads[names.index(child[name])])
        else:  # an end: its parent's direction, half as long
            p = names.index(PARENTS[name])
            tails.append(heads[k] + 0.5 * (heads[k] - heads[p]))
    tails = np.array(tails)
    parents = [names.index(PARENTS[n]) if PARENTS[n] else -1 for n in names]
    rest = np.array([bone_rest(h, t, 0.0) for h, t in zip(heads, tails)])
    rig = RigData(character, tuple(prefix + n for n in names), tuple(parents), rest, heads, tails,
                  np.linalg.norm(tails - heads, axis=1), tuple(False for _ in names))
    vertices = (np.asarray(data["rest_vertices"], dtype=np.float64) + joints["Hips"]) @ TO_BLENDER.T
    mesh = SkinnedMesh.from_weights(vertices, data["rest_faces"], data["skinning_weights"], range(len(names)),
                                    source=character)
    return rig, mesh


def subdivided(vertices, faces, weights):
    """Each triangle split in four at its edges' midpoints, a new vertex's weights its edge's ends' mean: the
    same surface with about four times the vertices (a heavier character for timing)."""
    faces = np.asarray(faces, dtype=np.int64)
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    unique, inverse = np.unique(edges, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    middle = len(vertices) + inverse.reshape(3, -1).T  # per face, its edges' new vertices (01, 12, 20)
    vertices = np.vstack([vertices, 0.5 * (vertices[unique[:, 0]] + vertices[unique[:, 1]])])
    weights = np.vstack([weights, 0.5 * (weights[unique[:, 0]] + weights[unique[:, 1]])])
    a, b, c = faces.T
    ab, bc, ca = middle.T
    return vertices, np.concatenate([np.stack(t, axis=1) for t in (
        (a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))]), weights


def winding_numbers(points, vertices, triangles, chunk: int = 256) -> np.ndarray:
    """(N,) the generalised winding number of the triangles about each point: 1 inside a closed,
    outward-wound surface, 0 outside (van Oosterom and Strackee's solid angle of each triangle)."""
    points = np.asarray(points, dtype=np.float64)
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    out = np.empty(len(points))
    for start in range(0, len(points), chunk):
        p = points[start:start + chunk, None, :]
        pa, pb, pc = a - p, b - p, c - p
        la, lb, lc = (np.linalg.norm(v, axis=2) for v in (pa, pb, pc))
        det = np.einsum("ijk,ijk->ij", pa, np.cross(pb, pc))
        dots = lambda u, v: np.einsum("ijk,ijk->ij", u, v)  # noqa: E731
        den = la * lb * lc + dots(pa, pb) * lc + dots(pb, pc) * la + dots(pc, pa) * lb
        out[start:start + chunk] = np.arctan2(det, den).sum(axis=1) / (2.0 * np.pi)
    return out
