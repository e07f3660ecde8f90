"""Benchmark: retargets measured against Mixamo's own (the SAN protocol, tests/common/san_protocol.py).

    tools/with_blender.sh 3.4 -b --factory-startup --python bench/mixamo_pairs.py -- \\
        --zip dist/motionkit-0.1.0-linux-x64-py311.zip [--every N] [--no-fbx] [--no-san] [--excerpts [--stride]]

Mixamo retargets every animation onto every character itself, so one clip on
two characters is a reference answer (../shared/data/pairs, README there).
Each clip of one character retargeted onto the other's rest armature, its 22
main body joints (21 on girl2) in world space, frame by frame, against the
other's own clip: the mean distance in % of the target's height over the
joints ("all"), the same with each frame's joints relative to its hips
("pose"), SAN's mean squared error over the height squared x1000 ("mse").
- san/Aj <-> san/Kaya: 4 clips x 2 directions, Blender's BVH importer; the
  target's own clip evaluated in Blender must agree with san_protocol's numpy
  forward kinematics to 1e-4 of its height (the protocol's sanity check);
- fbx/girl1 <-> fbx/girl2: 3 clips x 2 directions, Blender's FBX importer,
  both sides evaluated in Blender, girl2's body joints by the fixed
  correspondence san_protocol.GIRL2_JOINTS.
Methods: the plain rotation copy (san: numpy on the files' local rotations;
fbx: each body bone's world turn from rest, through the correspondence);
Blender's own way (COPY_ROTATION from each same-named or corresponding source
bone, World/World or Local/Local, COPY_LOCATION World on the hips, nla.bake
with visual keying); MotionKit's defaults, motionkit.retarget(source, target);
and MotionKit's defaults given the constraints' bone map (bone_map=pairs), to
tell the automatic map's share from the rest.
Wall time of each method (Blender's evaluation of the result not included).
"""
from __future__ import annotations

import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # Blender's --python adds no folder

import harness  # noqa: E402

sys.path.insert(0, os.path.join(harness.ROOT, "tests", "common"))

import mixamo_pairs as mp  # noqa: E402

SANITY = 1e-4  # of the height: Blender's evaluation against the numpy reference (float32 bone matrices)
EXCERPT_SANITY = 1e-3  # the same for the excerpts (BigVegas's root imported 0.17 mm off, 4.7 m out)


def print_table(title: str, rows) -> None:
    """rows: (label, result) pairs; one line per retarget and method, then each method's means."""
    print(f"\n### {title}\n")
    print("| clip | method | all joints % | pose alone % | SAN mse x1000 | seconds |")
    print("|---|---|---:|---:|---:|---:|")
    for label, result in rows:
        for method, e in result["errors"].items():
            print(f"| {label} | {method} | {e['all']:.2f} | {e['pose']:.2f} | {e['san_mse']:.3f} "
                  f"| {result['seconds'][method]:.2f} |")
    methods = rows[0][1]["errors"].keys()
    print(f"\nmeans over {len(rows)} retargets:\n")
    print("| method | all joints % | pose alone % | SAN mse x1000 | seconds (total) |")
    print("|---|---:|---:|---:|---:|")
    for method in methods:
        means = {k: np.mean([r["errors"][method][k] for _, r in rows]) for k in ("all", "pose", "san_mse")}
        total = sum(r["seconds"][method] for _, r in rows)
        print(f"| {method} | {means['all']:.2f} | {means['pose']:.2f} | {means['san_mse']:.3f} | {total:.1f} |")
    sys.stdout.flush()


def main() -> None:
    def arguments(parser):
        parser.add_argument("--every", type=int, default=1, help="measure every N-th frame")
        parser.add_argument("--no-fbx", action="store_true", help="only the BVH pairs")
        parser.add_argument("--no-san", action="store_true", help="only the FBX pairs")
        parser.add_argument("--joints", action="store_true",
                            help="also each body joint's pose-alone error, mean over the SAN retargets")
        parser.add_argument("--clips", nargs="*", help="only these SAN clips")
        parser.add_argument("--excerpts", action="store_true",
                            help="also Aj's and Kaya's clips onto the four characters of tests/data/mixamo_excerpts")
        parser.add_argument("--stride", action="store_true",
                            help="with --excerpts: also MotionKit given Mixamo's stride (Scale Horizontal)")
        parser.add_argument("--own", action="store_true",
                            help="each FBX target plays another clip of its own when the retarget starts")

    args, motionkit = harness.start("mixamo_pairs.py", __doc__, arguments, repeat=1)
    if not args.no_san:
        san_pairs(motionkit, args)
    if not args.no_fbx:
        fbx_pairs(motionkit, args)
    if args.excerpts:
        excerpt_pairs(motionkit, args.stride)


