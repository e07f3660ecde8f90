"""Benchmark: importing a BVH file, MotionKit against Blender's own importer.

    tools/with_blender.sh 5.2 -b --factory-startup --python bench/bvh_import.py -- \\
        --zip dist/motionkit-0.1.0-linux-x64-py314.zip

Generates a 10,000-frame, 31-joint file (root with 6 channels, the others 3
rotations in ZXY order), imports it with motionkit.bvh.load and, where it
works (4.2+: 3.4's importer cannot open files under Python 3.11), with
bpy.ops.import_anim.bvh, in the same rotation mode (quaternion, then each
joint's own Euler order), and checks that both armatures pose the same on
sampled frames before printing the ratio; then Blender's floors for the keys the
import writes (bench/harness.py).
"""
from __future__ import annotations

import os
import sys
import tempfile
import time

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # Blender's --python adds no folder

import harness  # noqa: E402

sys.path.insert(0, os.path.join(harness.ROOT, "tests", "common"))

import bvh_cases  # noqa: E402


def skeleton_31():
    """A humanoid-like tree of 31 joints: spine, neck, head, two arms with hands, two legs."""
    zxy = ["Zrotation", "Xrotation", "Yrotation"]
    joints = [("Hips", -1, (0, 1, 0), bvh_cases.POS + zxy, None)]

    def chain(parent, prefix, steps, direction, length, end):
        for k in range(steps):
            offset = tuple(length * d for d in direction)
            last = k == steps - 1
            joints.append((f"{prefix}{k}", parent, offset, zxy, tuple(0.5 * o for o in offset) if last and end else None))
            parent = len(joints) - 1
        return parent

    chest = chain(0, "Spine", 4, (0, 1, 0), 0.12, False)
    chain(chest, "Neck", 2, (0, 1, 0), 0.08, True)
    for side, sx in (("L", 1), ("R", -1)):
        chain(chest, f"{side}Arm", 7, (sx, 0, 0), 0.1, True)
        chain(0, f"{side}Leg", 5, (0, -1, 0.05), 0.18, True)
    assert len(joints) == 31, len(joints)
    return joints


def clear():
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    for collection in (bpy.data.armatures, bpy.data.actions):
        for item in list(collection):
            collection.remove(item)


def timed(fn):
    start = time.perf_counter()
    result = fn()
    return time.perf_counter() - start, result


def heads(obj, frame):
    bpy.context.scene.frame_set(frame)
    return np.array([np.array(obj.matrix_world @ b.head) for b in obj.pose.bones])


def main() -> None:
    args, motionkit = harness.start("bvh_import.py", __doc__, lambda parser: parser.add_argument(
        "--frames", type=int, default=10_000), repeat=3)

    text = bvh_cases.build(skeleton_31(), frames=args.frames, frame_time=1 / 60, seed=3)
    path = os.path.join(tempfile.mkdtemp(), "bench31.bvh")
    with open(path, "w") as f:
        f.write(text)
    size_mb = os.path.getsize(path) / 1e6

    builtin = bpy.app.version >= (4, 2, 0)
    print(f"\nBlender {bpy.app.version_string}: {args.frames:,} frames x 31 joints, {size_mb:.1f} MB "
          f"(median of {args.repeat})")
    print("| rotations | MotionKit s | Blender's importer s | MotionKit faster by |")
    print("|---|---:|---:|---:|")
    totals = {}
    for mode in ('QUATERNION', 'NATIVE'):
        ours_times, theirs_times = [], []
        for _ in range(args.repeat):
            clear()
            seconds, (ours, _) = timed(lambda: motionkit.bvh.load(path, rotation_mode=mode))
            ours_times.append(seconds)
            if builtin:
                before = set(bpy.data.objects)
                seconds, _ = timed(lambda: bpy.ops.import_anim.bvh(filepath=path, rotate_mode=mode))
                theirs_times.append(seconds)
                (theirs,) = [o for o in bpy.data.objects if o not in before]
        if builtin:
            names = [b.name for b in ours.pose.bones]
            for frame in (1, args.frames // 2, args.frames):
                a = heads(ours, frame)
                b = np.array([np.array(theirs.matrix_world @ theirs.pose.bones[n].head) for n in names])
                if not np.allclose(a, b, atol=1e-4):
                    raise SystemExit(f"bvh_import: the importers disagree at frame {frame} ({mode})")
        ours_s = harness.median(ours_times)
        channels, frames, values, _ = harness.curve_keys(motionkit.animdata, motionkit.animdata.assigned_action(ours),
                                                         ours)
        totals[mode] = (ours_s, values.size, harness.floors(motionkit.animdata, ours, [], channels, frames, values,
                                                            args.repeat))
        if builtin:
            theirs_s = harness.median(theirs_times)
            print(f"| {mode} | {ours_s:.3f} | {theirs_s:.3f} | {theirs_s / ours_s:.1f}x |")
        else:
            print(f"| {mode} | {ours_s:.3f} | (3.4's importer is broken) | |")
    for mode, (ours_s, written, found) in totals.items():
        harness.print_floors(f"bvh.load, {mode}", ours_s, found, 0, written)


if __name__ == "__main__":
    main()
