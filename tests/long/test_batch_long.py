"""The batch's slow cases, each a Blender (or several) of its own: the whole library through the command
line, two local worker Blenders and a Dask cluster against one Blender. tests/blender/test_batch.py runs
the command line on one good and one bad clip."""
import subprocess
import sys

import pytest

from test_batch import (BAD, GOOD, _same_actions, _some_files, check_command_line_run,  # noqa: F401
                        library, run_command_line, target, ybot_blend)
from test_production_files import fbx_dir  # noqa: F401  (library's fixture)


def test_the_command_line_retargets_the_whole_library(library, target, tmp_path):  # noqa: F811
    done, out = run_command_line(target, [library], tmp_path)
    check_command_line_run(done, out, tmp_path / "done.blend", GOOD, BAD, 8)  # fight.fbx holds two takes


def test_two_worker_blenders_give_the_same_actions_and_rows_as_one(mk, library, target):  # noqa: F811
    files = _some_files(library)
    alone = mk.batch.retarget_library(files, target)
    shared = mk.batch_workers.run_parallel(files, target, workers=2)
    assert [(r["file"], r["take"]) for r in shared.rows] == [(r["file"], r["take"]) for r in alone.rows]
    _same_actions(mk, alone, shared, target)
    for a, b in zip(alone.rows, shared.rows):
        assert a["sliding_worst_mm"] == b["sliding_worst_mm"] and a["direction_worst_deg"] == b["direction_worst_deg"]


@pytest.fixture()
def dask_scheduler():
    """A Dask LocalCluster of two worker processes, in a Python of its own, for as long as the test runs."""
    script = ("from distributed import LocalCluster\n"
              "import sys, time\n"
              "cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)\n"
              "print(cluster.scheduler_address, flush=True)\n"
              "sys.stdin.read()\n")
    process = subprocess.Popen([sys.executable, "-c", script], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                               text=True)
    try:
        address = process.stdout.readline().strip()
        assert address.startswith("tcp://"), f"the LocalCluster did not start: {address!r}"
        yield address
    finally:
        process.stdin.close()
        process.wait(timeout=60)


def test_a_dask_cluster_gives_the_same_actions_and_rows_as_one_blender(mk, library, target,  # noqa: F811
                                                                        dask_scheduler):
    files = _some_files(library)
    alone = mk.batch.retarget_library(files, target)
    on_dask = mk.batch_workers.run_parallel(files, target, scheduler=dask_scheduler)
    assert [(r["file"], r["take"], r["status"]) for r in on_dask.rows] == \
        [(r["file"], r["take"], r["status"]) for r in alone.rows]
    _same_actions(mk, alone, on_dask, target)
