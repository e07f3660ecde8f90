"""Benchmark: retargeting a 10,000-frame clip onto a 60-bone rig, MotionKit against the constraint way.

Run inside Blender (`make bench` runs it on the three Blenders):

    tools/with_blender.sh 5.2 -b --factory-startup --python bench/retarget.py -- \\
        --zip dist/motionkit-0.1.0-linux-x64-py314.zip

Two humanoid-ish armatures with the same topology (--bones bones each: hips,
spine, neck and head, two arms with clavicle, hand and finger chains, two legs
and a tail), the target with other names, proportions, rest directions (arms
45 degrees down instead of a T-pose, a leaning spine, flat feet, fingers
curled, a tail curling up) and random bone rolls. The source has one linear
key per frame on every bone's rotation_quaternion (smooth random rotations)
and on the root's location, --frames frames.
- MotionKit: motionkit.retarget(source, target, bone_map=pairs), end to end
  (reading the source's keys, FK, the native retarget, writing a new action
  with one key per frame), median of --repeat runs, each from the same state
  (the previous run's action removed first);
- the constraint way, the usual Blender recipe on the same rigs: COPY_ROTATION
  (world space to world space) from each mapped source bone on every target
  bone and COPY_LOCATION on the root, then bpy.ops.nla.bake with visual
  keying and clear_constraints (on 4.1 and later only the location and
  rotation channels, as MotionKit writes, unless --bake-all-channels). Every
  frame costs it a depsgraph evaluation and a key per channel, so it is timed
  on --bake-frames frames and scaled linearly to --frames (stated in the
  output). On 5.2 that is what a whole bake measures; on 3.4, which inserts the
  keys one by one, the cost per frame grows with the clip's length, so the
  scaled figure is a lower bound there.
Before any ratio is printed, MotionKit's mapped bones must point (world Y
axes, depsgraph pose matrices) where the source's do, to 0.01 degrees, on a few
frames. COPY_ROTATION copies world orientation, roll included, so the two ways
are not expected to agree on orientations; how far the baked result is off
(direction, and twist against the target's own rolls) is printed as a figure.
"""
from __future__ import annotations

import cProfile
import io
import math
import os
import pstats
import statistics
import sys
import time

import bpy
import numpy as np
from mathutils import Vector

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # Blender's --python adds no folder

import harness  # noqa: E402
import resample as resample_bench  # noqa: E402

CORE_BONES = 26  # hips, 6 spine, 2 neck, head, 2 x (clavicle, upper arm, forearm, hand), 2 x 4 leg bones
FINGER_CHAINS, FINGER_BONES = 8, 3  # up to 4 fingers per hand, 3 bones each; the tail takes the rest
TARGET_PREFIX = "DEF-"
# The plain retarget against the constraint way, which plants nothing; bench/plant_feet.py times planting
# on a walk, whose feet really stand (this clip's random rotations have no contacts to hold).
PLANT_FEET = False
# Nor does it stand feet on the floor: fitting the legs to the target's floor turns them from the source's
# directions, which the check below holds to 0.01 degrees.
FLOOR_FIT = "off"
# Every chain turned onto the source's direction, as the constraint way (world to world) does: the two do the
# same job, and the check below holds MotionKit to it (by default a target keeps its own posture).
MATCH_EVERY_CHAIN = {c: "MATCH" for c in ("trunk", "arm.L", "arm.R", "leg.L", "leg.R", "fingers.L", "fingers.R")}


def _unit(*v) -> Vector:
    return Vector(v).normalized()


def _turn_down(direction: Vector, degrees: float) -> Vector:
    """direction turned towards -Z by degrees in its vertical plane."""
    horizontal = Vector((direction.x, direction.y, 0.0))
    if horizontal.length < 1e-9:
        return direction.normalized()
    horizontal.normalize()
    angle = math.atan2(direction.z, Vector((direction.x, direction.y)).length) - math.radians(degrees)
    return (horizontal * math.cos(angle) + Vector((0.0, 0.0, math.sin(angle)))).normalized()


