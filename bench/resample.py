"""Benchmark: resampling a 10,000-frame, 60-bone action, MotionKit against the usual Python way.

Run inside Blender (`make bench` runs it on the three Blenders):

    tools/with_blender.sh 5.2 -b --factory-startup --python bench/resample.py -- \\
        --zip dist/motionkit-0.1.0-linux-x64-py314.zip

The action: 60 bones with quaternion rotations and a root location, one
linear key per frame at 60 fps (243 F-curves x 10,000 keys). Both ways put it
on 24 fps (4,000 keys per curve) with the scene's rate changed:
- MotionKit: motionkit.resample (squad rotations, Catmull-Rom locations),
  exact Bezier output and dense output, medians of --repeat runs on fresh
  copies of the action;
- the usual Python way: for every curve, fcurve.evaluate at every new frame,
  then keyframe_points.insert for every new key. Its cost is the same for
  every curve (and quadratic in keys per curve), so it runs on --python-curves
  whole curves and is scaled linearly to all 243 (stated in the output).
Before any ratio is printed, both must agree at the new keys that fall on old
keys (every other one at 60 -> 24), where every interpolant equals the data.
"""
from __future__ import annotations

import os
import sys
import time

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # Blender's --python adds no folder

import harness  # noqa: E402

SOURCE_FPS, TARGET_FPS = 60, 24


def build_rig(bones: int):
    armature = bpy.data.armatures.new("BenchRig")
    obj = bpy.data.objects.new("BenchRig", armature)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode='EDIT')
    parent = None
    for i in range(bones):
        bone = armature.edit_bones.new(f"b{i:02d}")
        bone.head = (0.0, 0.0, 0.1 * i)
        bone.tail = (0.0, 0.0, 0.1 * (i + 1))
        bone.parent = parent
        parent = bone if i % 10 else None
    bpy.ops.object.mode_set(mode='OBJECT')
    return obj


def source_action(animdata, obj, frames_count: int):
    rng = np.random.default_rng(7)
    frames = np.arange(1, frames_count + 1, dtype=np.float64)
    channels, rows = [], []
    names = [b.name for b in obj.pose.bones]
    for name in names:
        path = f'pose.bones["{name}"]'
        if name == names[0]:
            channels += [(f"{path}.location", k, name) for k in range(3)]
            rows += list(np.cumsum(rng.normal(scale=0.01, size=(3, frames.size)), axis=1))
        vectors = np.cumsum(rng.normal(scale=0.02, size=(frames.size, 3)), axis=0)
        angle = np.linalg.norm(vectors, axis=1, keepdims=True)
        q = np.hstack([np.cos(angle / 2), np.sin(angle / 2) * vectors / np.maximum(angle, 1e-12)])
        q *= np.where(np.cumsum(np.r_[0, np.einsum("ij,ij->i", q[1:], q[:-1]) < 0]) % 2, -1.0, 1.0)[:, None]
        channels += [(f"{path}.rotation_quaternion", k, name) for k in range(4)]
        rows += list(q.T)
    action = animdata.new_action("Source")
    animdata.write_keys(obj, action, channels, frames, np.array(rows))
    return action


def set_scene(frames_count: int):
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = SOURCE_FPS, 1.0
    scene.frame_start, scene.frame_end = 1, frames_count


def run_motionkit(mk, animdata, obj, source, output):
    action = source.copy()
    animdata.assign(obj, action)
    set_scene(int(source.frame_range[1]))
    start = time.perf_counter()
    mk.resample(obj, fps=TARGET_FPS, change_scene_rate=True, rotation="squad", scalar="catmull-rom",
                output=output)
    return time.perf_counter() - start, action


def run_python_way(animdata, obj, source, curves: int):
    """fcurve.evaluate at every new frame, then keyframe_points.insert per key, on whole curves."""
    action = source.copy()
    animdata.assign(obj, action)
    set_scene(int(source.frame_range[1]))
    scale = TARGET_FPS / SOURCE_FPS
    first, last = source.frame_range
    new_frames = np.arange(1.0, 1.0 + (last - first) * scale + 1e-9)
    old_frames = 1.0 + (new_frames - 1.0) / scale
    fcurves = list(animdata.fcurves(action, obj))[:curves]
    start = time.perf_counter()
    for fcurve in fcurves:
        values = [fcurve.evaluate(f) for f in old_frames]
        fcurve.keyframe_points.clear()
        for frame, value in zip(new_frames, values):
            fcurve.keyframe_points.insert(frame, value)
        fcurve.update()
    seconds = time.perf_counter() - start
    return seconds, fcurves


def main() -> None:
    def arguments(parser):
        parser.add_argument("--frames", type=int, default=10_000)
        parser.add_argument("--bones", type=int, default=60)
        parser.add_argument("--python-curves", type=int, default=6)

    args, mk = harness.start("resample.py", __doc__, arguments, repeat=3)
    animdata = mk.animdata

    obj = build_rig(args.bones)
    source = source_action(animdata, obj, args.frames)
    total_curves = len(animdata.fcurves(source, obj)) if animdata.LAYERED else len(source.fcurves)

    results = {}
    for output in ('EXACT', 'DENSE'):
        times, action = [], None
        for _ in range(args.repeat):
            if action is not None:  # each run starts from the same scene, not one full of earlier copies
                bpy.data.actions.remove(action)
            seconds, action = run_motionkit(mk, animdata, obj, source, output)
            times.append(seconds)
        results[output] = (harness.median(times), action)
    python_s, python_curves = run_python_way(animdata, obj, source, args.python_curves)
    python_full = python_s * total_curves / args.python_curves

    # Agreement where the new keys fall on old keys (every other key at 60 -> 24).
    for output, (_, action) in results.items():
        for fcurve in python_curves:
            ours = animdata.find_fcurve(action, obj, fcurve.data_path, fcurve.array_index)
            a, b = animdata.read_keys(ours), animdata.read_keys(fcurve)
            if a[0].size != b[0].size or not np.allclose(a[0], b[0]):
                raise SystemExit(f"resample: {output} key frames differ from the Python way")
            if not np.allclose(a[1][::2], b[1][::2], atol=1e-6):
                raise SystemExit(f"resample: {output} keys on old frames differ from the Python way")
    keys_out = results['EXACT'][1]
    out_count = sum(len(f.keyframe_points) for f in animdata.fcurves(keys_out, obj))

    print(f"\nBlender {bpy.app.version_string}: {args.bones} bones, {total_curves} F-curves x {args.frames:,} "
          f"keys at {SOURCE_FPS} fps -> {TARGET_FPS} fps ({out_count:,} keys written)")
    print("| method | seconds | MotionKit faster by |")
    print("|---|---:|---:|")
    for output, (seconds, _) in results.items():
        print(f"| motionkit.resample, squad + Catmull-Rom, {output.lower()} output (median of {args.repeat}) "
              f"| {seconds:.3f} | {python_full / seconds:.0f}x |")
    print(f"| fcurve.evaluate + keyframe_points.insert, {args.python_curves} curves timed ({python_s:.2f} s), "
          f"scaled to {total_curves} | {python_full:.1f} | |")
    source_curves = list(animdata.fcurves(source, obj))
    keys_in = sum(len(f.keyframe_points) for f in source_curves)
    channels, frames, values, _ = harness.curve_keys(animdata, keys_out, obj)
    harness.print_floors("resample, exact output", results['EXACT'][0],
                         harness.floors(animdata, obj, source_curves, channels, frames, values, args.repeat),
                         keys_in, values.size)


if __name__ == "__main__":
    main()
