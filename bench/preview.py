"""Benchmark: the retarget's live preview of a 1,000-frame clip (asked: within 0.3 s of a change), and
the Blender-native way of seeing a retarget over the clip, in the same run.

    tools/with_blender.sh 5.2 -b --factory-startup --python bench/preview.py -- \\
        --zip dist/motionkit-0.1.0-linux-x64-py314.zip

The clip: GAMES-105's walk_and_turn_left played forwards then backwards to --frames frames (a real
capture, continuous), onto the sample Mixamo-named character walking its own walk. Timed (medians of
--repeat):
- MotionKit's preview update: features.preview.show after an option changed (the retarget's plan of the
  whole clip, feet planted, written into a fresh preview action and assigned; what the panel's timer runs
  within a tenth of a second of the change), whole body, and for the arms alone over the character's walk;
- Blender's way: Copy Rotation constraints (world to world) from each mapped source bone, and Copy Location
  on the hips, then the clip played once through (frame_set on every frame: the depsgraph evaluates the
  constraints), what a constraint-based retarget costs to show the clip once after a change.
"""
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import harness  # noqa: E402


def _arguments(parser):
    parser.add_argument("--frames", type=int, default=1000)


def main():
    args, mk = harness.start("bench/preview.py", __doc__.splitlines()[0], _arguments, repeat=5)
    import characters
    import generate
    from motionkit.features import preview

    path = harness.long_walk(mk.native(), args.frames)
    source, _ = mk.bvh.load(path)
    target = generate.build_armature(characters.MIXAMO_T)
    generate.add_walk(target, characters.MIXAMO_T, mk.animdata)
    pairs = mk.retargeting.auto_map(source, target)
    held = preview.start(target)
    state = {"shown": None, "root": "scaled"}

    def update(**options):
        state["root"] = "in_place" if state["root"] == "scaled" else "scaled"  # the change
        shown = preview.show(source, target, pairs, None, mk.retargeting.RetargetOptions(root=state["root"],
                                                                                         **options),
                             held, state["shown"])
        state["shown"] = shown.action

    whole = harness.timed(update, args.repeat)
    arms = harness.timed(lambda: update(parts="arms"), args.repeat)
    loose = harness.timed(lambda: update(plant_feet=False), args.repeat)
    planted = mk.retargeting.plan(source, target, pairs).contact_report
    start, end = source.animation_data.action.frame_range
    frames = int(round(end - start)) + 1
    preview.stop(target, held, state["shown"])
    constrained = _constraints_shown(source, target, pairs, frames)
    version = ".".join(map(str, bpy.app.version[:2]))
    print(f"\nBlender {version}: preview of a {frames}-frame clip, {len(pairs)} bones mapped")
    print("| way | seconds (median) |\n|---|---:|")
    print(f"| MotionKit preview update, whole body, feet planted | {harness.median(whole):.3f} |")
    print(f"| MotionKit preview update, whole body, feet not planted | {harness.median(loose):.3f} |")
    print(f"| MotionKit preview update, arms over the target's walk | {harness.median(arms):.3f} |")
    print(f"| Copy Rotation/Location constraints, the clip played once (frame_set) | {constrained:.3f} |")
    print(f"runs: whole {[round(s, 3) for s in whole]}, arms {[round(s, 3) for s in arms]}; feet held on "
          f"{int(planted.contacts.sum()) if planted is not None else 0} foot-point frames")


def _constraints_shown(source, target, pairs, frames) -> float:
    import time
    for a, b in pairs:
        c = target.pose.bones[b].constraints.new('COPY_ROTATION')
        c.target, c.subtarget = source, a
    hips = next(b for a, b in pairs if b.endswith("Hips"))
    c = target.pose.bones[hips].constraints.new('COPY_LOCATION')
    c.target, c.subtarget = source, next(a for a, b in pairs if b == hips)
    started = time.perf_counter()
    for frame in range(1, frames + 1):
        bpy.context.scene.frame_set(frame)
    return time.perf_counter() - started


main()
