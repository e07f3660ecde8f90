"""Benchmark: world-space key reduction against the per-channel mode and Blender's Decimate, at the same
worst world error, on real clips.

    tools/with_blender.sh 3.4 -b --factory-startup --python bench/reduce_world.py -- \\
        --zip dist/motionkit-0.1.0-linux-x64-py311.zip

Clips: walk60 (../shared/data/bvh, through motionkit.bvh.load) and every Mixamo clip in
../shared/data/fbx (Blender's FBX importer). For each, from the same original action:
(a) reduce_keys(space='WORLD', distance=1 mm, axis_length=10 cm);
(b) reduce_keys per channel with (tolerance, rotation_tolerance) = s * (1 mm in the armature's units,
    0.1 degree), s bisected (in log scale, 14 steps) towards the largest whose worst world error stays
    within (a)'s, keeping of the settings tried the one with the fewest keys within that error;
(c) Blender's graph.decimate(mode='ERROR', remove_error_margin=m) on every curve of the armature, m
    tuned the same way.
The world error is always Blender's: scene.frame_set on every frame, each pose bone's head, tail (bones
without children) and the points 10 cm along its axes from pose_bone.matrix, in world units (armature
space times the object's scale), against the original's. Times are one run at the setting found.
"""
from __future__ import annotations

import glob
import importlib
import os
import sys
import time

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # Blender's --python adds no folder

import harness  # noqa: E402

sys.path.insert(0, os.path.join(harness.ROOT, "tests", "common"))
from blender_eval import world_points, world_scale  # noqa: E402

DISTANCE, AXIS = 1e-3, 0.1
BISECTIONS = 14


def keys_of(animdata, obj):
    return sum(len(fc.keyframe_points) for fc in animdata.fcurves(animdata.assigned_action(obj), obj))


def fresh(animdata, obj, original):
    """A copy of the original action on obj (the last one removed)."""
    old = animdata.assigned_action(obj)
    animdata.assign(obj, original.copy())
    if old is not None and old != original:
        bpy.data.actions.remove(old)


def decimate(animdata, obj, margin):
    screen = bpy.context.window.screen
    area = screen.areas[0]
    area.type = 'GRAPH_EDITOR'
    region = next(r for r in area.regions if r.type == 'WINDOW')
    for fc in animdata.fcurves(animdata.assigned_action(obj), obj):
        fc.select = True
        fc.hide = False
        for point in fc.keyframe_points:
            point.select_control_point = True
    override = {"window": bpy.context.window, "screen": screen, "area": area, "region": region}
    if hasattr(bpy.context, "temp_override"):
        with bpy.context.temp_override(**override):
            result = bpy.ops.graph.decimate(mode='ERROR', remove_error_margin=margin)
    else:
        result = bpy.ops.graph.decimate(override, mode='ERROR', remove_error_margin=margin)
    assert result == {'FINISHED'}, result


def measure(animdata, obj, original, frames, reference, run):
    """run() on a fresh copy: (keys, worst world error, seconds)."""
    fresh(animdata, obj, original)
    start = time.perf_counter()
    run()
    seconds = time.perf_counter() - start
    error = np.linalg.norm(world_points(obj, frames, AXIS) - reference, axis=-1)
    return keys_of(animdata, obj), float(error.max()), seconds


def tune(animdata, obj, original, frames, reference, bound, run_at, low, high):
    """Of the settings a log bisection in [low, high] tries, the one keeping the fewest keys with its worst
    error within bound (the error need not grow monotonically with the setting), and its measure;
    run_at(setting) reduces."""
    passing = []
    for _ in range(BISECTIONS):
        middle = float(np.sqrt(low * high))
        keys, error, _ = measure(animdata, obj, original, frames, reference, lambda: run_at(middle))
        if error <= bound:
            low = middle
            passing.append((keys, -middle))
        else:
            high = middle
    setting = -min(passing)[1] if passing else low
    return setting, measure(animdata, obj, original, frames, reference, lambda: run_at(setting))


def clips(mk):
    walk = os.path.join(harness.SHARED, "data", "bvh", "walk60.bvh")
    yield "walk60", lambda: mk.bvh.load(walk)[0]
    for path in sorted(glob.glob(os.path.join(harness.SHARED, "data", "fbx", "*@*.fbx"))):
        def load(path=path):
            before = set(bpy.data.objects)
            bpy.ops.import_scene.fbx(filepath=path)
            return next(o for o in bpy.data.objects if o not in before and o.type == 'ARMATURE')
        yield os.path.splitext(os.path.basename(path))[0], load


def bench_clip(mk, animdata, name, load):
    obj = load()
    for other in bpy.context.view_layer.objects:
        other.select_set(other == obj)
    bpy.context.view_layer.objects.active = obj
    original = animdata.assigned_action(obj)
    original.use_fake_user = True
    first, last = original.frame_range
    frames = np.arange(int(round(first)), int(round(last)) + 1)
    reference = world_points(obj, frames, AXIS)
    before = keys_of(animdata, obj)
    scale = world_scale(obj)
    world = measure(animdata, obj, original, frames, reference,
                    lambda: mk.reduce_keys(obj, space='WORLD', distance=DISTANCE, axis_length=AXIS))
    bound = world[1]
    channels = tune(animdata, obj, original, frames, reference, bound,
                    lambda s: mk.reduce_keys(obj, s * DISTANCE / scale, s * np.radians(0.1)), 1e-3, 1e3)
    blender = tune(animdata, obj, original, frames, reference, bound,
                   lambda m: decimate(animdata, obj, m), 1e-8, 10.0)
    bones = len(obj.pose.bones)
    print(f"\n{name}: {len(frames)} frames, {bones} bones, {before} keys, object scale {scale:g}")
    print(f"| {name} | (a) world, 1 mm | {world[0]} | {100 * world[0] / before:.1f} % | "
          f"{world[1] * 1e3:.3f} | {world[2]:.3f} |")
    print(f"| {name} | (b) per channel, s = {channels[0]:.3g} | {channels[1][0]} | "
          f"{100 * channels[1][0] / before:.1f} % | {channels[1][1] * 1e3:.3f} | {channels[1][2]:.3f} |")
    print(f"| {name} | (c) Decimate, margin {blender[0]:.3g} | {blender[1][0]} | "
          f"{100 * blender[1][0] / before:.1f} % | {blender[1][1] * 1e3:.3f} | {blender[1][2]:.3f} |")
    sys.stdout.flush()


def main():
    _, mk = harness.start("reduce_world.py", __doc__.splitlines()[0], repeat=1)
    animdata = importlib.import_module(mk.__name__ + ".blender.animdata")
    print(f"Blender {bpy.app.version_string}")
    print("| clip | way | keys | of original | worst world error (mm) | time (s) |")
    for name, load in clips(mk):
        bench_clip(mk, animdata, name, load)
        for obj in list(bpy.data.objects):
            bpy.data.objects.remove(obj)


if __name__ == "__main__":
    main()
