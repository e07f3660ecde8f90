"""Builds the sample characters and their walk cycle in the running Blender.

Deterministic: the same Blender gives the same bones, meshes and keys every run.
Keys go through MotionKit's own bulk writer, so MotionKit must be installed:

    tools/with_blender.sh 3.4 -b --factory-startup --python blend_samples/generate.py -- \\
        --zip dist/motionkit-0.1.0-linux-x64-py311.zip --out build/samples-3.4.blend
"""
from __future__ import annotations

import argparse
import math
import os
import sys

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
if HERE not in sys.path:
    sys.path.insert(0, HERE)

import characters  # noqa: E402
import walk  # noqa: E402

FPS = 30
CYCLES = 2

# Body radius at head and tail of each canonical bone, for a 1.8 m character.
RADII = {
    "hips": (0.12, 0.13), "spine": (0.13, 0.14), "neck": (0.05, 0.05), "head": (0.09, 0.10),
    "shoulder": (0.05, 0.05), "upper_arm": (0.05, 0.04), "forearm": (0.04, 0.032),
    "hand": (0.035, 0.022), "thigh": (0.08, 0.055), "shin": (0.052, 0.04),
    "foot": (0.042, 0.032), "toe": (0.03, 0.022),
}
SEGMENTS = 10
# Ring positions along the bone and the radius factor at each: closed, rounded ends.
RING_T = np.array([0.0, 0.1, 0.5, 0.9, 1.0])
RING_SCALE = np.array([0.45, 0.95, 1.0, 0.95, 0.45])


def _kind(canonical: str) -> str:
    return canonical.split(".")[0]


def build_armature(spec: characters.CharacterSpec, x: float = 0.0) -> bpy.types.Object:
    arm = bpy.data.armatures.new(spec.name)
    obj = bpy.data.objects.new(spec.name, arm)
    obj.location.x = x
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode='EDIT')
    for bone in spec.bones:
        eb = arm.edit_bones.new(bone.name)
        eb.head, eb.tail, eb.roll = bone.head, bone.tail, bone.roll
        if bone.parent:
            eb.parent = arm.edit_bones[bone.parent]
            eb.use_connect = tuple(arm.edit_bones[bone.parent].tail) == tuple(eb.head)
    bpy.ops.object.mode_set(mode='OBJECT')
    arm.display_type = 'STICK'
    return obj


def _bone_tube(head, tail, x_axis, z_axis, radii):
    """Vertices and faces of a rounded tube from head to tail (capped with fans)."""
    head, tail = np.asarray(head), np.asarray(tail)
    angles = np.linspace(0.0, 2.0 * math.pi, SEGMENTS, endpoint=False)
    circle = np.cos(angles)[:, None] * x_axis + np.sin(angles)[:, None] * z_axis
    radius = (radii[0] + (radii[1] - radii[0]) * RING_T) * RING_SCALE
    centres = head + RING_T[:, None] * (tail - head)
    rings = centres[:, None, :] + radius[:, None, None] * circle[None, :, :]
    verts = np.concatenate([rings.reshape(-1, 3), [head, tail]])
    faces = []
    for r in range(len(RING_T) - 1):
        for s in range(SEGMENTS):
            a, b = r * SEGMENTS + s, r * SEGMENTS + (s + 1) % SEGMENTS
            faces.append((a, b, b + SEGMENTS, a + SEGMENTS))
    cap0, cap1, last = len(verts) - 2, len(verts) - 1, (len(RING_T) - 1) * SEGMENTS
    for s in range(SEGMENTS):
        faces.append((cap0, (s + 1) % SEGMENTS, s))
        faces.append((cap1, last + s, last + (s + 1) % SEGMENTS))
    return verts, faces


def build_body(spec: characters.CharacterSpec, arm_obj: bpy.types.Object) -> bpy.types.Object:
    """A skinned body for a sample character, radii by canonical bone."""
    scale = spec.proportions.height / 1.8
    radii = {b.name: tuple(scale * r for r in RADII[_kind(b.canonical)]) for b in spec.bones
             if _kind(b.canonical) in RADII}  # a floor root has no flesh
    return skin_bones(arm_obj, radii, spec.color, spec.name)


