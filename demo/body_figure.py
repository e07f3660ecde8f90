"""out/body.png: a slim character's dance onto a cartoon mouse, rendered with the meshes: the source on its
own body, the plain retarget (MotionKit's bones only, body="off") and MotionKit's with the body stage, on
the frame where the plain retarget's arms go deepest into Mousey's body.

Sporty Granny's Macarena Dance (Mixamo's, ../shared/data/bodies/clips) onto Mousey (a huge head, short
arms), both skinned from ../shared/data/bodies/meshes (tests/common/body_scene). The frame is chosen and the
figures under it measured by tests/common/body_metrics on Blender's evaluated meshes (the winding number of
the trunk, head and thighs about the forearm and hand vertices), not by MotionKit's own report.
"""
from __future__ import annotations

import os
import sys

import bpy
import mathutils
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tests", "common"))

import body_metrics as bm  # noqa: E402
import mixamo_pairs as mp  # noqa: E402

SOURCE, TARGET, CLIP = "Sporty_Granny", "Mousey", "Macarena Dance"
COLOURS = {"source": (0.55, 0.62, 0.85, 1.0), "plain": (0.85, 0.45, 0.35, 1.0), "body": (0.35, 0.72, 0.45, 1.0)}


def available(shared: str) -> str | None:
    """Why the figure cannot be made here (None when it can): under CI=true a missing input is an error."""
    clips = os.path.join(shared, "data", "bodies", "clips")
    missing = [p for p in (os.path.join(clips, c, f"{CLIP}.bvh") for c in (SOURCE, TARGET)) if not os.path.isfile(p)]
    if missing:
        if os.environ.get("CI") == "true":
            raise SystemExit(f"demo: {missing[0]} is missing, and CI=true requires it")
        return f"{missing[0]} is absent"
    return None


def _paint(obj, colour) -> None:
    material = bpy.data.materials.new(obj.name + " skin")
    material.diffuse_color = colour
    material.use_nodes = True
    bsdf = next(n for n in material.node_tree.nodes if n.type == 'BSDF_PRINCIPLED')
    bsdf.inputs["Base Color"].default_value = colour
    obj.data.materials.append(material)


def figure(motionkit, add_label, render, shared: str, path: str, samples: int) -> None:
    """Replaces the scene's objects (but its lights and ground) with the three dancers and renders them."""
    scene = bpy.context.scene
    for obj in list(bpy.data.objects):
        if obj.type != 'LIGHT' and obj.name != "Ground":
            bpy.data.objects.remove(obj)
    clips = os.path.join(shared, "data", "bodies", "clips")
    source = mp.import_bvh(os.path.join(clips, SOURCE, f"{CLIP}.bvh"))
    own = mp.import_bvh(os.path.join(clips, TARGET, f"{CLIP}.bvh"))
    plain, body = mp.rest_copy(own, "bones only"), mp.rest_copy(own, "with the body")
    bpy.data.objects.remove(own)
    motionkit.retarget(source, plain, body="off")
    skins = {"source": bm.Skinned.of(source, shared, SOURCE), "plain": bm.Skinned.of(plain, shared, TARGET),
             "body": bm.Skinned.of(body, shared, TARGET)}
    motionkit.retarget(source, body)
    frames = np.arange(1, int(motionkit.animdata.assigned_action(source).frame_range[1]) + 1, 20)
    plain_frames = bm.measure(skins["plain"], frames)
    frame = int(frames[np.argmax(plain_frames.inside)])
    one = {k: bm.measure(s, [frame]) for k, s in skins.items()}
    for key, armature, x in (("source", source, -1.3), ("plain", plain, 0.0), ("body", body, 1.3)):
        armature.location.x += x
        _paint(skins[key].obj, COLOURS[key])
    cam = bpy.data.cameras.new("BodyCamera")
    cam.lens = 36
    camera = bpy.data.objects.new("BodyCamera", cam)
    camera.location = (0.0, -5.6, 1.2)
    camera.rotation_euler = (mathutils.Vector((0.0, 0.0, 0.95)) - camera.location).to_track_quat('-Z', 'Y').to_euler()
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.frame_set(frame)
    text = {"source": f"{SOURCE.replace('_', ' ')}'s own\n(the source)",
            "plain": f"onto {TARGET}, bones only\n{100 * one['plain'].inside[0]:.0f} % of the arms inside",
            "body": f"onto {TARGET}, MotionKit\n{100 * one['body'].inside[0]:.0f} % of the arms inside"}
    for key, x in (("source", -1.3), ("plain", 0.0), ("body", 1.3)):
        add_label(text[key], (x, 0.0, 2.02), camera, size=0.08)
    print(f"demo: body.png {CLIP} frame {frame}: forearm and hand vertices inside the body: source "
          f"{100 * one['source'].inside[0]:.1f} %, bones only {100 * one['plain'].inside[0]:.1f} % "
          f"({100 * one['plain'].deepest[0]:.1f} cm deep), MotionKit {100 * one['body'].inside[0]:.1f} % "
          f"({100 * one['body'].deepest[0]:.1f} cm); over every twentieth frame: bones only "
          f"{100 * plain_frames.inside.mean():.1f} %")
    render(scene, path, samples)
