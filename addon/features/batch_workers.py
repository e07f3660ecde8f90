"""A batch spread over Blender processes: N local workers taking files from a shared queue, or tasks on a
Dask distributed cluster; each opens a copy of the target's .blend once, and their actions and report rows
are merged back into this Blender (core/batch_tasks runs each worker).
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time

import bpy

from ..core import batch_inputs, batch_report, batch_tasks, worker_thread
from . import batch

_PACKAGE = __package__.rsplit(".", 1)[0]  # the add-on's module: motionkit, or bl_ext.<repo>.motionkit


def _worker_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="motionkit worker")
    parser.add_argument("--target", required=True)
    parser.add_argument("--result", required=True, help="the prefix of the .blend and .json it leaves")
    parser.add_argument("--options", default="{}", help="batch.retarget_file's keywords, as JSON")
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--queue", help="a queue folder (core/batch_tasks) to take files from")
    source.add_argument("--files", nargs="+", help="the files to do")
    parser.add_argument("--first", type=int, default=0, help="the first of --files' index in the whole batch")
    return parser


def _next_files(args):
    """The worker's files, with their indices in the whole batch: from its list, or claimed from the queue."""
    if args.files:
        yield from enumerate(args.files, start=args.first)
        return
    with open(os.path.join(args.queue, batch_tasks.QUEUE_FILES), encoding="utf-8") as f:
        files = json.load(f)
    index = batch_tasks.claim_next(args.queue, files)
    while index is not None:
        yield index, files[index]
        index = batch_tasks.claim_next(args.queue, files, index + 1)


def worker_main(argv: list[str]) -> int:
    """The worker mode of the command line: every file it is given or can claim, its actions written into
    <result>.blend and its rows (each with the file's index in the batch) into <result>.json."""
    args = _worker_parser().parse_args(argv)
    target = bpy.data.objects[args.target]
    options = json.loads(args.options)
    rows, actions = [], []
    stems = options.pop("stems", {})
    for index, path in _next_files(args):
        print(f"worker: {path}", flush=True)
        one = batch.retarget_file(path, target, stem=stems.get(path), **options)
        rows += [dict(row, index=index) for row in one.rows]
        actions += one.actions
    bpy.data.libraries.write(args.result + ".blend", set(actions), fake_user=True)
    with open(args.result + ".json", "w", encoding="utf-8") as f:
        json.dump({"rows": rows}, f)
    return 0


def _merge(result: batch.BatchResult, worker: dict) -> None:
    """A worker's actions appended into this file, each held by its row until the rows are in order, the
    rows renamed after them where a name was taken."""
    made = {row["action"] for row in worker["rows"] if row["status"] == "ok"}
    if made and os.path.exists(worker["blend"]):
        with bpy.data.libraries.load(worker["blend"]) as (source, loaded):
            names = [name for name in source.actions if name in made]
            loaded.actions = list(names)  # filled with the loaded actions in place
        by_name = dict(zip(names, loaded.actions))
        for row in worker["rows"]:
            action = by_name.get(row["action"]) if row["status"] == "ok" else None
            if action is not None:
                action.use_fake_user = True
                row["action"], row["_made"] = action.name, action
    result.rows += worker["rows"]


