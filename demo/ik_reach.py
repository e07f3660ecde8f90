"""out/ik_reach.png: the same reach solved without and with MotionKit's priorities and natural defaults.

Two UnrealA characters walk in place of each other; each reaches with the left hand for a ball ahead of
it and above its head, further than the arm can go, both feet pinned where the walk puts them. On the
left, the solver as it was at first (pins weighted like targets, every joint free and alike); on
the right, the default (strict priorities, distal joints first, human ranges, balance). Seen from the
side, at one frame.
"""
from __future__ import annotations

import math

import bpy
import mathutils
import numpy as np

import characters
import generate

FRAME = 16


def _reacher(motionkit, y: float, ball_color, **options):
    spec = characters.UNREAL_A
    obj = generate.build_armature(spec)
    obj.location.y = y
    generate.build_body(spec, obj)
    generate.add_walk(obj, spec, motionkit.animdata)
    names = spec.canonical
    action = motionkit.animdata.assigned_action(obj)
    start, end = (int(v) for v in action.frame_range)
    frames = np.arange(start, end + 1, dtype=np.float64)
    scene = bpy.context.scene
    shoulders = []
    for f in frames:
        scene.frame_set(int(f))
        shoulders.append(tuple(obj.matrix_world @ obj.pose.bones[names["upper_arm.L"]].head))
    bones = obj.data.bones
    reach = sum(bones[names[k]].length for k in ("upper_arm.L", "forearm.L", "hand.L"))
    path = np.array(shoulders) + reach * 1.25 * np.array([0.15, -0.75, 0.65]) / np.linalg.norm([0.15, -0.75, 0.65])
    ball = bpy.data.meshes.new("Ball")
    goal = bpy.data.objects.new("Ball", ball)
    scene.collection.objects.link(goal)
    _sphere(ball, 0.06)
    material = bpy.data.materials.new("BallRed")
    material.diffuse_color = ball_color
    ball.materials.append(material)
    goal_path = motionkit.animdata.new_action("BallPath")
    motionkit.animdata.write_keys(goal, goal_path, [("location", k) for k in range(3)], frames, path.T)
    motionkit.animdata.assign(goal, goal_path)
    feet = [motionkit.ik.Effector(names[f"foot.{s}"], pin=True, orientation=True) for s in "LR"]
    result = motionkit.ik.solve(obj, feet + [motionkit.ik.Effector(names["hand.L"], target=goal)],
                                frame_range=(start, end), **options)
    return obj, result


def _sphere(mesh, radius: float) -> None:
    verts, faces, rings, segments = [], [], 8, 12
    for i in range(rings + 1):
        theta = math.pi * i / rings
        for j in range(segments):
            phi = 2 * math.pi * j / segments
            verts.append((radius * math.sin(theta) * math.cos(phi), radius * math.sin(theta) * math.sin(phi),
                          radius * math.cos(theta)))
    for i in range(rings):
        for j in range(segments):
            a, b = i * segments + j, i * segments + (j + 1) % segments
            faces.append((a, b, b + segments, a + segments))
    mesh.from_pydata(verts, [], faces)


def figure(motionkit, add_label, render, path: str, samples: int) -> None:
    """Replaces the scene's objects with the two reachers and renders them to path."""
    scene = bpy.context.scene
    for obj in list(bpy.data.objects):
        if obj.type not in ('LIGHT',) and obj.name != "Ground":
            bpy.data.objects.remove(obj)
    before, old = _reacher(motionkit, -1.1, (0.85, 0.1, 0.1, 1.0), natural=False, priorities=False,
                           balance=False, reference="previous", regularization=1e-4)
    after, new = _reacher(motionkit, 1.1, (0.85, 0.1, 0.1, 1.0))
    cam = bpy.data.cameras.new("SideCamera")
    cam.lens = 40
    camera = bpy.data.objects.new("SideCamera", cam)
    camera.location = (7.5, 0.0, 1.3)
    camera.rotation_euler = (mathutils.Vector((0.0, 0.0, 1.05)) - camera.location).to_track_quat('-Z', 'Y').to_euler()
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.frame_set(FRAME)
    add_label("before: pins weighted,\nevery joint alike", (0.0, -1.1, 2.55), camera, size=0.11)
    add_label("after: priorities, natural\ndefaults, balance", (0.0, 1.1, 2.55), camera, size=0.11)
    i = FRAME - 1
    print(f"demo: ik_reach frame {FRAME}: before, feet off by {1000 * old.errors[i, :2].max():.2f} mm, hand "
          f"{1000 * old.errors[i, 2]:.0f} mm short; after, feet off by {1000 * new.errors[i, :2].max():.4f} mm, "
          f"hand {1000 * new.errors[i, 2]:.0f} mm short; whole clip, feet: before {1000 * old.errors[:, :2].max():.1f} "
          f"mm, after {1000 * new.errors[:, :2].max():.5f} mm")
    render(scene, path, samples)
