"""Benchmark: baking full-body IK over a 10,000-frame clip on a 60-bone rig, MotionKit against Blender's IK.

Run inside Blender (`make bench` runs it on the three Blenders):

    tools/with_blender.sh 5.2 -b --factory-startup --python bench/ik.py -- \\
        --zip dist/motionkit-0.1.0-linux-x64-py314.zip

The rig is bench/retarget.py's humanoid (--bones bones) with its random clip
(one key per frame on every bone). Four empties follow smooth paths near the
hands' and feet's tails in the clip (reachable: each is the tail's own path
plus a slow circle of 6 cm), and each of the four bones must reach its empty:
the arms through clavicle, upper arm, forearm and hand (chain of 4), the legs
through thigh, shin and foot (chain of 3), the root as the clip has it. That
is what Blender's IK constraint can express, so both ways solve the same
problem:
- MotionKit: motionkit.ik.solve over the whole range (DLS, warm-started frame
  to frame), keys on the solved bones, end to end, median of --repeat runs,
  each on a fresh copy of the clip;
- Blender: an IK constraint per effector with the same target and chain
  length, then bpy.ops.nla.bake with visual keying, timed on --bake-frames
  frames and scaled linearly to --frames (stated in the output).
Both ways twice (--keys-into new|current|both): keys in a new action (MotionKit copies the clip, so the other
bones keep their motion; nla.bake's default) and keys in the action the rig
plays (new_action=False; use_current_action=True).
Residual: the effectors' distance to their targets on sampled frames (the
depsgraph's pose matrices), for both; MotionKit's must be no larger.
"""
from __future__ import annotations

import os
import sys
import time

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # Blender's --python adds no folder

import harness  # noqa: E402
import retarget as rig_bench  # noqa: E402  (the humanoid rig and its clip)

EFFECTORS = (("arm_L_3", 4), ("arm_R_3", 4), ("leg_L_2", 3), ("leg_R_2", 3))  # bone, chain length


def tails(mk, obj, names, frames) -> np.ndarray:
    """World tails of the bones on each frame, (frames, bones, 3), posed natively from the clip (the rig
    sits at the origin)."""
    rig, bones = mk.pose_channels.native_rig(obj.data)
    g, heads = mk.pose_channels.armature_motion(obj, obj.animation_data.action, frames, rig, bones)
    index = [[b.name for b in bones].index(name) for name in names]
    lengths = np.array([bones[i].length for i in index])
    axes = mk.rotation_channels.y_axes(g.reshape(len(frames), -1, 4)[:, index])
    return heads.reshape(len(frames), -1, 3)[:, index] + lengths[None, :, None] * axes


def add_targets(mk, obj, frames):
    """One empty per effector, keyed on every frame along the tail's path plus a slow circle."""
    paths = tails(mk, obj, [b for b, _ in EFFECTORS], frames)
    phase = 2.0 * np.pi * frames / 240.0
    empties = []
    for e, (bone, _) in enumerate(EFFECTORS):
        empty = bpy.data.objects.new(f"Goal_{bone}", None)
        bpy.context.scene.collection.objects.link(empty)
        path = paths[:, e] + 0.06 * np.stack([np.cos(phase + e), np.sin(phase + e), 0.5 * np.sin(2 * phase)], 1)
        action = mk.animdata.new_action(empty.name)
        mk.animdata.write_keys(empty, action, [("location", k) for k in range(3)], frames, path.T)
        mk.animdata.assign(empty, action)
        empties.append(empty)
    return empties


def residuals(obj, empties, frames) -> np.ndarray:
    scene = bpy.context.scene
    out = []
    for frame in frames:
        scene.frame_set(int(frame))
        out.append([(obj.matrix_world @ obj.pose.bones[b].tail - g.matrix_world.translation).length
                    for (b, _), g in zip(EFFECTORS, empties)])
    return np.array(out)


def run_blender_ik(obj, empties, bake_frames: int, into_current: bool):
    """An IK constraint per effector (same target and chain length), then nla.bake: (setup, bake) seconds."""
    def add_constraints():
        for (bone, chain), goal in zip(EFFECTORS, empties):
            con = obj.pose.bones[bone].constraints.new('IK')
            con.target, con.chain_count = goal, chain

    setup, bake, _ = rig_bench.constrain_and_bake(obj, add_constraints, bake_frames, use_current_action=into_current)
    return setup, bake


