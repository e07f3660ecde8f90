"""What the end-to-end benchmarks share: their arguments, installing the add-on, timing with medians,
and Blender's own floors for the keys a job reads and writes.

Every bench runs inside Blender (`tools/with_blender.sh 3.4|4.3|5.2 -b --factory-startup --python
bench/<name>.py -- --zip dist/motionkit-...zip [--repeat N] ...`). Besides its own comparison with the
Blender-native way of doing the same job, each prints, for the same keys in the same run:
- RNA's bulk floor: `foreach_get("co")` of the keys the job reads, plus `keyframe_points.add` +
  `foreach_set("co")` + `update()` of the keys it writes, the least any add-on that goes through RNA pays;
- the unavoidable floor: `add` + `update()` alone, which no add-on can skip, however it fills the keys;
and MotionKit's total as a multiple of each, so that docs/benchmarks.md shows how close each job is to
what Blender allows.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time

import bpy
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
for _path in (os.path.join(ROOT, "tools"), os.path.join(ROOT, "blend_samples")):
    if _path not in sys.path:
        sys.path.insert(0, _path)

import install_addon  # noqa: E402

SHARED = os.path.join(os.path.dirname(ROOT), "shared")


def start(prog: str, description: str, add_arguments=None, repeat: int = 5):
    """Parse the bench's arguments (those after Blender's "--"; --zip and --repeat for all, more from
    add_arguments(parser)), install the add-on from the zip and return (args, the motionkit module)."""
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    parser = argparse.ArgumentParser(prog=prog, description=description)
    parser.add_argument("--zip", required=True, help="the add-on zip built for this Blender")
    parser.add_argument("--repeat", type=int, default=repeat, help="timed runs of each way (medians)")
    if add_arguments is not None:
        add_arguments(parser)
    args = parser.parse_args(argv)
    install_addon.install(args.zip)
    import motionkit
    return args, motionkit


WALK_AND_TURN = os.path.join(SHARED, "data", "bvh", "more", "walk_and_turn_left.bvh")


def long_walk(native, frames: int) -> str:
    """A BVH file of GAMES-105's walk_and_turn_left played forwards then backwards until frames frames
    (continuous, so its feet really stand), in a temporary folder: its path."""
    skeleton, motion = native.read_bvh(WALK_AND_TURN)
    values = np.asarray(motion.values)
    there_and_back = np.vstack([values, values[-2:0:-1]])
    repeats = int(np.ceil(frames / len(there_and_back)))
    path = os.path.join(tempfile.mkdtemp(), "walk_and_turn_long.bvh")
    native.write_bvh(path, skeleton, native.Motion(
        np.ascontiguousarray(np.tile(there_and_back, (repeats, 1))[:frames]), motion.frame_time))
    return path


def timed(run, repeat: int, before=None) -> list[float]:
    """Seconds of repeat calls of run(); before() (untimed) ahead of each, for example to remove what the
    previous run made."""
    seconds = []
    for _ in range(repeat):
        if before is not None:
            before()
        started = time.perf_counter()
        run()
        seconds.append(time.perf_counter() - started)
    return seconds


def median(seconds) -> float:
    return float(statistics.median(seconds))


def curve_keys(animdata, action, id_data) -> tuple[list, np.ndarray, list]:
    """An action's curves as (channels, frames, values) to write again, for curves that share one set of
    key times (the longest such set; the rest are left out), and the curves themselves."""
    curves = list(animdata.fcurves(action, id_data))
    reads = [animdata.read_keys(fc) for fc in curves]
    frames = max((r[0] for r in reads), key=len)
    chosen = [i for i, r in enumerate(reads) if r[0].size == frames.size and np.array_equal(r[0], frames)]
    channels = [(curves[i].data_path, curves[i].array_index,
                 curves[i].group.name if curves[i].group is not None else "") for i in chosen]
    return channels, frames, np.array([reads[i][1] for i in chosen]), curves


def floors(animdata, id_data, read_curves, channels, frames, values, repeat: int = 3,
           read_after_removal: bool = False) -> dict[str, float]:
    """Blender's floors, medians of repeat, in seconds, for reading every key of read_curves and writing
    values (channels x frames) on id_data: "read" (foreach_get of co), "write" (add + foreach_set of co +
    update), "unavoidable" (add + update alone). read_after_removal: each read right after an action as
    large as the one written is made and removed (untimed), as a job meets its source's keys when each of
    its timed runs starts by removing the previous run's action: on some machines the first pass over
    memory after Blender frees that much costs several times a later one (bench/retarget.py measured 0.13 s
    against 0.016 s for the same 2.4 million keys), and a floor read warm would not be the same job's."""
    co = np.empty((len(channels), 2 * frames.size), dtype=np.float32)
    co[:, 0::2] = frames
    co[:, 1::2] = values

    def read():
        for fcurve in read_curves:
            buffer = np.empty(2 * len(fcurve.keyframe_points), dtype=np.float32)
            fcurve.keyframe_points.foreach_get("co", buffer)

    def write(fill):
        action = animdata.new_action("MotionKit bench floor")
        try:
            for row, fcurve in enumerate(animdata.new_fcurves(action, id_data, channels)):
                fcurve.keyframe_points.add(frames.size)
                if fill:
                    fcurve.keyframe_points.foreach_set("co", co[row])
                fcurve.update()
        finally:
            bpy.data.actions.remove(action)

    settle = (lambda: write(True)) if read_after_removal else None
    return {"read": median(timed(read, repeat, settle)), "write": median(timed(lambda: write(True), repeat)),
            "unavoidable": median(timed(lambda: write(False), repeat))}


def print_floors(label: str, total: float, found: dict[str, float], keys_read: int, keys_written: int) -> None:
    """A markdown table: MotionKit's total against RNA's bulk floor (read + write) and the unavoidable one."""
    rna = found["read"] + found["write"]
    print(f"\nBlender {bpy.app.version_string}: {label} against Blender's floors for the same keys "
          f"({keys_read:,} read, {keys_written:,} written)")
    print("| | seconds | MotionKit's total as a multiple |")
    print("|---|---:|---:|")
    print(f"| MotionKit, {label} | {total:.3f} | 1.00 |")
    print(f"| RNA's bulk floor: foreach_get of the keys read ({found['read']:.3f} s) + add, foreach_set "
          f"and update of the keys written ({found['write']:.3f} s) | {rna:.3f} | {total / rna:.2f} |")
    print(f"| the unavoidable floor: add + update alone | {found['unavoidable']:.3f} | "
          f"{total / found['unavoidable']:.2f} |")
