"""The Mixamo meshes of ../shared/data/bodies made into skinned Blender meshes on an armature Blender's
importer made (tests/common/bodies.py has the files' layout): vertex groups named as the armature's bones,
an Armature modifier, the mesh standing on the armature's own hips; and the evaluated mesh, as Blender's
Armature modifier deforms it on a frame."""
from __future__ import annotations

import bpy
import numpy as np

import bodies


def bone_of(armature: bpy.types.Object, joint: str) -> str | None:
    """The armature's bone for a Mixamo joint name, whatever its prefix (mixamorig:, newVegas:, none)."""
    for bone in armature.data.bones:
        if bone.name == joint or bone.name.endswith(":" + joint):
            return bone.name
    return None


def skin(armature: bpy.types.Object, shared: str, character: str, subdivisions: int = 0) -> bpy.types.Object:
    """The character's mesh, its hips on the armature's hips at rest, deformed by the armature; subdivisions:
    times each triangle is split in four (bodies.subdivided)."""
    data = np.load(bodies.mesh_path(shared, character))
    names = [str(n) for n in data["joint_names"]]
    hips = armature.data.bones[bone_of(armature, "Hips")]
    origin = np.array(armature.matrix_world @ hips.head_local)
    vertices = np.asarray(data["rest_vertices"], dtype=np.float64) @ bodies.TO_BLENDER.T + origin
    faces = np.asarray(data["rest_faces"], dtype=np.int64)
    weights = np.asarray(data["skinning_weights"], dtype=np.float64)
    for _ in range(subdivisions):
        vertices, faces, weights = bodies.subdivided(vertices, faces, weights)
    mesh = bpy.data.meshes.new(f"{character}_body")
    mesh.from_pydata(vertices.tolist(), [], faces.tolist())
    mesh.update()
    obj = bpy.data.objects.new(f"{character}_body", mesh)
    bpy.context.scene.collection.objects.link(obj)
    for k, joint in enumerate(names):
        name = bone_of(armature, joint)
        if name is None:
            continue
        group = obj.vertex_groups.new(name=name)
        for v in np.flatnonzero(weights[:, k] > 0.0):
            group.add([int(v)], float(weights[v, k]), 'REPLACE')
    modifier = obj.modifiers.new("Armature", 'ARMATURE')
    modifier.object = armature
    # Parented, so that moving the armature moves its mesh (the modifier alone would turn each part about
    # joints moved away from it).
    obj.parent = armature
    obj.matrix_parent_inverse = armature.matrix_world.inverted()
    return obj


def evaluated_vertices(obj: bpy.types.Object, frame: int) -> np.ndarray:
    """(V, 3) the mesh's vertices in world space as Blender evaluates the frame (its modifiers applied)."""
    scene = bpy.context.scene
    scene.frame_set(frame)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        co = np.empty(3 * len(mesh.vertices), dtype=np.float32)
        mesh.vertices.foreach_get("co", co)
    finally:
        evaluated.to_mesh_clear()
    world = np.array(obj.matrix_world)
    return co.reshape(-1, 3).astype(np.float64) @ world[:3, :3].T + world[:3, 3]
