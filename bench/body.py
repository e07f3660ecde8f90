"""Benchmark: how retargeted arms sit in the target's own body, on Mixamo characters with their real skinned
meshes (../shared/data/bodies), every measured frame evaluated by Blender's Armature modifier.

    tools/with_blender.sh 3.4 -b --factory-startup --python bench/body.py -- \\
        --zip dist/motionkit-0.1.0-linux-x64-py311.zip [--every N] [--cases NAME ...]

The protocol (tests/common/body_metrics.py, nothing of MotionKit's body code): a forearm or hand vertex is
inside when the generalised winding number of the closed body (the trunk, head and thighs) about it is
over a half; a frame goes in when any is more than 1 cm deep; contact frames are those where the source's
hand is within 2 cm of its own body on its own clip, and on them the target's hand's distance to its own
body is taken (0 inside), in % of the target's height. Rows, for each retarget (a clip of one character
onto another that has the same clip of Mixamo's own):
- source: the source's clip on its own mesh;
- Mixamo: Mixamo's own retarget, the target's clip on the target's mesh;
- plain copy: the target's hierarchy playing the source's local rotations (a BVH Blender's importer reads);
- MotionKit, bones only: motionkit.retarget(source, target, body="off"), the defaults but the body stage;
- MotionKit: motionkit.retarget(source, target) with the defaults (the body stage on: the target has a mesh).
Retargets: san/Aj <-> san/Kaya (the four SAN clips, both ways; meshes AJ, Kaya) and Mousey <-> Sporty
Granny (bodies/clips: Macarena Dance, Hip Hop Dancing; both ways).
"""
from __future__ import annotations

import os
import sys
import tempfile
import time

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # Blender's --python adds no folder

import harness  # noqa: E402

sys.path.insert(0, os.path.join(harness.ROOT, "tests", "common"))

import body_metrics as bm  # noqa: E402
import made_characters as made  # noqa: E402
import mixamo_pairs as mp  # noqa: E402
import san_protocol as sp  # noqa: E402

METHODS = ("source", "Mixamo", "plain copy", "MotionKit, bones only", "MotionKit")
SAN = {"Aj": "AJ", "Kaya": "Kaya"}  # the pairs' characters -> their meshes
DANCERS = {"Mousey": "Mousey", "Sporty_Granny": "Sporty_Granny"}
DANCES = ("Macarena Dance", "Hip Hop Dancing")


def cases() -> list[tuple[str, str, str, str, str]]:
    """(label, source file, source mesh, target file, target mesh) of every retarget."""
    out = []
    for clip in mp.SAN_CLIPS:
        for a, b in (("Aj", "Kaya"), ("Kaya", "Aj")):
            out.append((f"{clip} {a}->{b}", mp.san_path(harness.SHARED, a, clip), SAN[a],
                        mp.san_path(harness.SHARED, b, clip), SAN[b]))
    clips = os.path.join(harness.SHARED, "data", "bodies", "clips")
    for clip in DANCES:
        for a, b in (("Mousey", "Sporty_Granny"), ("Sporty_Granny", "Mousey")):
            out.append((f"{clip} {a}->{b}", os.path.join(clips, a, f"{clip}.bvh"), DANCERS[a],
                        os.path.join(clips, b, f"{clip}.bvh"), DANCERS[b]))
    return out


def measure(motionkit, case, every: int, scratch: str) -> dict:
    label, source_path, source_mesh, target_path, target_mesh = case
    source_bvh, target_bvh = sp.read_bvh(source_path), sp.read_bvh(target_path)
    frames = np.arange(1, min(len(source_bvh.values), len(target_bvh.values)) + 1, every)
    height = mp.BVH_SCALE * sp.height([n.split(":")[-1] for n in target_bvh.names], target_bvh.parents,
                                      target_bvh.offsets)
    measured, seconds = {}, {}
    before = set(bpy.data.objects)
    source = mp.import_bvh(source_path)
    measured["source"] = bm.measure(bm.Skinned.of(source, harness.SHARED, source_mesh), frames)
    own = mp.import_bvh(target_path)
    measured["Mixamo"] = bm.measure(bm.Skinned.of(own, harness.SHARED, target_mesh), frames)
    copy_path = os.path.join(scratch, "copy.bvh")
    made.write_bvh(bm.plain_copy(source_bvh, target_bvh), copy_path)
    copy = mp.import_bvh(copy_path)
    measured["plain copy"] = bm.measure(bm.Skinned.of(copy, harness.SHARED, target_mesh), frames)
    for method, body in (("MotionKit, bones only", "off"), ("MotionKit", "auto")):
        target = mp.rest_copy(own, method)
        skinned = bm.Skinned.of(target, harness.SHARED, target_mesh)
        start = time.perf_counter()
        motionkit.retarget(source, target, body=body)
        seconds[method] = time.perf_counter() - start
        measured[method] = bm.measure(skinned, frames)
    contacts = bm.contact_frames(measured["source"])
    source_height = mp.BVH_SCALE * sp.height([n.split(":")[-1] for n in source_bvh.names], source_bvh.parents,
                                             source_bvh.offsets)
    rows = {m: bm.summary(f, source_height if m == "source" else height, contacts) for m, f in measured.items()}
    made_now = [o for o in bpy.data.objects if o not in before]
    bpy.data.batch_remove(made_now + [o.data for o in made_now if o.data is not None])
    return {"label": label, "frames": len(frames), "rows": rows, "seconds": seconds}


