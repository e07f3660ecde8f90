"""Benchmark: a real Mixamo clip with fingers (Blender's FBX importer) onto a real Mixamo character.

    tools/with_blender.sh 3.4 -b --factory-startup --python bench/retarget_mixamo.py -- \\
        --zip dist/motionkit-0.1.0-linux-x64-py311.zip [--repeats 100]

The punch (ybot@punch.fbx, 65 bones with the fingers' end bones, 66 frames at
30 fps) played --repeats times in a row (its keys copied, so every frame is a
real pose) onto Y Bot (ybot.fbx), both as Blender's FBX importer leaves them
(centimetres, scaled 0.01, turned 90 degrees). The same bones both ways: every
bone the two rigs share by name that is not an end bone (51 pairs, the 30
phalanges among them), given as the bone map.
- MotionKit: motionkit.retarget(source, target, bone_map=pairs), planted feet
  off (the constraint way plants nothing), with each floor fit ("legs", the
  default; "off": the hips scaled only, as before the feet were put on the
  floor), median of --repeat runs;
- the constraint way: COPY_ROTATION (world to world) from each source bone and
  COPY_LOCATION on the hips, then nla.bake with visual keying, timed on
  --bake-frames frames and scaled to the clip's length.
Per-frame costs are printed so that a run of an earlier MotionKit (which has no
floor_fit: then only the plain retarget runs) can be compared on the same bones.
"""
from __future__ import annotations

import os
import sys
import time

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # Blender's --python adds no folder

import harness  # noqa: E402
import retarget as retarget_bench  # noqa: E402

FBX = os.path.join(harness.SHARED, "data", "fbx")


def import_fbx(path):
    before = set(bpy.data.objects)
    bpy.ops.import_scene.fbx(filepath=path)
    return next(o for o in bpy.data.objects if o not in before and o.type == 'ARMATURE')


def repeat_action(action, times: int) -> int:
    """The action's keys played times in a row (each curve's keys shifted by the clip's length): its frames."""
    first, last = (int(round(v)) for v in action.frame_range)
    length = last - first + 1
    for curve in action.fcurves:
        count = len(curve.keyframe_points)
        co = np.empty(2 * count)
        curve.keyframe_points.foreach_get("co", co)
        co = co.reshape(count, 2)
        tiled = np.concatenate([co + [k * length, 0.0] for k in range(times)])
        curve.keyframe_points.add(len(tiled) - count)
        curve.keyframe_points.foreach_set("co", tiled.ravel())
        curve.keyframe_points.foreach_set("interpolation", [2] * len(tiled))  # LINEAR
        curve.update()
    return length * times


def main() -> None:
    def arguments(parser):
        parser.add_argument("--repeats", type=int, default=100, help="times the punch is played in a row")
        parser.add_argument("--bake-frames", type=int, default=660, help="frames the constraint way bakes")

    args, motionkit = harness.start("retarget_mixamo.py", __doc__, arguments, repeat=3)
    target = import_fbx(os.path.join(FBX, "ybot.fbx"))
    source = import_fbx(os.path.join(FBX, "ybot@punch.fbx"))
    if bpy.app.version >= (5, 0, 0):
        raise SystemExit("retarget_mixamo.py: the key tiling reads action.fcurves (Blender 3.4 and 4.x)")
    frames = repeat_action(source.animation_data.action, args.repeats)
    bpy.context.scene.frame_start, bpy.context.scene.frame_end = 1, frames
    shared = [b.name for b in source.data.bones if b.name in target.data.bones and b.children]
    pairs = [(n, n) for n in shared]
    fingers = sum(1 for n in shared if "Hand" in n and not n.endswith("Hand"))
    print(f"punch x {args.repeats}: {frames} frames, {len(source.data.bones)} source bones, {len(pairs)} pairs "
          f"({fingers} phalanges)")
    has_floor_fit = "floor_fit" in motionkit.retarget.__code__.co_varnames
    ways = {"floor_fit=legs": dict(floor_fit="legs"), "floor_fit=off": dict(floor_fit="off")} if has_floor_fit \
        else {"(before floor_fit)": {}}
    results = {}
    for label, options in ways.items():
        def run(options=options):
            motionkit.retarget(source, target, bone_map=pairs, plant_feet=False, **options)
        seconds = harness.timed(run, args.repeat, before=lambda: retarget_bench.clear_action(target))
        results[label] = harness.median(seconds)
        print(f"MotionKit {label}: {results[label]:.3f} s, {1e6 * results[label] / frames:.1f} us a frame "
              f"(fastest of {len(seconds)}: {1e6 * min(seconds) / frames:.1f} us)")
    retarget_bench.clear_action(target)
    setup, bake, _ = retarget_bench.run_constraint_way(source, target, pairs, min(args.bake_frames, frames), False)
    scaled = setup + bake * frames / min(args.bake_frames, frames)
    print(f"constraints + nla.bake: {setup + bake:.2f} s for {min(args.bake_frames, frames)} frames, scaled to "
          f"{frames}: {scaled:.1f} s ({1e6 * scaled / frames:.0f} us a frame)")
    for label, seconds in results.items():
        print(f"| {label} | {seconds:.3f} s | {1e6 * seconds / frames:.1f} us | {scaled / seconds:.0f}x |")


if __name__ == "__main__":
    main()