def excerpt_pairs(motionkit, stride: bool) -> None:
    """Aj's and Kaya's whole clips onto each excerpt's rest, measured on the excerpt's frames; a table per clip.
    stride: MotionKit with Mixamo's own stride given (mixamo_pairs.STRIDE) besides."""
    methods = ("plain copy", "MotionKit") + ((mp.STRIDE,) if stride else ())
    for clip in dict.fromkeys(c for c, _ in mp.EXCERPT_RUNS):
        rows = []
        for source in mp.SAN_CHARACTERS:
            for target in mp.EXCERPT_CHARACTERS:
                for part in (p for c, p in mp.EXCERPT_RUNS if c == clip):
                    result = mp.measure_excerpt(motionkit, mp.san_path(harness.SHARED, source, clip), target, part,
                                                methods, clip=clip)
                    if not result["sanity"] <= EXCERPT_SANITY:
                        raise SystemExit(f"{target}'s {clip} ({part}): Blender's joints {result['sanity']:.2e} of "
                                         f"the height from the numpy reference (asked {EXCERPT_SANITY})")
                    rows.append((f"{clip} {source}->{target} ({part}, frames {result['start']}+{result['frames']})",
                                 result))
        print_table(f"san/Aj, san/Kaya -> tests/data/mixamo_excerpts, {clip} (BVH)", rows)


def san_pairs(motionkit, args) -> None:
    rows = []
    for clip in args.clips or mp.SAN_CLIPS:
        for source, target in (mp.SAN_CHARACTERS, mp.SAN_CHARACTERS[::-1]):
            result = mp.measure_san(motionkit, harness.SHARED, source, target, clip, args.every)
            if not result["sanity"] <= SANITY:
                raise SystemExit(f"{target}'s {clip}: Blender's joints {result['sanity']:.2e} of the height "
                                 f"from the numpy reference (asked {SANITY})")
            print(f"{clip} {source} -> {target}: {result['frames']} frames, height {result['height']:.3f} m, "
                  f"sanity {result['sanity']:.1e} of the height", flush=True)
            rows.append((f"{clip} {source}->{target}", result))
    print(f"sanity: at most {max(r['sanity'] for _, r in rows):.1e} of the height over {len(rows)} clips")
    print_table("san/Aj <-> san/Kaya (BVH)", rows)
    if args.joints:
        print_joints(rows)


def print_joints(rows) -> None:
    """Each body joint's pose-alone error (% of the height), mean over the retargets, per method."""
    methods = list(rows[0][1]["joint_pose"])
    print(f"\npose alone per joint, mean over {len(rows)} retargets (% of the height):\n")
    print("| joint | " + " | ".join(methods) + " |")
    print("|---|" + "---:|" * len(methods))
    means = {m: np.mean([r["joint_pose"][m] for _, r in rows], axis=0) for m in methods}
    for j, joint in enumerate(mp.sp.BODY_JOINTS):
        print(f"| {joint} | " + " | ".join(f"{means[m][j]:.2f}" for m in methods) + " |")


def fbx_pairs(motionkit, args) -> None:
    fbx_rows = []
    for k, clip in enumerate(mp.FBX_CLIPS):
        own = mp.FBX_CLIPS[(k + 1) % len(mp.FBX_CLIPS)] if args.own else None
        for source, target in (mp.FBX_CHARACTERS, mp.FBX_CHARACTERS[::-1]):
            result = mp.measure_fbx(motionkit, harness.SHARED, source, target, clip, args.every, own=own)
            print(f"{clip} {source} -> {target}: {result['frames']} frames, {result['joints']} joints, "
                  f"height {result['height']:.4g}", flush=True)
            fbx_rows.append((f"{clip} {source}->{target}", result))
    print_table("fbx/girl1 <-> fbx/girl2 (FBX)", fbx_rows)


if __name__ == "__main__":
    main()