def print_table(results) -> None:
    print("\n| retarget | method | arm vertices inside % | frames > 1 cm inside % | contact mean / worst % of height |")
    print("|---|---|---:|---:|---:|")
    for r in results:
        for m in METHODS:
            row = r["rows"][m]
            contact = (f"{row['contact_mean']:.2f} / {row['contact_worst']:.2f} ({row['contact_count']})"
                       if row["contact_mean"] is not None else "none")
            print(f"| {r['label']} ({r['frames']} frames) | {m} | {row['inside']:.2f} | {row['deep_frames']:.1f} "
                  f"| {contact} |")
    print(f"\nmeans over {len(results)} retargets:\n")
    print("| method | arm vertices inside % | frames > 1 cm inside % | contact mean / worst % of height |")
    print("|---|---:|---:|---:|")
    for m in METHODS:
        rows = [r["rows"][m] for r in results]
        touching = [row for row in rows if row["contact_mean"] is not None]
        mean = np.mean([row["contact_mean"] for row in touching]) if touching else float("nan")
        worst = np.max([row["contact_worst"] for row in touching]) if touching else float("nan")
        print(f"| {m} | {np.mean([row['inside'] for row in rows]):.2f} | "
              f"{np.mean([row['deep_frames'] for row in rows]):.1f} | {mean:.2f} / {worst:.2f} |")
    sys.stdout.flush()


def timing(motionkit, repeat: int) -> None:
    """The stage's cost: Aj's Catwalk Walk (its first 1,000 frames) onto Mousey with its mesh subdivided once
    (24,400 vertices), the retarget with the stage (its field built, then cached as a batch finds it) against
    the same without it, in the same run: the medians of repeat runs of each, taken in turn."""
    import body_scene
    clips = os.path.join(harness.SHARED, "data", "bodies", "clips")
    source = mp.import_bvh(mp.san_path(harness.SHARED, "Aj", "Catwalk Walk"))
    own = mp.import_bvh(os.path.join(clips, "Mousey", "Macarena Dance.bvh"))
    target = mp.rest_copy(own, "timed")
    mesh = body_scene.skin(target, harness.SHARED, "Mousey", subdivisions=1)
    print(f"\nThe stage's cost: 1,000 frames onto Mousey, {len(mesh.data.vertices):,} vertices, "
          f"medians of {repeat}\n")

    def timed(body: str) -> float:
        start = time.perf_counter()
        motionkit.retarget(source, target, frame_range=(1, 1000), body=body)
        return time.perf_counter() - start

    built = timed("auto")  # the first with the stage builds the field
    runs = {"off": [], "auto": []}
    for _ in range(repeat):
        for body in runs:
            runs[body].append(timed(body))
    without, cached = float(np.median(runs["off"])), float(np.median(runs["auto"]))
    print("| retarget | seconds | the stage / the rest |")
    print("|---|---:|---:|")
    print(f"| without the stage | {without:.3f} | |")
    print(f"| with it, the field built (once) | {built:.3f} | {(built - without) / without:.2f} |")
    print(f"| with it, the field cached | {cached:.3f} | {(cached - without) / without:.2f} |")
    print(f"\nThe stage a frame, the field cached: {(cached - without):.3f} ms")
    sys.stdout.flush()


def main() -> None:
    def arguments(parser):
        parser.add_argument("--every", type=int, default=4, help="measure every N-th frame")
        parser.add_argument("--cases", nargs="*", help="only the retargets whose label contains one of these")
        parser.add_argument("--timing", action="store_true", help="only the stage's cost (timing())")

    args, motionkit = harness.start("body.py", __doc__, arguments, repeat=5)
    if args.timing:
        timing(motionkit, args.repeat)
        return
    chosen = [c for c in cases() if not args.cases or any(k in c[0] for k in args.cases)]
    results = []
    with tempfile.TemporaryDirectory() as scratch:
        for case in chosen:
            result = measure(motionkit, case, args.every, scratch)
            print(f"{result['label']}: {result['frames']} frames, MotionKit {result['seconds']['MotionKit']:.2f} s "
                  f"(bones only {result['seconds']['MotionKit, bones only']:.2f} s)", flush=True)
            results.append(result)
    print_table(results)


if __name__ == "__main__":
    main()
