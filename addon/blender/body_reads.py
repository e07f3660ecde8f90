"""The meshes an armature deforms, read once in bulk as plain data (core.skinned_mesh.SkinnedMesh): their
rest vertices in the armature's space, their triangles and each vertex's heaviest bone (core.body builds
the body's volume from it)."""
from __future__ import annotations

import bpy
import numpy as np

from ..core.rig_data import RigData
from ..core.skinned_mesh import SkinnedMesh


def deformed_by(armature: bpy.types.Object) -> list:
    """The mesh objects the armature deforms: an enabled Armature modifier pointing at it, or parented to
    it with the old 'Armature' parenting; sorted by name, so that the same scene reads the same."""
    found = []
    for obj in bpy.data.objects:
        if obj.type != 'MESH':
            continue
        modifier = any(m.type == 'ARMATURE' and m.object == armature and m.show_viewport for m in obj.modifiers)
        if modifier or (obj.parent == armature and obj.parent_type == 'ARMATURE'):
            found.append(obj)
    return sorted(found, key=lambda o: o.name)


def read(armature: bpy.types.Object, rig: RigData) -> SkinnedMesh | None:
    """Every mesh the armature deforms, joined (SkinnedMesh.join), or None where it deforms none. Vertices
    are the meshes' own (their shape keys' basis, no modifier applied) placed in the armature's space;
    weights count only vertex groups named as the rig's bones. A mesh without triangles is left out."""
    meshes = [m for m in (_one(obj, armature, rig) for obj in deformed_by(armature)) if m is not None]
    return SkinnedMesh.join(meshes) if meshes else None


def _one(obj: bpy.types.Object, armature: bpy.types.Object, rig: RigData) -> SkinnedMesh | None:
    mesh = obj.data
    count = len(mesh.vertices)
    if count == 0 or len(mesh.polygons) == 0:
        return None
    co = np.empty(3 * count, dtype=np.float32)
    mesh.vertices.foreach_get("co", co)
    to_armature = np.array(armature.matrix_world.inverted() @ obj.matrix_world, dtype=np.float64)
    vertices = co.reshape(-1, 3).astype(np.float64) @ to_armature[:3, :3].T + to_armature[:3, 3]
    if hasattr(mesh, "calc_loop_triangles"):  # 4.x and later keep them computed
        mesh.calc_loop_triangles()
    triangles = np.empty(3 * len(mesh.loop_triangles), dtype=np.int32)
    mesh.loop_triangles.foreach_get("vertices", triangles)
    bone, weight = _heaviest(obj, rig, count)
    return SkinnedMesh(vertices, triangles.reshape(-1, 3), bone, weight, obj.name)


def _heaviest(obj: bpy.types.Object, rig: RigData, count: int) -> tuple[np.ndarray, np.ndarray]:
    """Per vertex the rig bone whose vertex group weighs it most, and that weight (-1 and 0 for none).
    Blender has no bulk read of vertex-group weights: one pass over the vertices' groups, once per rig."""
    bone_of = np.array([rig.index(g.name) if g.name in rig else -1 for g in obj.vertex_groups] + [-1],
                       dtype=np.int64)
    bone, weight = np.full(count, -1, dtype=np.int64), np.zeros(count)
    for v in obj.data.vertices:
        for element in v.groups:
            b = bone_of[element.group] if element.group < len(bone_of) - 1 else -1
            if b >= 0 and element.weight > weight[v.index]:
                bone[v.index], weight[v.index] = b, element.weight
    return bone, weight
