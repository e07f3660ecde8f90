"""MotionKit from a pipeline's command line, in a Blender that has the target's .blend open:

    blender -b character.blend --python-expr "import motionkit.cli as c; c.main()" -- \\
        retarget --target Armature --out DIR [--export fbx] [--root-motion-onto root]
        [--workers 2 | --scheduler tcp://host:8786] clips/

Progress goes to the console (file i of n, time left), the report (report.json, report.csv) into --report
(default: --out, else the current folder) and as a table onto the console; --save keeps the new actions in
the .blend. The exit status is the number of files that failed (at most 100): 0 when every clip was done;
101 when the command cannot run as given (an unknown option or armature, a missing input, options that
contradict each other), with the reason on stderr and nothing done.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import bpy

from ..core import batch_report
from ..core.retarget_options import ROOT_MOTION_ONTO
from . import batch, batch_workers

MAX_STATUS = 100
USAGE_STATUS = 101  # the command cannot run as given: above MAX_STATUS, never a count of failed files


class _Parser(argparse.ArgumentParser):
    """argparse, its errors exiting with USAGE_STATUS (argparse's own 2 would read as two failed files)."""

    def error(self, message):
        self.print_usage(sys.stderr)
        self.exit(USAGE_STATUS, f"{self.prog}: error: {message}\n")


def _workers(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of Blenders, 1 or more")
    return value


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="motionkit", description="MotionKit from the command line")
    commands = parser.add_subparsers(dest="command", required=True)
    run = commands.add_parser("retarget", help="retarget motion files and folders onto an armature of the .blend")
    run.add_argument("inputs", nargs="+", help="motion files (.bvh .fbx .glb .gltf) and folders")
    run.add_argument("--target", required=True, help="the armature object to retarget onto")
    run.add_argument("--glob", default="*", help="in folders, only files whose names match (default *)")
    run.add_argument("--no-recursive", action="store_true", help="only the folders' own files, not subfolders'")
    run.add_argument("--out", help="the folder exports (and by default the report) go into")
    run.add_argument("--export", choices=batch.EXPORTS, help="write each clip as a file of this kind into --out")
    run.add_argument("--overwrite", action="store_true", help="replace exported files that exist")
    run.add_argument("--report", help="the folder report.json and report.csv go into")
    run.add_argument("--save", nargs="?", const="", metavar="BLEND",
                     help="save the .blend with the new actions (to BLEND, else over the open file)")
    run.add_argument("--files-only", action="store_true",
                     help="with --export: write the clips out without keeping their actions in the .blend")
    run.add_argument("--plant-feet", choices=("auto", "on", "off"), default="auto")
    run.add_argument("--root-motion-onto", choices=[c[0] for c in ROOT_MOTION_ONTO], default="auto",
                     help="where the target's travel goes: auto (the hips; a root bone above them moves as the "
                          "source's does, if it has one), hips, root (the root bone above the hips, on the floor: "
                          "Unreal's root motion) or object (the armature object keyed)")
    workers = run.add_mutually_exclusive_group()
    workers.add_argument("--workers", type=_workers, default=1, help="Blender processes to run side by side")
    workers.add_argument("--scheduler", help="a Dask distributed scheduler's address to run the files on")
    return parser


def retarget_options(args) -> dict:
    """The retarget's options the command line sets (what a worker is given too)."""
    return {"plant_feet": {"auto": None, "on": True, "off": False}[args.plant_feet],
            "root_motion_onto": args.root_motion_onto}


class ConsoleProgress:
    """'[3/200] clips/walk.bvh, 41 s left' lines, the time left from the pace so far."""

    def __init__(self):
        self.started = time.perf_counter()

    def __call__(self, done: int, total: int, path: str) -> None:
        if not path:
            print(f"[{done}/{total}] done in {time.perf_counter() - self.started:.1f} s", flush=True)
            return
        left = ""
        if done:
            left = f", {(time.perf_counter() - self.started) / done * (total - done):.0f} s left"
        print(f"[{done + 1}/{total}] {path}{left}", flush=True)


def _target(parser, name: str):
    obj = bpy.data.objects.get(name)
    if obj is None or obj.type != 'ARMATURE':
        armatures = [o.name for o in bpy.data.objects if o.type == 'ARMATURE']
        parser.error(f"--target: no armature '{name}' in {bpy.data.filepath or 'the open file'} "
                     f"(armatures: {', '.join(armatures) or 'none'})")
    return obj


def _check(parser, args, target) -> None:
    """What the command cannot run with, said before any file is read (USAGE_STATUS)."""
    if args.export and not args.out:
        parser.error("--export needs --out, the folder the clips are written into")
    if args.files_only and not args.export:
        parser.error("--files-only needs --export: without it nothing of the clips would be kept")
    for item in args.inputs:
        if not os.path.exists(item):
            parser.error(f"{item}: no such file or folder")
    try:
        batch.check_arguments(target, args.export, args.out, not args.files_only, retarget_options(args))
    except ValueError as error:
        parser.error(str(error))


def run(argv: list[str]) -> batch.BatchResult:
    parser = _parser()
    args = parser.parse_args(argv)
    target = _target(parser, args.target)
    _check(parser, args, target)
    report_dir = args.report or args.out or os.getcwd()
    common = dict(pattern=args.glob, recursive=not args.no_recursive, out_dir=args.out, export=args.export,
                  overwrite=args.overwrite, keep=not args.files_only, progress=ConsoleProgress(),
                  **retarget_options(args))
    if args.scheduler or args.workers > 1:
        result = batch_workers.run_parallel(args.inputs, target, workers=args.workers, scheduler=args.scheduler,
                                            **common)
    else:
        result = batch.retarget_library(args.inputs, target, **common)
    batch_report.write(result.rows, report_dir)
    print(batch_report.table(result.rows), flush=True)
    if args.save is not None:
        bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(args.save) if args.save else bpy.data.filepath)
    return result


def main(argv: list[str] | None = None) -> None:
    """Runs the command after Blender's '--' and exits Blender with the number of failed files."""
    if argv is None:
        argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if argv[:1] == ["worker"]:
        sys.exit(batch_workers.worker_main(argv[1:]))
    result = run(argv)
    sys.exit(min(result.failed, MAX_STATUS))