def _worker_commands(files, target, blend, folder, workers, options, tasks=None) -> list[tuple[list, str]]:
    """(command, result prefix) per worker: workers sharing a queue locally; or tasks, each a slice of the
    files (on Dask, a few per worker: the scheduler balances them, each pays one Blender's start)."""
    common = ["--target", target.name, "--options", json.dumps(options)]
    if tasks is None:
        batch_tasks.write_queue(folder, files)
        return [(batch_tasks.blender_command(bpy.app.binary_path, blend, _PACKAGE,
                                             common + ["--result", os.path.join(folder, f"worker{w}"),
                                                       "--queue", folder]), os.path.join(folder, f"worker{w}"))
                for w in range(workers)]
    chunk = max(1, -(-len(files) // max(tasks, 1)))
    out = []
    for start in range(0, len(files), chunk):
        prefix = os.path.join(folder, f"task{start}")
        out.append((batch_tasks.blender_command(bpy.app.binary_path, blend, _PACKAGE,
                                                common + ["--result", prefix, "--first", str(start),
                                                          "--files", *files[start:start + chunk]]),
                    prefix))
    return out


def _run_local(commands, folder, total, progress) -> list[dict]:
    # Each thread waits on its worker Blender's process.
    threads = [worker_thread.WorkerThread(lambda c=c, p=p: batch_tasks.run_worker(c, p, p + ".log"),
                                          name=f"motionkit-batch-{i}").start()
               for i, (c, p) in enumerate(commands)]
    shown = -1
    while any(t.is_alive() for t in threads):
        done = min(batch_tasks.claimed(folder), total)
        if progress is not None and done != shown:
            progress(max(done - len(threads), 0), total, f"{done} of {total} files taken by {len(threads)} workers")
            shown = done
        time.sleep(0.2)
    return [t.result() for t in threads]


TASKS_PER_DASK_WORKER = 3


def _run_dask(make_commands, scheduler, total, progress) -> list[dict]:
    """make_commands(tasks) -> the tasks' commands, sized once the cluster says how many workers it has."""
    import subprocess
    from distributed import Client, as_completed
    results = []
    with Client(scheduler) as client:
        workers = max(len(client.scheduler_info()["workers"]), 1)
        commands = make_commands(TASKS_PER_DASK_WORKER * workers)
        futures = {client.submit(subprocess.run, command, capture_output=True, text=True, check=False,
                                 pure=False): prefix for command, prefix in commands}
        for future in as_completed(futures):
            done = future.result()
            results.append(batch_tasks.collect(futures[future], done.returncode, done.stdout + done.stderr))
            if progress is not None:
                files_done = len({row["index"] for r in results for row in r["rows"]})
                progress(files_done, total, f"Dask: {len(results)} of {len(futures)} tasks done")
    return results


def run_parallel(inputs, target, *, workers: int = 2, scheduler: str | None = None, pattern: str = "*",
                 recursive: bool = True, out_dir=None, export=None, overwrite=False, keep: bool = True,
                 progress=None, **options) -> batch.BatchResult:
    """batch.retarget_library over worker Blenders (workers of them here, or a Dask scheduler's); the same
    actions and rows, in the files' order."""
    batch.check_arguments(target, export, out_dir, keep, options)
    if scheduler is None and not (isinstance(workers, int) and workers >= 1):
        raise ValueError(f"workers must be a whole number of Blenders, 1 or more, not {workers!r}")
    files = batch_inputs.collect(inputs, pattern, recursive)
    if out_dir:
        os.makedirs(out_dir, exist_ok=True)
    folder = tempfile.mkdtemp(prefix="motionkit-batch-", dir=os.environ.get("MOTIONKIT_BATCH_TMP"))
    try:
        blend = os.path.join(folder, "target.blend")
        bpy.ops.wm.save_as_mainfile(filepath=blend, copy=True)
        worker_options = dict(options, out_dir=out_dir, export=export, overwrite=overwrite, keep=keep,
                              stems=batch_inputs.stems(files))
        if scheduler:
            results = _run_dask(lambda tasks: _worker_commands(files, target, blend, folder, workers, worker_options,
                                                               tasks), scheduler, len(files), progress)
        else:
            results = _run_local(_worker_commands(files, target, blend, folder, workers, worker_options), folder,
                                 len(files), progress)
        result = batch.BatchResult()
        for worker in results:
            if worker["error"]:
                print(f"motionkit: {worker['error']}", file=sys.stderr)
            _merge(result, worker)
        done = {row["index"] for row in result.rows}
        result.rows += [dict(batch_report.new_row(path, "", worker_options["stems"][path], status="failed",
                                                  reason=f"{path}: its worker Blender ended without a report"),
                             index=i) for i, path in enumerate(files) if i not in done]
        result.rows.sort(key=lambda row: row["index"])
        for row in result.rows:
            row.pop("index")
            if "_made" in row:
                result.actions.append(row.pop("_made"))
        if progress is not None:
            progress(len(files), len(files), "")
        return result
    finally:
        shutil.rmtree(folder, ignore_errors=True)