def main() -> None:
    def arguments(parser):
        parser.add_argument("--frames", type=int, default=10_000)
        parser.add_argument("--bones", type=int, default=60)
        parser.add_argument("--bake-frames", type=int, default=500)
        parser.add_argument("--keys-into", choices=("new", "current", "both"), default="both",
                            help="time keying a new action, the current one, or both (the default)")
        parser.add_argument("--rna-keys", action="store_true", help="keys through RNA's foreach_get/foreach_set "
                                                                     "only (motionkit.animdata.KEY_ARRAY = False)")

    args, mk = harness.start("ik.py", __doc__, arguments, repeat=3)
    mk.animdata.KEY_ARRAY = not args.rna_keys

    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, args.frames
    obj = rig_bench.build_rig("Rig", args.bones, target=False)
    clip = rig_bench.source_action(mk.animdata, obj, args.frames)
    frames = np.arange(1, args.frames + 1, dtype=np.float64)
    empties = add_targets(mk, obj, frames)
    effectors = [mk.ik.Effector(bone, target=goal, chain_count=chain) for (bone, chain), goal in zip(EFFECTORS, empties)]

    check = np.unique(np.linspace(1, args.bake_frames, 12).round())
    rows, floor_rows = [], []
    kept = set(bpy.data.actions)  # the clip and the targets' paths
    for into_current in {"new": (False,), "current": (True,), "both": (False, True)}[args.keys_into]:
        # Each run on a fresh copy of the clip; both ways key a new action, or the action the rig plays.
        times, result = [], None
        for _ in range(args.repeat):
            # The previous run's actions go first, so that every run finds memory as the one before it left
            # it: here a copy of the clip into memory this Blender had not used before took 0.09-0.5 s,
            # into memory the run before freed 0.02 s.
            for action in [a for a in bpy.data.actions if a not in kept]:
                bpy.data.actions.remove(action)
            mk.animdata.assign(obj, clip.copy())
            start = time.perf_counter()
            # The problem Blender's IK constraints solve: no natural defaults (the bone map sees a
            # humanoid in this rig, and would add joint ranges the constraints do not have).
            result = mk.ik.solve(obj, effectors, frame_range=(1, args.frames), root_translation=False,
                                 root_rotation=False, new_action=not into_current, natural=False)
            times.append(time.perf_counter() - start)
        ours_s = harness.median(times)
        ours = residuals(obj, empties, check)
        baked = mk.animdata.assigned_action(obj)
        read_curves = list(mk.animdata.fcurves(clip, obj))
        # The keys the solve writes: the solved bones' curves (a new action also holds copies of the others).
        channels, key_frames, values, _ = harness.curve_keys(mk.animdata, baked, obj)
        solved = [i for i, (path, _, _) in enumerate(channels)
                  if any(path.startswith(f'pose.bones["{bone}"]') for bone in result.bones)]
        found = harness.floors(mk.animdata, obj, read_curves, [channels[i] for i in solved], key_frames,
                               values[solved], args.repeat)
        floor_rows.append((into_current, ours_s, found, sum(len(f.keyframe_points) for f in read_curves),
                           values[solved].size))
        mk.animdata.assign(obj, clip.copy())
        setup_s, bake_s = run_blender_ik(obj, empties, args.bake_frames, into_current)
        theirs = residuals(obj, empties, check)
        blender_full = setup_s + bake_s * args.frames / args.bake_frames
        rows.append((into_current, ours_s, ours, setup_s, bake_s, blender_full, theirs, result))
        for action in [a for a in bpy.data.actions if a not in kept and a.users == 0]:
            bpy.data.actions.remove(action)

    print(f"\nBlender {bpy.app.version_string}: {args.bones} bones, {args.frames:,} frames, 4 effectors "
          f"(chains 4, 4, 3, 3), root from the clip; keys through "
          f"{'RNA only' if args.rna_keys else 'the key array where it checks out'}")
    print("| keys go into | method | seconds | residual mean / max (m) | MotionKit faster by |")
    print("|---|---|---:|---:|---:|")
    for into_current, ours_s, ours, setup_s, bake_s, blender_full, theirs, result in rows:
        where = "the current action" if into_current else "a new action"
        print(f"| {where} | motionkit.ik.solve, DLS (median of {args.repeat}) | {ours_s:.3f} | "
              f"{ours.mean():.1e} / {ours.max():.1e} | {blender_full / ours_s:.0f}x |")
        print(f"| {where} | IK constraints + nla.bake, {args.bake_frames} frames timed ({bake_s:.2f} s + "
              f"{setup_s:.2f} s setup), scaled to {args.frames:,} | {blender_full:.1f} | "
              f"{theirs.mean():.1e} / {theirs.max():.1e} | |")
        if ours.max() > theirs.max() + 1e-6:
            raise SystemExit("ik.py: MotionKit's residual is larger than Blender's")
    result = rows[-1][-1]
    print(f"MotionKit's own residuals over all {args.frames:,} frames: mean {result.errors.mean():.1e}, "
          f"max {result.errors.max():.1e} m; median iterations {np.median(result.iterations):.0f}")
    for into_current, ours_s, found, keys_read, keys_written in floor_rows:
        harness.print_floors(f"ik.solve, keys into {'the current' if into_current else 'a new'} action", ours_s,
                             found, keys_read, keys_written)


if __name__ == "__main__":
    main()
