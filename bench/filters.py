"""Benchmark: Butterworth filtering of a 10,000-frame, 65-bone action, MotionKit against Blender's own
Butterworth smoothing and against a per-curve Python loop.

Run inside Blender:

    tools/with_blender.sh 4.3 -b --factory-startup --python bench/filters.py -- \\
        --zip dist/motionkit-0.1.0-linux-x64-py313.zip

The action: 65 bones, each with a location and a quaternion rotation, one key per frame at 30 fps (455
F-curves x 10,000 keys), slow motion with noise. Three ways filter the location curves alone (the same
work for all three), then every curve, at the same cut-off (--cutoff Hz) and order (--order), each on a
fresh copy of the action, medians of --repeat runs:
- MotionKit: motionkit.filter(kind="butterworth") end to end, rotations as quaternions on the sphere;
- Blender's graph.butterworth_smooth (Blender 4.2 and later; absent in 3.4, so the column is left out) in
  a Graph Editor with every key selected: filter_order is --order / 2, as each of Blender's filter orders
  is one second-order section; blend 1 and blend in/out 0, so that every key takes the filtered value;
- the way a user script does it: for each F-curve, foreach_get the keys' co, scipy.signal.sosfiltfilt, and
  foreach_set the co back (rotations filtered component by component, as such a script does).
Before any ratio is printed, the location curves must agree: MotionKit and the Python loop everywhere to
one float32 ulp (both are scipy's sosfiltfilt, in double, written to float32 keys), MotionKit and Blender a
second away from the ends (Blender holds the end values and starts each pass from rest, sosfiltfilt
reflects the ends: see docs/cleanup.md).
"""
from __future__ import annotations

import os
import sys
import time

import bpy
import numpy as np
from scipy import signal

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # Blender's --python adds no folder

import harness  # noqa: E402

sys.path.insert(0, os.path.join(harness.ROOT, "tests", "common"))
from blender_eval import GraphEditor  # noqa: E402
import resample  # noqa: E402

FPS = 30
BLENDER_INSIDE = 1e-5  # metres, a second from the ends (docs/cleanup.md, Blender's own Butterworth smoothing)


def source_action(animdata, obj, frames_count: int):
    """Every bone keyed on every frame: a location and a quaternion, slow waves plus noise."""
    rng = np.random.default_rng(5)
    frames = np.arange(1, frames_count + 1, dtype=np.float64)
    t = frames / FPS
    channels, rows = [], []
    for i, name in enumerate(b.name for b in obj.pose.bones):
        path = f'pose.bones["{name}"]'
        waves = np.stack([np.sin(2 * np.pi * hz * t + phase) for hz, phase in
                          zip((0.3 + 0.01 * i, 0.5, 0.7), rng.uniform(0, 6, 3))])
        channels += [(f"{path}.location", k, name) for k in range(3)]
        rows += list(0.1 * waves + rng.normal(0.0, 0.003, waves.shape))
        vectors = 0.6 * waves.T + rng.normal(0.0, 0.02, waves.T.shape)
        angle = np.linalg.norm(vectors, axis=1, keepdims=True)
        q = np.hstack([np.cos(angle / 2), np.sin(angle / 2) * vectors / np.maximum(angle, 1e-12)])
        channels += [(f"{path}.rotation_quaternion", k, name) for k in range(4)]
        rows += list(q.T)
    action = animdata.new_action("Source")
    animdata.write_keys(obj, action, channels, frames, np.array(rows))
    return action


def has_blender_butterworth() -> bool:
    return "butterworth_smooth" in dir(bpy.ops.graph)


def run_ways(mk, animdata, obj, source, args, channels: str) -> dict:
    """{way: (median wall seconds, median CPU seconds of the process's threads, the action of its last run)}
    for each way this Blender has, filtering every
    curve (channels 'ALL') or the location curves alone ('LOCATION')."""
    sos = signal.butter(args.order, args.cutoff, fs=FPS, output='sos')

    def chosen(action):
        return [fc for fc in animdata.fcurves(action, obj) if channels == "ALL" or fc.data_path.endswith(".location")]

    def motionkit_way(action):
        mk.filter(obj, "butterworth", cutoff=args.cutoff, order=args.order, channels=channels)

    def select_keys(action):
        picked = chosen(action)
        for fcurve in animdata.fcurves(action, obj):
            fcurve.select = fcurve in picked
            fcurve.keyframe_points.foreach_set("select_control_point",
                                               [fcurve.select] * len(fcurve.keyframe_points))

    def blender_way(action):
        with GraphEditor() as editor, bpy.context.temp_override(**editor):
            bpy.ops.graph.butterworth_smooth(cutoff_frequency=args.cutoff, filter_order=args.order // 2,
                                             samples_per_frame=1, blend=1.0, blend_in_out=0)

    def python_way(action):
        for fcurve in chosen(action):
            co = np.empty(2 * len(fcurve.keyframe_points), dtype=np.float32)
            fcurve.keyframe_points.foreach_get("co", co)
            co[1::2] = signal.sosfiltfilt(sos, co[1::2])
            fcurve.keyframe_points.foreach_set("co", co)
            fcurve.update()

    ways = {"motionkit": (motionkit_way, None), "python": (python_way, None)}
    if has_blender_butterworth():
        ways["blender"] = (blender_way, select_keys)
    results = {}
    for name, (run, prepare) in ways.items():
        seconds, cpu, action = [], [], None
        for _ in range(args.repeat):
            if action is not None:  # each run starts from the same scene, not one full of earlier copies
                bpy.data.actions.remove(action)
            action = source.copy()
            animdata.assign(obj, action)
            if prepare is not None:
                prepare(action)
            started, started_cpu = time.perf_counter(), time.process_time()
            run(action)
            seconds.append(time.perf_counter() - started)
            cpu.append(time.process_time() - started_cpu)
        results[name] = (harness.median(seconds), harness.median(cpu), action)
    return results


