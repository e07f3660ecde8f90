"""Benchmark: a library of motion clips onto one character, and the memory a long batch takes.

    tools/with_blender.sh 3.4 -b --factory-startup --python bench/batch.py -- \\
        --zip dist/motionkit-0.1.0-linux-x64-py311.zip [--clips 200] [--native-clips 20] [--memory 50,500]

The library: --clips copies of the real captures (walk60, run_forward, walk_and_turn_left and the Bandai dash
as BVH; Mixamo's punch and kick as FBX), onto Y Bot (ybot.fbx, Blender's FBX importer), plant_feet off on
every way (the constraint way plants nothing). Clips per second, each way in the same run:
- MotionKit in this Blender (motionkit.batch.retarget_library, a report row per clip);
- MotionKit with 2 worker Blenders (motionkit.batch_workers.run_parallel, workers=2);
- MotionKit on a Dask LocalCluster of 2 worker processes (run_parallel, scheduler=);
- Blender's way, timed on --native-clips of them: the file imported (Blender's FBX importer; MotionKit's
  BVH reader on 3.4, whose BVH importer cannot run on its Python), COPY_ROTATION on every mapped bone and
  COPY_LOCATION on the hips (world to world), nla.bake with visual keying over the clip, the source removed.
Memory: this Blender's resident set after --memory files (BVH exported, actions not kept, so that what is
measured is what a batch leaves behind, not the actions it was asked to keep).
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import time

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # Blender's --python adds no folder

import harness  # noqa: E402
import retarget as retarget_bench  # noqa: E402
import retarget_mixamo  # noqa: E402

BVH = os.path.join(harness.SHARED, "data", "bvh")
FBX = os.path.join(harness.SHARED, "data", "fbx")
CAPTURES = [os.path.join(BVH, "walk60.bvh"), os.path.join(BVH, "run_forward.bvh"),
            os.path.join(BVH, "more", "walk_and_turn_left.bvh"), os.path.join(BVH, "more", "bandai_dash_normal_001.bvh"),
            os.path.join(FBX, "ybot@punch.fbx"), os.path.join(FBX, "ybot@kick.fbx")]


def library(folder: str, count: int) -> list[str]:
    """count copies of the captures, in turn, as files of their own."""
    files = []
    os.makedirs(folder, exist_ok=True)
    for i in range(count):
        capture = CAPTURES[i % len(CAPTURES)]
        path = os.path.join(folder, f"clip{i:04d}{os.path.splitext(capture)[1]}")
        shutil.copy(capture, path)
        files.append(path)
    return files


def resident_mb() -> float:
    with open("/proc/self/status", encoding="ascii") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def drop(actions) -> None:
    for action in actions:
        bpy.data.actions.remove(action)


def timed_batch(run, files) -> float:
    start = time.perf_counter()
    result = run()
    seconds = time.perf_counter() - start
    if result.failed:
        raise SystemExit(f"the batch failed on {result.failed} files: {[r['reason'] for r in result.rows if r['status'] == 'failed']}")
    drop(result.actions)
    return len(files) / seconds


def native_way(mk, files, target) -> float:
    """Clips per second of import + constraints + nla.bake + removal, over files."""
    start = time.perf_counter()
    for path in files:
        before = mk.batch.imports.snapshot()
        if path.endswith(".fbx"):
            source = retarget_mixamo.import_fbx(path)
        elif hasattr(bpy.ops.import_anim, "bvh") and bpy.app.version >= (4, 0, 0):
            bpy.ops.import_anim.bvh(filepath=path)
            source = bpy.context.view_layer.objects.active
        else:
            source, _ = mk.bvh.load(path)
        pairs = mk.retargeting.auto_map(source, target)
        first, last = (int(round(v)) for v in source.animation_data.action.frame_range)
        bpy.context.scene.frame_start, bpy.context.scene.frame_end = first, last
        retarget_bench.run_constraint_way(source, target, pairs, last, False)
        added = mk.batch.imports.added_since(before)
        added["actions"] = [a for a in added["actions"] if a != target.animation_data.action]
        mk.batch.imports.remove(added)
    return len(files) / (time.perf_counter() - start)


def dask_cluster():
    script = ("from distributed import LocalCluster\nimport sys\n"
              "cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)\n"
              "print(cluster.scheduler_address, flush=True)\nsys.stdin.read()\n")
    process = subprocess.Popen([sys.executable, "-c", script], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                               text=True)
    return process, process.stdout.readline().strip()


def main() -> None:
    def arguments(parser):
        parser.add_argument("--clips", type=int, default=200)
        parser.add_argument("--native-clips", type=int, default=20)
        parser.add_argument("--memory", default="50,500", help="file counts at which to read the memory")

    args, mk = harness.start("batch", __doc__, arguments, repeat=1)
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    target = retarget_mixamo.import_fbx(os.path.join(FBX, "ybot.fbx"))
    folder = tempfile.mkdtemp(prefix="motionkit-bench-batch-")
    try:
        files = library(os.path.join(folder, "clips"), args.clips)
        options = dict(plant_feet=False)
        rates = {"MotionKit, this Blender": timed_batch(
            lambda: mk.batch.retarget_library(files, target, **options), files)}
        rates["MotionKit, 2 worker Blenders"] = timed_batch(
            lambda: mk.batch_workers.run_parallel(files, target, workers=2, **options), files)
        process, address = dask_cluster()
        try:
            rates["MotionKit, Dask LocalCluster of 2"] = timed_batch(
                lambda: mk.batch_workers.run_parallel(files, target, scheduler=address, **options), files)
        finally:
            process.stdin.close()
            process.wait(timeout=60)
        rates["constraints + nla.bake"] = native_way(mk, files[:args.native_clips], target)
        native = rates["constraints + nla.bake"]
        print(f"Blender {bpy.app.version_string}, {args.clips} clips ({len(CAPTURES)} captures in turn) onto Y Bot")
        for way, rate in rates.items():
            print(f"  {way:<36} {rate:7.2f} clips/s   {rate / native:6.1f} x constraints + nla.bake")
        counts = sorted(int(c) for c in args.memory.split(","))
        many = library(os.path.join(folder, "many"), counts[-1])
        out = os.path.join(folder, "out")
        done, readings = 0, []
        for count in counts:
            mk.batch.retarget_library(many[done:count], target, out_dir=out, export="bvh", keep=False,
                                      overwrite=True, **options)
            done = count
            readings.append((count, resident_mb()))
            print(f"  memory after {count} files: {readings[-1][1]:.0f} MB resident")
        print(f"  growth from {counts[0]} to {counts[-1]} files: {readings[-1][1] - readings[0][1]:.1f} MB")
    finally:
        shutil.rmtree(folder, ignore_errors=True)


main()
