"""Benchmark: importing a BVH file, MotionKit against Blender's own importer.

    tools/with_blender.sh 5.2 -b --factory-startup --python bench/bvh_import.py -- \\
        --zip dist/motionkit-0.1.0-linux-x64-py314.zip

Generates a 10,000-frame, 31-joint file (root with 6 channels, the others 3
rotations in ZXY order), imports it with motionkit.bvh.load and, where it
works (4.2+: 3.4's importer cannot open files under Python 3.11), with
bpy.ops.import_anim.bvh, both with quaternion rotations, and checks that both
armatures pose the same on sampled frames before printing the ratio.
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

import bpy
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path[:0] = [os.path.join(ROOT, "tools"), os.path.join(ROOT, "tests", "common")]

import bvh_cases  # noqa: E402
import install_addon  # noqa: E402


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


def timed(fn):
    start = time.perf_counter()
    result = fn()
    return time.perf_counter() - start, result


def heads(obj, frame):
    bpy.context.scene.frame_set(frame)
    return np.array([np.array(obj.matrix_world @ b.head) for b in obj.pose.bones])


def main() -> None:
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    parser = argparse.ArgumentParser(prog="bvh_import.py")
    parser.add_argument("--zip", required=True)
    parser.add_argument("--frames", type=int, default=10_000)
    args = parser.parse_args(argv)
    install_addon.install(args.zip)
    import motionkit

    text = bvh_cases.build(skeleton_31(), frames=args.frames, frame_time=1 / 60, seed=3)
    path = os.path.join(tempfile.mkdtemp(), "bench31.bvh")
    with open(path, "w") as f:
        f.write(text)
    size_mb = os.path.getsize(path) / 1e6

    ours_s, (ours, _) = timed(lambda: motionkit.bvh.load(path))
    rows = [("MotionKit motionkit.bvh.load", ours_s)]
    builtin = bpy.app.version >= (4, 2, 0)
    if builtin:
        before = set(bpy.data.objects)
        theirs_s, _ = timed(lambda: bpy.ops.import_anim.bvh(filepath=path, rotate_mode='QUATERNION'))
        (theirs,) = [o for o in bpy.data.objects if o not in before]
        names = [b.name for b in ours.pose.bones]
        for frame in (1, args.frames // 2, args.frames):
            a = heads(ours, frame)
            b = np.array([np.array(theirs.matrix_world @ theirs.pose.bones[n].head) for n in names])
            if not np.allclose(a, b, atol=1e-4):
                raise SystemExit(f"bvh_import: the importers disagree at frame {frame}")
        rows.append(("Blender's import_anim.bvh", theirs_s))

    print(f"\nBlender {bpy.app.version_string}: {args.frames:,} frames x 31 joints, {size_mb:.1f} MB")
    print("| importer | seconds | MotionKit faster by |")
    print("|---|---:|---:|")
    for label, seconds in rows:
        print(f"| {label} | {seconds:.3f} | {seconds / ours_s:.1f}x |")


if __name__ == "__main__":
    main()