def skin_bones(arm_obj: bpy.types.Object, radii: dict, color, name: str) -> bpy.types.Object:
    """One rounded tube per named bone, rigidly weighted to it: a body for any armature."""
    all_verts, all_faces, groups = [], [], []
    offset = 0
    for bone_name, bone_radii in radii.items():
        rest = arm_obj.data.bones[bone_name]
        matrix = rest.matrix_local
        x_axis = np.array(matrix.col[0][:3])
        z_axis = np.array(matrix.col[2][:3])
        verts, faces = _bone_tube(rest.head_local, rest.tail_local, x_axis, z_axis, bone_radii)
        all_verts.append(verts)
        all_faces.extend(tuple(i + offset for i in f) for f in faces)
        groups.append((bone_name, range(offset, offset + len(verts))))
        offset += len(verts)
    mesh = bpy.data.meshes.new(name + "Body")
    mesh.from_pydata(np.concatenate(all_verts).tolist(), [], all_faces)
    mesh.polygons.foreach_set("use_smooth", np.ones(len(mesh.polygons), dtype=bool))
    mesh.update()
    body = bpy.data.objects.new(name + "Body", mesh)
    bpy.context.scene.collection.objects.link(body)
    body.parent = arm_obj
    for bone_name, indices in groups:
        body.vertex_groups.new(name=bone_name).add(list(indices), 1.0, 'REPLACE')
    body.modifiers.new("Armature", 'ARMATURE').object = arm_obj
    subsurf = body.modifiers.new("Smooth", 'SUBSURF')
    subsurf.levels = subsurf.render_levels = 1
    material = bpy.data.materials.new(name + "Skin")
    material.diffuse_color = color
    if material.node_tree is None:
        material.use_nodes = True
    principled = next(n for n in material.node_tree.nodes if n.type == 'BSDF_PRINCIPLED')
    principled.inputs["Base Color"].default_value = color
    principled.inputs["Roughness"].default_value = 0.55
    mesh.materials.append(material)
    return body


def rest_orientations(arm_obj, spec) -> dict[str, np.ndarray]:
    """canonical -> the bone's rest orientation in armature space, as (w, x, y, z)."""
    return {b.canonical: np.array(arm_obj.data.bones[b.name].matrix_local.to_quaternion())
            for b in spec.bones}


def add_walk(arm_obj, spec, animdata, fps: int = FPS, cycles: int = CYCLES) -> bpy.types.Action:
    """Keys the walk on every bone (one key per frame) and assigns it to arm_obj."""
    n = int(round(cycles * walk.CYCLE_SECONDS * fps)) + 1
    frames = np.arange(1, n + 1, dtype=np.float64)
    G, offset = walk.global_rotations(spec, (frames - 1.0) / fps)
    rest = rest_orientations(arm_obj, spec)
    local = walk.local_rotations(spec, rest, G)
    channels, rows = [], []
    for bone in spec.bones:
        path = f'pose.bones["{bone.name}"]'
        channels += [(f"{path}.rotation_quaternion", i, bone.name) for i in range(4)]
        rows.append(local[bone.canonical].T)
        if bone.canonical == "hips":  # under a floor root too: the root stays on the floor
            channels += [(f"{path}.location", i, bone.name) for i in range(3)]
            rows.append(walk.hips_location(rest[bone.canonical], offset).T)
    action = animdata.new_action(spec.name + "Walk")
    animdata.write_keys(arm_obj, action, channels, frames, np.vstack(rows))
    animdata.assign(arm_obj, action)
    return action


def build_all(animdata, spacing: float = 1.2, walk_on=("MixamoT",), offset: float = 0.0) -> dict[str, bpy.types.Object]:
    """All sample characters side by side along X; the walk on those named in walk_on."""
    out = {}
    for i, spec in enumerate(characters.CHARACTERS):
        obj = build_armature(spec, x=offset + (i - (len(characters.CHARACTERS) - 1) / 2) * spacing)
        build_body(spec, obj)
        if spec.name in walk_on:
            add_walk(obj, spec, animdata)
        out[spec.name] = obj
    bpy.context.scene.render.fps = FPS
    return out


def main() -> None:
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    parser = argparse.ArgumentParser(prog="generate.py")
    parser.add_argument("--zip", help="install this MotionKit zip first")
    parser.add_argument("--out", required=True, help=".blend file to write")
    args = parser.parse_args(argv)
    if args.zip:
        sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tools"))
        import install_addon
        install_addon.install(args.zip)
    import motionkit
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    build_all(motionkit.animdata, walk_on=tuple(s.name for s in characters.CHARACTERS))
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(args.out))
    print(f"generate.py: wrote {args.out}")


if __name__ == "__main__":
    main()
