"""out/mirror.png and out/reduction.png: a mirrored Mixamo clip rendered beside its original, and what
world-space key reduction keeps of walk60 against the per-channel mode.

mirror.png: Y Bot's punch (Mixamo's FBX through Blender's importer) on the frame its right fist is
furthest out, and beside it the same clip mirrored by motionkit.mirror: the skinned mesh shows what a
stick figure hides (a forearm twisted by a roll that is not a mirror image, a foot turned the wrong way).

reduction.png: walk60 reduced per channel at its nominal tolerances (1 mm, 0.1 degree) and in world space
(1 mm): the left knee's bend with the keys each keeps, and each frame's worst world error. The errors
are Blender's own evaluation (frame_set, pose_bone.matrix) against the original's, never the reducer's.
"""
from __future__ import annotations

import math
import os
import sys

import bpy
import mathutils
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tests", "common"))
from blender_eval import world_points, world_scale  # noqa: E402
from feet_fingers import import_fbx  # noqa: E402

AXIS, DISTANCE = 0.1, 1e-3


def _world_head(obj, bone):
    return np.array(obj.matrix_world @ obj.pose.bones[bone].head)


def _furthest_punch(obj, frames):
    """The frame where the right hand is furthest from the hips across the floor, and that direction."""
    best = (-1.0, frames[0], None)
    for frame in frames:
        bpy.context.scene.frame_set(int(frame))
        reach = _world_head(obj, "mixamorig:RightHand") - _world_head(obj, "mixamorig:Hips")
        reach[2] = 0.0
        best = max(best, (float(np.linalg.norm(reach)), int(frame), reach), key=lambda b: b[0])
    return best[1], best[2] / np.linalg.norm(best[2])


def _reflected_hand_gap(original, mirrored, frame):
    """Metres between the mirrored left hand and the original right hand reflected in the armature's
    X = 0 plane (both in their own armature space, scaled to world units), at frame."""
    bpy.context.scene.frame_set(frame)
    right = np.array(original.pose.bones["mixamorig:RightHand"].head) * (-1.0, 1.0, 1.0)
    left = np.array(mirrored.pose.bones["mixamorig:LeftHand"].head)
    return float(np.linalg.norm(left - right)) * world_scale(original)


def mirror_figure(motionkit, add_label, render, fbx_dir: str, path: str, samples: int) -> None:
    """Replaces the scene's objects (but its lights and ground) with the two Y Bots and renders them."""
    scene = bpy.context.scene
    for obj in list(bpy.data.objects):
        if obj.type != 'LIGHT' and obj.name != "Ground":
            bpy.data.objects.remove(obj)
    # The clip's FBX holds the skeleton only: Y Bot's skinned FBX plays it, and its mirror image lands on
    # a second Y Bot (mirroring onto another armature).
    clip, _ = import_fbx(os.path.join(fbx_dir, "ybot@punch.fbx"), "Punch clip")
    original, _ = import_fbx(os.path.join(fbx_dir, "ybot.fbx"), "Punch")
    mirrored, _ = import_fbx(os.path.join(fbx_dir, "ybot.fbx"), "Punch mirrored")
    motionkit.animdata.assign(original, motionkit.animdata.assigned_action(clip))
    report = motionkit.mirror(clip, target=mirrored)
    first, last = (int(round(v)) for v in motionkit.animdata.assigned_action(clip).frame_range)
    frame, forward = _furthest_punch(clip, range(first, last + 1))
    gap = _reflected_hand_gap(clip, mirrored, frame)
    bpy.data.objects.remove(clip)
    # Side by side along the mirror plane's normal (the armature's X axis in the world), the camera in front
    # of them where the punch leans: each image is then the other's reflection, the punches go outwards.
    across = np.array(original.matrix_world.to_3x3().normalized().col[0])
    forward = forward - (forward @ across) * across
    forward /= np.linalg.norm(forward)
    original.location = tuple(original.location + mathutils.Vector(-0.75 * across))
    mirrored.location = tuple(mirrored.location + mathutils.Vector(0.75 * across))
    cam = bpy.data.cameras.new("FrontCamera")
    cam.lens = 45
    camera = bpy.data.objects.new("FrontCamera", cam)
    camera.location = tuple(6.2 * forward + (0.0, 0.0, 1.25))
    camera.rotation_euler = (mathutils.Vector((0.0, 0.0, 0.95)) - camera.location).to_track_quat('-Z', 'Y').to_euler()
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.frame_set(frame)
    add_label("Mixamo's punch:\nright fist", tuple(-0.75 * across + (0.0, 0.0, 2.15)), camera, size=0.11)
    add_label("mirrored by MotionKit:\nleft fist", tuple(0.75 * across + (0.0, 0.0, 2.15)), camera, size=0.11)
    print(f"demo: mirror.png frame {frame}: {len(report.pairs)} pairs, {len(report.centre)} centre bones; the "
          f"mirrored left hand is {gap * 1000:.4f} mm from the reflected right hand (Blender's evaluation)")
    render(scene, path, samples)


