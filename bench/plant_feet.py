"""Benchmark: retargeting a 10,000-frame walk with and without planted feet, end to end.

Run inside Blender (`make bench` runs it on the three Blenders):

    tools/with_blender.sh 5.2 -b --factory-startup --python bench/plant_feet.py -- \\
        --zip dist/motionkit-0.1.0-linux-x64-py314.zip

Real capture made long: GAMES-105's walk_and_turn_left.bvh (420 frames at
100 fps, ../shared/data/bvh/more/) played forwards then backwards, again and
again (so the clip stays continuous), to --frames frames, imported by
motionkit.bvh.load and retargeted onto UnrealA (other proportions and rolls,
a floor root) by motionkit.retarget:
- plain: plant_feet=False;
- planted: plant_feet=True (contacts detected on the source, one native IK
  solve over the clip, the contact curves written too);
alternating, --repeat runs of each from the same state (the previous run's
action removed first), medians and the median ratio of the pairs. The issue's budget: planting adds at most 50 %.
- Blender's floors for the planted retarget's own keys (bench/harness.py):
  what any tool that reads the source's keys and writes these pays, however
  it computes them.
Blender has no foot-sliding fix of its own to compare against (its IK
constraints would need a target per contact, keyed by hand). Before the
ratios are printed, every contact must hold to 1 mm (native FK of the keys).
"""
from __future__ import annotations

import importlib
import os
import statistics
import sys
import time

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # Blender's --python adds no folder

import harness  # noqa: E402
import characters  # noqa: E402  (blend_samples, on the path harness sets)
import generate  # noqa: E402

def main() -> None:
    args, mk = harness.start("plant_feet.py", __doc__,
                             lambda parser: parser.add_argument("--frames", type=int, default=10_000))
    retargeting = importlib.import_module(mk.__name__ + ".features.retargeting")
    imports = importlib.import_module(mk.__name__ + ".blender.imports")
    pose_channels = importlib.import_module(mk.__name__ + ".blender.pose_channels")
    animdata = mk.animdata

    long_clip = harness.long_walk(mk.native(), args.frames)
    source, _ = mk.bvh.load(long_clip)
    target = generate.build_armature(characters.UNREAL_A, x=1.5)
    frames_count = int(animdata.assigned_action(source).frame_range[1])

    def remove(action):
        bpy.data.actions.remove(action)

    def run(plant):
        return lambda: mk.retarget(source, target, plant_feet=plant)

    # Alternating, so that a change in the machine's load falls on both alike.
    times = {False: [], True: []}
    action = None
    for _ in range(args.repeat):
        for plant in (False, True):
            if action is not None:
                remove(action)
            start = time.perf_counter()
            action = run(plant)()
            times[plant].append(time.perf_counter() - start)
    (plain_s, plain_lo, plain_hi), (planted_s, planted_lo, planted_hi) = (
        (statistics.median(times[p]), min(times[p]), max(times[p])) for p in (False, True))
    ratios = sorted(b / a for a, b in zip(times[False], times[True]))

    # The same from the file, as a pipeline runs it: retarget(path) imports the capture first.
    file_times = {False: [], True: []}
    for _ in range(max(3, args.repeat // 3)):
        for plant in (False, True):
            remove(action)
            before = set(bpy.data.objects)
            start = time.perf_counter()
            action = mk.retarget(long_clip, target, plant_feet=plant)
            file_times[plant].append(time.perf_counter() - start)
            for obj in set(bpy.data.objects) - before:
                imports.remove_armature(obj)
    file_plain, file_planted = (statistics.median(file_times[p]) for p in (False, True))
    file_ratios = sorted(b / a for a, b in zip(file_times[False], file_times[True]))
    remove(action)
    action = run(True)()

    # Where the planted run's time goes, and a check that it holds its contacts.
    plan_start = time.perf_counter()
    plan = retargeting.plan(source, target)
    plan_s = time.perf_counter() - plan_start
    report = plan.contact_report
    names = [b.name for b in pose_channels.depth_first(target.data)]
    rotations, heads = pose_channels.armature_motion(target, action, plan.frames)
    worst = 0.0
    for p, foot in enumerate(f for f in plan.feet for _ in range(2)):
        b = names.index(foot.foot)
        track = heads[:, 3 * b:3 * b + 3]
        if p % 2:  # the ball: the foot bone's tail
            y = mk.rotation_channels.y_axes(rotations[:, 4 * b:4 * b + 4])
            track = track + target.data.bones[foot.foot].length * y
        on = np.flatnonzero(plan.contacts[:, p])
        for run_ in np.split(on, np.flatnonzero(np.diff(on) > 1) + 1) if on.size else []:
            worst = max(worst, float(np.linalg.norm(track[run_] - track[run_[0]], axis=1).max()))
    if worst > 1e-3:
        raise SystemExit(f"plant_feet.py: a contact slides {1000 * worst:.3f} mm")
    curves = animdata.fcurves(action, target)
    keys = sum(len(fc.keyframe_points) for fc in curves)

    # Blender's floors for the same keys: the source's read, the planted retarget's per-frame curves written.
    source_curves = list(animdata.fcurves(animdata.assigned_action(source), source))
    channels, key_frames, values, _ = harness.curve_keys(animdata, action, target)
    found = harness.floors(animdata, target, source_curves, channels, key_frames, values, args.repeat)

    print(f"\nBlender {bpy.app.version_string}: walk_and_turn_left.bvh there and back, {frames_count:,} frames at "
          f"{plan.frame_rate:g} fps, onto UnrealA ({len(curves)} F-curves, {keys:,} keys); {int(plan.contacts.any(axis=1).sum()):,} frames with "
          f"a contact; worst contact slide {1000 * worst:.3f} mm")
    print("| run | seconds (median, min-max) | against plain |")
    print("|---|---:|---:|")
    print(f"| motionkit.retarget, plant_feet=False | {plain_s:.3f} ({plain_lo:.3f}-{plain_hi:.3f}) | 1.00 |")
    print(f"| motionkit.retarget, plant_feet=True | {planted_s:.3f} ({planted_lo:.3f}-{planted_hi:.3f}) | "
          f"{planted_s / plain_s:.2f} (budget <= 1.50) |")
    print(f"per pair of runs, planted / plain: median {statistics.median(ratios):.2f}, "
          f"{ratios[0]:.2f}-{ratios[-1]:.2f}")
    print(f"from the BVH file (import included): plain {file_plain:.3f} s, planted {file_planted:.3f} s; per pair "
          f"median {statistics.median(file_ratios):.2f}, {file_ratios[0]:.2f}-{file_ratios[-1]:.2f}")
    print(f"planting alone: {planted_s - plain_s:.3f} s (+{100 * (planted_s / plain_s - 1):.0f} %); in one plan() "
          f"({plan_s:.3f} s) the cleanup took {report.seconds:.3f} s, its native solve {report.solve_seconds:.3f} s "
          f"({report.iterations:,} iterations)")
    harness.print_floors("retarget, plant_feet=True", planted_s, found,
                         sum(len(f.keyframe_points) for f in source_curves), values.size)


if __name__ == "__main__":
    main()
