"""Benchmark: writing keys into F-curves, MotionKit's bulk path against insert loops.

Run inside Blender (`make bench` runs it on the three Blenders):

    tools/with_blender.sh 3.4 -b --factory-startup --python bench/fcurve_write.py -- \\
        --zip dist/motionkit-0.1.0-linux-x64-py311.zip

MotionKit writes all curves x keys (default 100 x 10,000 = 1,000,000 keys)
with motionkit.animdata.write_keys. The per-key loops most add-ons use,
keyframe_points.insert(frame, value) with default options and with
options={'FAST'}, cost the same for every curve and grow quadratically with
the keys per curve, so they run on --insert-curves whole curves and are scaled
linearly to the full count (stated in the output). Every path must produce the
same keys, checked with fcurve.evaluate, or the run fails. Then Blender's floors for the same keys
(bench/harness.py).
"""
from __future__ import annotations

import os
import sys
import time

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # Blender's --python adds no folder

import harness  # noqa: E402


def fresh_target():
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    for action in list(bpy.data.actions):
        bpy.data.actions.remove(action)
    obj = bpy.data.objects.new("BenchTarget", None)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def bulk(animdata, curves, frames, values):
    obj = fresh_target()
    action = animdata.new_action("Bulk")
    channels = [(f'["p{c}"]', 0) for c in range(curves)]
    start = time.perf_counter()
    written = animdata.write_keys(obj, action, channels, frames, values)
    return time.perf_counter() - start, written


def insert_loop(animdata, curves, frames, values, options):
    """The usual add-on loop; curve creation goes through animdata so both worlds work."""
    obj = fresh_target()
    action = animdata.new_action("Insert")
    # One key per curve creates the curves (and 5.x slot); cleared before timing.
    created = animdata.write_keys(obj, action, [(f'["p{c}"]', 0) for c in range(curves)],
                                  frames[:1], values[:curves, :1])
    for fcurve in created:
        fcurve.keyframe_points.clear()
    start = time.perf_counter()
    for c, fcurve in enumerate(created):
        points = fcurve.keyframe_points
        row = values[c]
        for k, frame in enumerate(frames):
            points.insert(frame, row[k], options=options)
        fcurve.update()
    return time.perf_counter() - start, created


def main() -> None:
    def arguments(parser):
        parser.add_argument("--curves", type=int, default=100)
        parser.add_argument("--keys", type=int, default=10_000)
        parser.add_argument("--insert-curves", type=int, default=5)

    args, motionkit = harness.start("fcurve_write.py", __doc__, arguments, repeat=3)
    animdata = motionkit.animdata

    rng = np.random.default_rng(1)
    frames = np.arange(1, args.keys + 1, dtype=np.float64)
    values = rng.normal(size=(args.curves, args.keys))
    total = args.curves * args.keys

    bulk_times = []
    for _ in range(args.repeat):
        seconds, bulk_curves = bulk(animdata, args.curves, frames, values)
        bulk_times.append(seconds)
    bulk_s = harness.median(bulk_times)
    bulk_keys = [tuple(animdata.read_keys(fc)) for fc in bulk_curves[:args.insert_curves]]

    rows = [("MotionKit animdata.write_keys (bulk)", total, bulk_s, bulk_s)]
    for label, options in (("keyframe_points.insert loop", set()),
                           ("keyframe_points.insert loop, options={'FAST'}", {'FAST'})):
        seconds, curves = insert_loop(animdata, args.insert_curves, frames, values, options)
        keys = [tuple(animdata.read_keys(fc)) for fc in curves]
        if not all(np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
                   for a, b in zip(keys, bulk_keys)):
            raise SystemExit(f"fcurve_write: {label} produced different keys than the bulk path")
        rows.append((label, args.insert_curves * args.keys, seconds,
                     seconds * args.curves / args.insert_curves))

    print(f"\nBlender {bpy.app.version_string}: {args.curves} curves x {args.keys} keys "
          f"= {total:,} keys (bulk: median of {args.repeat})")
    print("| method | keys timed | seconds | seconds for all keys | MotionKit faster by |")
    print("|---|---:|---:|---:|---:|")
    for label, keys, seconds, full in rows:
        ratio = full / bulk_s
        scaled = "" if keys == total else " (scaled)"
        print(f"| {label} | {keys:,} | {seconds:.3f} | {full:.2f}{scaled} | {ratio:.0f}x |")
    target = fresh_target()
    channels = [(f'["p{c}"]', 0) for c in range(args.curves)]
    harness.print_floors("animdata.write_keys", bulk_s,
                         harness.floors(animdata, target, [], channels, frames, values, args.repeat), 0, total)


if __name__ == "__main__":
    main()