def _knee_bend(animdata, action, obj, frames):
    """Degrees of the left knee's rotation at frames, its curves sampled in one call."""
    channels = [('pose.bones["lKnee"].rotation_quaternion', k) for k in range(4)]
    w, *vector = animdata.sample(action, obj, channels, np.asarray(frames, dtype=np.float64))[0]
    return np.degrees(2.0 * np.arctan2(np.linalg.norm(vector, axis=0), np.abs(w)))


def _reduced(motionkit, obj, original, frames, reference, **settings):
    """On a copy of the original: (the copy, keys kept, each frame's worst world error in mm, knee bend, knee key
    frames)."""
    animdata = motionkit.animdata
    action = original.copy()
    animdata.assign(obj, action)
    motionkit.reduce_keys(obj, **settings)
    error = np.linalg.norm(world_points(obj, frames, AXIS) - reference, axis=-1).reshape(len(frames), -1)
    curves = animdata.fcurves(action, obj)
    kept = sum(len(fc.keyframe_points) for fc in curves)
    knee = animdata.find_fcurve(action, obj, 'pose.bones["lKnee"].rotation_quaternion', 0)
    bend = _knee_bend(animdata, action, obj, frames)
    return action, kept, 1000.0 * error.max(axis=1), bend, animdata.read_keys(knee)[0]


def reduction_figure(motionkit, mocap: str, path: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    animdata = motionkit.animdata
    obj, original = motionkit.bvh.load(mocap, name="walk60 (reduction)")
    first, last = (int(round(v)) for v in original.frame_range)
    frames = np.arange(first, last + 1)
    reference = world_points(obj, frames, AXIS)
    before = sum(len(fc.keyframe_points) for fc in animdata.fcurves(original, obj))
    scale = world_scale(obj)
    bend = _knee_bend(animdata, original, obj, frames)
    channels = _reduced(motionkit, obj, original, frames, reference, tolerance=DISTANCE / scale,
                        rotation_tolerance=math.radians(0.1))
    world = _reduced(motionkit, obj, original, frames, reference, space='WORLD', distance=DISTANCE,
                     axis_length=AXIS)
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(10, 6.5), sharex=True, constrained_layout=True)
    top.plot(frames, bend, color="black", lw=1.0, ls="--", label=f"captured ({before} keys in the action)")
    for (_, kept, _, knee, keys), label, color, mark in (
            (channels, "per channel, 1 mm / 0.1°", "#d95f02", "s"),
            (world, "world space, 1 mm", "#1b9e77", "o")):
        top.plot(frames, knee, color=color, lw=1.2, label=f"{label}: {kept} keys")
        top.plot(keys, np.interp(keys, frames, knee), mark, color=color, ms=3.5, mfc="none")
    top.set_ylabel("left knee bend (°)")
    low, high = top.get_ylim()
    top.set_ylim(low, high + 0.25 * (high - low))  # room for the legend above the curves
    top.legend(loc="upper center", ncol=3, fontsize=9, frameon=False)
    top.set_title("walk60.bvh reduced: the left knee's curve and its keys; below, every frame's worst world "
                  "error (Blender's evaluation)", fontsize=10)
    for (_, kept, error, _, _), label, color in ((channels, "per channel, 1 mm / 0.1°", "#d95f02"),
                                             (world, "world space, 1 mm", "#1b9e77")):
        bottom.plot(frames, error, color=color, lw=1.2, label=f"{label}: worst {error.max():.2f} mm")
    bottom.axhline(1.0, color="grey", ls=":", lw=1.0)
    bottom.set_ylabel("worst joint or axis-point error (mm)")
    bottom.set_xlabel("frame")
    bottom.legend(loc="upper right", fontsize=9, frameon=False)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    print(f"demo: reduction.png: {before} keys; per channel {channels[1]} (worst {channels[2].max():.3f} mm), "
          f"world space {world[1]} (worst {world[2].max():.3f} mm)")
    armature = obj.data
    bpy.data.objects.remove(obj)
    bpy.data.armatures.remove(armature)
    for action in (channels[0], world[0], original):
        bpy.data.actions.remove(action)