def humanoid(bones: int, target: bool) -> list[tuple[str, str | None, Vector, Vector]]:
    """(name, parent, head, tail) for every bone, parents first. The target differs in proportions and
    rest directions; both have the same topology and bone names (the target's get a prefix later)."""
    if bones < CORE_BONES:
        raise SystemExit(f"retarget.py: --bones must be at least {CORE_BONES}")
    extra = bones - CORE_BONES
    fingers = min(FINGER_CHAINS, extra // FINGER_BONES)
    tail_bones = extra - fingers * FINGER_BONES
    size = 1.15 if target else 1.0
    out = []

    def chain(prefix, parent, start, directions, lengths):
        head = Vector(start)
        for i, (d, length) in enumerate(zip(directions, lengths)):
            tail = head + size * length * d
            name = f"{prefix}{i}" if len(lengths) > 1 else prefix
            out.append((name, parent, head.copy(), tail))
            parent, head = name, tail
        return parent, head

    hips_top = size * 1.1
    out.append(("hips", None, Vector((0.0, 0.0, size * 1.0)), Vector((0.0, 0.0, hips_top))))
    lean = math.radians(12.0 if target else 0.0)
    up = _unit(0.0, -math.sin(lean), math.cos(lean))
    spine_lengths = [0.06, 0.07, 0.08, 0.08, 0.09, 0.10] if target else [0.08] * 6
    chest, top = chain("spine_", "hips", (0.0, 0.0, hips_top), [up] * 6, spine_lengths)
    neck, neck_top = chain("neck_", chest, top, [_unit(0, -0.3, 1) if target else up] * 2,
                           [0.06, 0.06] if target else [0.05, 0.05])
    chain("head", neck, neck_top, [up], [0.22 if target else 0.2])
    for side, sign in (("L", 1.0), ("R", -1.0)):
        shoulder = top + size * Vector((sign * 0.03, 0.0, -0.04))
        clavicle_dir = _unit(sign, -0.3, 0.15) if target else _unit(sign, 0.0, 0.1)
        arm_dir = _turn_down(Vector((sign, 0.0, 0.0)), 45.0 if target else 0.0)
        arm_lengths = [0.16, 0.31, 0.29, 0.1] if target else [0.15, 0.28, 0.26, 0.08]
        hand, hand_tail = chain(f"arm_{side}_", chest, shoulder, [clavicle_dir] + [arm_dir] * 3, arm_lengths)
        for f in range(fingers // 2 + (fingers % 2 if side == "L" else 0)):
            # Finger 1 starts at the hand's tail, as a middle finger does: a hand that points off its
            # continuing finger is aimed at that finger (core/bone_axes.py), not along its Y axis.
            spread = (f - 1) * 0.02
            start = hand_tail + size * Vector((0.0, spread, 0.0))
            dirs = ([_turn_down(arm_dir, 20.0 * (k + 1)) for k in range(FINGER_BONES)] if target
                    else [arm_dir] * FINGER_BONES)
            dirs = [(d + Vector((0.0, spread, 0.0))).normalized() for d in dirs]
            chain(f"finger_{side}{f}_", hand, start, dirs, [0.035, 0.025, 0.02] if target else [0.03] * 3)
        hip = Vector((sign * 0.1 * size, 0.0, size * 1.0))
        leg_dir = _unit(sign * 0.09, 0.0, -1.0) if target else _unit(0.0, 0.0, -1.0)
        foot_dir = _unit(0.0, -1.0, 0.0) if target else _unit(0.0, -0.8, -0.6)
        chain(f"leg_{side}_", "hips", hip, [leg_dir, leg_dir, foot_dir, _unit(0.0, -1.0, 0.0)],
              [0.47, 0.44, 0.12, 0.06] if target else [0.45, 0.45, 0.1, 0.05])
    if tail_bones:
        dirs = [_unit(0.0, 1.0, (0.3 if target else -0.3) * k) for k in range(tail_bones)]
        chain("tail_", "hips", (0.0, size * 0.05, size * 1.0), dirs, [0.06 if target else 0.05] * tail_bones)
    assert len(out) == bones, (len(out), bones)
    return out


def build_rig(name: str, bones: int, target: bool):
    armature = bpy.data.armatures.new(name)
    obj = bpy.data.objects.new(name, armature)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode='EDIT')
    prefix = TARGET_PREFIX if target else ""
    # Random rolls, the same every run.
    rng = np.random.default_rng(1)
    edit = armature.edit_bones
    for bone_name, parent, head, tail in humanoid(bones, target):
        bone = edit.new(prefix + bone_name)
        bone.head, bone.tail = head, tail
        bone.roll = float(rng.uniform(-math.pi, math.pi)) if target else 0.0
        if parent is not None:
            bone.parent = edit[prefix + parent]
    bpy.ops.object.mode_set(mode='OBJECT')
    return obj


def source_action(animdata, obj, frames_count: int):
    """One linear key per frame: bench/resample.py's clip (smooth random rotations on every bone, a random
    walk on the root), assigned to obj."""
    action = resample_bench.source_action(animdata, obj, frames_count)
    animdata.assign(obj, action)
    return action


def world_poses(obj, names, frames):
    """{frame: [(world Y axis, world orientation)] per bone}, as the depsgraph poses them."""
    scene = bpy.context.scene
    out = {}
    for frame in frames:
        scene.frame_set(int(frame))
        world = obj.matrix_world.to_3x3()
        row = []
        for name in names:
            m = world @ obj.pose.bones[name].matrix.to_3x3()
            row.append((m.col[1].normalized(), m.to_quaternion()))
        out[frame] = row
    return out


def angle_deg(a: Vector, b: Vector) -> float:
    return math.degrees(math.atan2(a.cross(b).length, a.dot(b)))


def twist_deg(a, b) -> float:
    return math.degrees(2.0 * math.acos(min(1.0, abs(a.dot(b)))))


def clear_action(obj) -> None:
    if obj.animation_data is not None:
        obj.animation_data.action = None


def run_motionkit(mk, source, target, pairs):
    start = time.perf_counter()
    action = mk.retarget(source, target, bone_map=pairs, plant_feet=PLANT_FEET, floor_fit=FLOOR_FIT,
                         chain_modes=MATCH_EVERY_CHAIN)
    return time.perf_counter() - start, action


def constrain_and_bake(obj, add_constraints, bake_frames: int, all_channels: bool = False,
                       use_current_action: bool = False, bones=None):
    """Blender's recipe, timed: add_constraints() on obj in pose mode, then bpy.ops.nla.bake with visual
    keying over frames 1..bake_frames, of every bone or (bones) of those alone, selected (a control rig's
    own constraints elsewhere must stay). Returns (seconds to set up, seconds to bake, the bake's options)."""
    for other in bpy.context.view_layer.objects:
        other.select_set(other == obj)
    bpy.context.view_layer.objects.active = obj
    start = time.perf_counter()
    bpy.ops.object.mode_set(mode='POSE')
    if bones is not None:
        # Bone selection lives on the pose bones in 5.x, on the bones before.
        selectable = obj.pose.bones if hasattr(obj.pose.bones[0], "select") else obj.data.bones
        for bone in selectable:
            bone.select = bone.name in bones
    add_constraints()
    setup = time.perf_counter() - start
    options = dict(frame_start=1, frame_end=bake_frames, only_selected=bones is not None, visual_keying=True,
                   clear_constraints=True, use_current_action=use_current_action, bake_types={'POSE'})
    # 4.1 and later bake only the channels asked for: location and rotation, what MotionKit writes, unless
    # all_channels keeps Blender's default (scale, B-Bone and custom properties too). 3.4 bakes location,
    # rotation and scale of every bone.
    if "channel_types" in bpy.ops.nla.bake.get_rna_type().properties and not all_channels:
        options["channel_types"] = {'LOCATION', 'ROTATION'}
    start = time.perf_counter()
    result = bpy.ops.nla.bake(**options)
    bake = time.perf_counter() - start
    bpy.ops.object.mode_set(mode='OBJECT')
    if result != {'FINISHED'}:
        raise SystemExit(f"nla.bake returned {result}")
    if any(len(pb.constraints) for pb in obj.pose.bones if bones is None or pb.name in bones):
        raise SystemExit("nla.bake left constraints behind")
    return setup, bake, options


def run_constraint_way(source, target, pairs, bake_frames: int, all_channels: bool):
    """COPY_ROTATION (world -> world) on every mapped bone, COPY_LOCATION on the root, nla.bake."""
    clear_action(target)
    for pose_bone in target.pose.bones:
        pose_bone.rotation_quaternion = (1.0, 0.0, 0.0, 0.0)
        pose_bone.location = (0.0, 0.0, 0.0)
    root = target.data.bones[0].name

    def add_constraints():
        for src, tgt in pairs:
            pose_bone = target.pose.bones[tgt]
            kinds = ('COPY_ROTATION', 'COPY_LOCATION') if tgt == root else ('COPY_ROTATION',)
            for kind in kinds:
                con = pose_bone.constraints.new(kind)
                con.target, con.subtarget = source, src
                con.target_space = con.owner_space = 'WORLD'

    return constrain_and_bake(target, add_constraints, bake_frames, all_channels)


def main() -> None:
    def arguments(parser):
        parser.add_argument("--frames", type=int, default=10_000)
        parser.add_argument("--bones", type=int, default=60)
        parser.add_argument("--bake-frames", type=int, default=500,
                            help="frames the constraint way is baked on, then scaled to --frames")
        parser.add_argument("--bake-all-channels", action="store_true",
                            help="on Blender 4.1 and later, bake Blender's default channel types, not only "
                                 "location and rotation")
        parser.add_argument("--profile", action="store_true",
                            help="also print a cProfile of one motionkit.retarget")

    args, mk = harness.start("retarget.py", __doc__, arguments, repeat=3)
    if not 2 <= args.bake_frames <= args.frames:
        raise SystemExit("retarget.py: --bake-frames must be between 2 and --frames")
    import importlib
    retargeting = importlib.import_module(mk.__name__ + ".features.retargeting")
    animdata = mk.animdata

    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, args.frames
    source = build_rig("Source", args.bones, target=False)
    target = build_rig("Target", args.bones, target=True)
    source_action(animdata, source, args.frames)
    pairs = [(b.name, TARGET_PREFIX + b.name) for b in source.data.bones]

    # MotionKit, end to end; every run from the same state.
    times, action = [], None
    for _ in range(args.repeat):
        if action is not None:
            bpy.data.actions.remove(action)
        seconds, action = run_motionkit(mk, source, target, pairs)
        times.append(seconds)
    motionkit_s = harness.median(times)
    keys = sum(len(fc.keyframe_points) for fc in animdata.fcurves(action, target))
    curves = len(animdata.fcurves(action, target))
    source_curves = list(animdata.fcurves(animdata.assigned_action(source), source))
    written = harness.curve_keys(animdata, action, target)
    # Each MotionKit run above starts by removing the previous run's action: the floor reads as it does.
    found = harness.floors(animdata, target, source_curves, *written[:3], args.repeat, read_after_removal=True)

    # Where the time goes: plan() and apply() separately, same state each time.
    plan_times, apply_times = [], []
    for _ in range(args.repeat):
        bpy.data.actions.remove(action)
        start = time.perf_counter()
        result = retargeting.plan(source, target, pairs, plant_feet=PLANT_FEET, floor_fit=FLOOR_FIT,
                                  chain_modes=MATCH_EVERY_CHAIN)
        plan_times.append(time.perf_counter() - start)
        start = time.perf_counter()
        action = retargeting.apply(result)
        apply_times.append(time.perf_counter() - start)
    if args.profile:
        bpy.data.actions.remove(action)
        profile = cProfile.Profile()
        profile.enable()
        action = mk.retarget(source, target, bone_map=pairs, plant_feet=PLANT_FEET, floor_fit=FLOOR_FIT,
                         chain_modes=MATCH_EVERY_CHAIN)
        profile.disable()
        text = io.StringIO()
        pstats.Stats(profile, stream=text).sort_stats("tottime").print_stats(25)
        bpy.data.actions.remove(action)
        profile = cProfile.Profile()
        profile.enable()
        result = retargeting.plan(source, target, pairs, plant_feet=PLANT_FEET, floor_fit=FLOOR_FIT,
                                  chain_modes=MATCH_EVERY_CHAIN)
        profile.disable()
        action = retargeting.apply(result)
        text.write("plan() alone, by cumulative time:\n")
        pstats.Stats(profile, stream=text).sort_stats("cumulative").print_stats(45)
        print(text.getvalue())

    # MotionKit points every mapped bone where the source's points.
    src_names, tgt_names = [a for a, _ in pairs], [b for _, b in pairs]
    bake_check = sorted({1, 2, args.bake_frames // 2, args.bake_frames})
    mk_check = sorted(set(bake_check) | {args.frames // 2, args.frames})
    source_poses = world_poses(source, src_names, mk_check)
    mk_poses = world_poses(target, tgt_names, mk_check)
    mk_worst, worst_bone, worst_frame = max((angle_deg(s[0], t[0]), name, f) for f in mk_check
                                            for name, s, t in zip(tgt_names, source_poses[f], mk_poses[f]))
    if mk_worst > 0.01:
        raise SystemExit(f"retarget.py: MotionKit's {worst_bone} points {mk_worst:.4f} deg away from the "
                         f"source's on frame {worst_frame}")

    # The constraint way on the first --bake-frames frames, scaled to all.
    bpy.data.actions.remove(action)
    setup_s, bake_s, bake_options = run_constraint_way(source, target, pairs, args.bake_frames, args.bake_all_channels)
    baked = animdata.assigned_action(target)
    baked_curves = len(animdata.fcurves(baked, target))
    constraint_full = setup_s + bake_s * args.frames / args.bake_frames
    baked_poses = world_poses(target, tgt_names, bake_check)
    direction_off = [angle_deg(s[0], t[0]) for f in bake_check for s, t in zip(source_poses[f], baked_poses[f])]
    twist_off = [twist_deg(m[1], t[1]) for f in bake_check for m, t in zip(mk_poses[f], baked_poses[f])]

    ratio = constraint_full / motionkit_s
    print(f"\nBlender {bpy.app.version_string}: {args.bones} bones onto {args.bones} bones, {args.frames:,} frames "
          f"({curves} F-curves, {keys:,} keys written by MotionKit)")
    print("| method | seconds | MotionKit faster by | target |")
    print("|---|---:|---:|---|")
    print(f"| motionkit.retarget end to end, keys written (median of {args.repeat}) | {motionkit_s:.3f} | "
          f"{ratio:.0f}x | <= 1 s |")
    timed = (f"all {args.frames:,} frames timed (setup {setup_s:.3f} s)" if args.bake_frames == args.frames else
             f"{args.bake_frames} frames timed ({bake_s:.2f} s, setup {setup_s:.3f} s), scaled linearly to "
             f"{args.frames:,}")
    print(f"| COPY_ROTATION/COPY_LOCATION + nla.bake(visual_keying), {timed} | {constraint_full:.1f} | | "
          f"MotionKit >= 30x faster |")
    print(f"\nmotionkit.retarget runs: {', '.join(f'{t:.3f}' for t in times)} s; then plan() "
          f"{', '.join(f'{t:.3f}' for t in plan_times)} s (median {statistics.median(plan_times):.3f}) and "
          f"apply() {', '.join(f'{t:.3f}' for t in apply_times)} s (median {statistics.median(apply_times):.3f})")
    print(f"nla.bake options: {bake_options}; baked action: {baked_curves} F-curves")
    print(f"Directions on frames {mk_check}: MotionKit off the source's by at most {mk_worst:.2e} deg")
    print(f"Constraint way on frames {bake_check}: directions off the source's by at most "
          f"{max(direction_off):.2e} deg (median {statistics.median(direction_off):.2e}); orientations "
          f"off MotionKit's (twist about the bone: the source's roll instead of the target's) by up to "
          f"{max(twist_off):.1f} deg (median {statistics.median(twist_off):.1f})")
    met = motionkit_s <= 1.0 and ratio >= 30
    print(f"Targets (<= 1 s, >= 30x): {'met' if met else 'MISSED'}")
    harness.print_floors("retarget", motionkit_s, found, sum(len(fc.keyframe_points) for fc in source_curves),
                         written[2].size)


if __name__ == "__main__":
    main()
