"""One unit of a batch's work, as a process: a Blender opening the target's .blend and retargeting a list of
files (or files claimed from a shared queue), leaving its actions in a .blend and its report rows in a JSON
file. The same function runs the local workers and, pickled by value, a Dask task on any machine that has
Blender, the add-on and the files at the same paths. No bpy here: it only starts Blender.
"""
from __future__ import annotations

import json
import os
import subprocess

QUEUE_FILES = "files.json"
CLAIMS = "claims"


def blender_command(blender: str, blend: str, package: str, worker_args: list[str]) -> list[str]:
    """The command line of a worker Blender: it enables the add-on by its module name (so that it runs
    whatever the user's preferences hold) and hands the rest to the command line's worker mode."""
    expr = (f"import addon_utils, importlib; addon_utils.enable({package!r}, default_set=False); "
            f"importlib.import_module({package!r} + '.features.cli').main()")
    return [blender, "-b", blend, "--python-expr", expr, "--", "worker", *worker_args]


def run_worker(command: list[str], result_prefix: str, log_path: str | None = None) -> dict:
    """Runs a worker Blender to its end here: collect()'s result."""
    with open(log_path or os.devnull, "w", encoding="utf-8") as log:
        done = subprocess.run(command, stdout=log, stderr=subprocess.STDOUT, check=False)
    tail = ""
    if log_path and os.path.exists(log_path):
        with open(log_path, encoding="utf-8", errors="replace") as f:
            tail = f.read()[-2000:]
    return collect(result_prefix, done.returncode, tail)


def collect(result_prefix: str, returncode: int, output_tail: str = "") -> dict:
    """What a worker Blender left: {"rows": [...], "blend": its actions' .blend, "returncode", "error"}. A
    worker that died leaves no rows, and 'error' holds the end of what it printed."""
    result = {"rows": [], "blend": result_prefix + ".blend", "returncode": returncode, "error": ""}
    try:
        with open(result_prefix + ".json", encoding="utf-8") as f:
            result["rows"] = json.load(f)["rows"]
    except (OSError, ValueError):
        result["error"] = f"the worker Blender ended ({returncode}) without its report: {output_tail[-2000:]}"
    return result


def write_queue(folder: str, files: list[str]) -> None:
    os.makedirs(os.path.join(folder, CLAIMS), exist_ok=True)
    with open(os.path.join(folder, QUEUE_FILES), "w", encoding="utf-8") as f:
        json.dump(files, f)


def claim_next(folder: str, files: list[str], start: int = 0) -> int | None:
    """The index of the next file no worker has taken, now taken by this one (an exclusive create is the
    lock, so that any number of processes share the queue); None when all are taken."""
    for index in range(start, len(files)):
        try:
            os.close(os.open(os.path.join(folder, CLAIMS, str(index)), os.O_CREAT | os.O_EXCL | os.O_WRONLY))
            return index
        except FileExistsError:
            continue
    return None


def claimed(folder: str) -> int:
    return len(os.listdir(os.path.join(folder, CLAIMS)))