def curve_values(animdata, obj, action, prop: str) -> np.ndarray:
    """(curves, keys): the values of every bone's prop curves, in the action's curve order."""
    return np.array([animdata.read_keys(fc)[1] for fc in animdata.fcurves(action, obj)
                     if fc.data_path.endswith(prop)], dtype=np.float64)


def check_agreement(animdata, obj, results) -> dict:
    """The largest differences on location curves (metres), after checking them against round-off."""
    ours = curve_values(animdata, obj, results["motionkit"][-1], ".location")
    found = {"python": float(np.abs(ours - curve_values(animdata, obj, results["python"][-1], ".location")).max())}
    # Two double results of the same filter, each rounded to float32: one ulp of the largest value apart at most.
    if found["python"] > np.spacing(np.float32(np.abs(ours).max())):
        raise SystemExit(f"filters: MotionKit and the Python loop differ by {found['python']:.2e} m")
    if "blender" in results:
        difference = np.abs(ours - curve_values(animdata, obj, results["blender"][-1], ".location"))
        found["blender inside"] = float(difference[:, FPS:-FPS].max())
        found["blender ends"] = float(difference.max())
        if found["blender inside"] > BLENDER_INSIDE:
            raise SystemExit(f"filters: MotionKit and Blender differ by {found['blender inside']:.2e} m a "
                             f"second from the ends")
    return found


def sphere_against_components(animdata, obj, results) -> float:
    """The largest angle (degrees) between MotionKit's rotations, filtered on the sphere, and the Python
    loop's, filtered component by component and normalised."""
    ours = curve_values(animdata, obj, results["motionkit"][-1], ".rotation_quaternion").T.reshape(-1, 4)
    theirs = curve_values(animdata, obj, results["python"][-1], ".rotation_quaternion").T.reshape(-1, 4)
    theirs /= np.linalg.norm(theirs, axis=1, keepdims=True)
    ours /= np.linalg.norm(ours, axis=1, keepdims=True)
    return float(np.degrees(2 * np.arccos(np.clip(np.abs(np.einsum("ij,ij->i", ours, theirs)), 0, 1))).max())


def print_rows(label: str, results: dict, args) -> None:
    ours, ours_cpu, _ = results["motionkit"]
    rows = [("motionkit.filter" + (", rotations on the sphere" if label.startswith("all") else ""), "motionkit")]
    if "blender" in results:
        rows.append((f"graph.butterworth_smooth, filter_order {args.order // 2}", "blender"))
    rows.append(("per-curve foreach_get + sosfiltfilt + foreach_set + update", "python"))
    for way, name in rows:
        seconds, cpu, _ = results[name]
        print(f"| {label} | {way} | {seconds:.3f} | {seconds / ours:.2f}x | {cpu:.3f} | {cpu / ours_cpu:.2f}x |")


def main() -> None:
    def arguments(parser):
        parser.add_argument("--frames", type=int, default=10_000)
        parser.add_argument("--bones", type=int, default=65)
        parser.add_argument("--cutoff", type=float, default=7.0, help="Hz at 30 fps")
        parser.add_argument("--order", type=int, default=4, help="even: Blender's filter order is half")

    args, mk = harness.start("filters.py", __doc__, arguments, repeat=3)
    animdata = mk.animdata
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = FPS, 1.0
    scene.frame_start, scene.frame_end = 1, args.frames
    obj = resample.build_rig(args.bones)
    source = source_action(animdata, obj, args.frames)
    curves = len(animdata.fcurves(source, obj))

    print(f"\nBlender {bpy.app.version_string}: {args.bones} bones, {curves} F-curves x {args.frames:,} keys at "
          f"{FPS} fps, Butterworth {args.cutoff:g} Hz order {args.order} (medians of {args.repeat})")
    print("| curves | way | wall s | / MotionKit's | CPU s | / MotionKit's |")
    print("|---|---|---:|---:|---:|---:|")
    locations = run_ways(mk, animdata, obj, source, args, "LOCATION")
    found = check_agreement(animdata, obj, locations)
    print_rows(f"{3 * args.bones} location", locations, args)
    for *_, action in locations.values():
        bpy.data.actions.remove(action)
    results = run_ways(mk, animdata, obj, source, args, "ALL")
    found_all = check_agreement(animdata, obj, results)
    print_rows(f"all {curves}", results, args)
    for label, agreement in (("the location curves alone", found), ("every curve", found_all)):
        print(f"\nFiltering {label}: largest difference from MotionKit on location curves: Python loop "
              f"{agreement['python']:.2e} m" + (f"; Blender {agreement['blender inside']:.2e} m a second from the "
                                                 f"ends, {agreement['blender ends']:.2e} m at the ends"
                                                 if "blender inside" in agreement else ""))
    print(f"Rotations: MotionKit's on the sphere against the Python loop's componentwise filter, normalised: "
          f"{sphere_against_components(animdata, obj, results):.3f} degrees at most")
    ours = results["motionkit"][0]
    source_curves = list(animdata.fcurves(source, obj))
    channels, frames, values, _ = harness.curve_keys(animdata, results["motionkit"][-1], obj)
    harness.print_floors("filter", ours, harness.floors(animdata, obj, source_curves, channels, frames, values),
                         sum(len(f.keyframe_points) for f in source_curves), values.size)


if __name__ == "__main__":
    main()
