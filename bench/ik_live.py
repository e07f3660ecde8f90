"""Benchmark: one live IK re-solve on a 60-bone rig, as dragging a target in the viewport triggers it.

    tools/with_blender.sh 5.2 -b --factory-startup --python bench/ik_live.py -- \\
        --zip dist/motionkit-0.1.0-linux-x64-py314.zip

bench/retarget.py's humanoid at rest, four effectors (hands and feet, each to
an empty at its tail), root from the pose. An empty is moved 3 mm, the
depsgraph updated, and motionkit's live re-solve (ik_live.solve_live: read the
pose, the limits and the targets, solve natively, write the pose) timed; the
median and worst of --moves moves are printed (building the settings from the panel's
properties, as the handler does on each update, included). It writes the pose, not keys: no key-writing floor
applies (bench/harness.py).
"""
from __future__ import annotations

import os
import sys
import time

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # Blender's --python adds no folder

import harness  # noqa: E402
import ik as ik_bench  # noqa: E402
import retarget as rig_bench  # noqa: E402


def main() -> None:
    args, mk = harness.start("ik_live.py", __doc__,
                             lambda parser: parser.add_argument("--moves", type=int, default=50))
    live = __import__(mk.__name__ + ".features.ik_live", fromlist=["solve_live", "LiveSettings"])
    obj = rig_bench.build_rig("Rig", 60, target=False)
    goals = []
    for bone, _ in ik_bench.EFFECTORS:
        goal = bpy.data.objects.new("Goal_" + bone, None)
        bpy.context.scene.collection.objects.link(goal)
        goal.location = obj.matrix_world @ obj.pose.bones[bone].tail
        item = obj.motionkit_ik.effectors.add()
        item.bone, item.target = bone, goal
        goals.append(goal)
    obj.motionkit_ik.root_translation = obj.motionkit_ik.root_rotation = False
    times = []
    for _ in range(args.moves):
        goals[0].location.x += 0.003
        bpy.context.view_layer.update()
        start = time.perf_counter()
        # As the handler does on each update: the settings from the panel's properties, then the re-solve.
        settings = live.LiveSettings(obj.motionkit_ik.effector_list(), obj.motionkit_ik.method,
                                     obj.motionkit_ik.options())
        live.solve_live(obj, settings)
        times.append(time.perf_counter() - start)
    print(f"\nBlender {bpy.app.version_string}: live IK re-solve, 60 bones, 4 effectors: median "
          f"{1000 * harness.median(times):.2f} ms, worst {1000 * max(times):.2f} ms over {args.moves} moves")


if __name__ == "__main__":
    main()
