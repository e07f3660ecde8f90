"""Work on threads beside Blender's: the one way the add-on runs work beside it (a worker Blender of a
batch is a process: core.batch_tasks). Blender's data may be touched from its own thread only, but native
jobs release the GIL: a native solve runs on a worker while Blender's thread reads or writes meanwhile.
No bpy here."""
from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor


class WorkerThread:
    """work() on a thread of its own; result() waits for it and gives its value, or raises what it raised
    (on the thread that asks)."""

    def __init__(self, work, name: str = "motionkit-worker"):
        self._work = work
        self._started = threading.Event()
        self._outcome = (False, RuntimeError(f"{name} never ran"))
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)

    def _run(self) -> None:
        self._started.set()
        try:
            self._outcome = (True, self._work())
        except BaseException as error:  # handed to the thread that asks for the result
            self._outcome = (False, error)

    def start(self) -> "WorkerThread":
        self._thread.start()
        # Blender's calls keep the GIL: let the worker reach its work (a native call releases it) first.
        self._started.wait()
        return self

    def join(self) -> None:
        self._thread.join()

    def is_alive(self) -> bool:
        return self._thread.is_alive()

    def result(self):
        self._thread.join()
        ok, outcome = self._outcome
        if not ok:
            raise outcome
        return outcome


def pool(threads: int | None = None) -> ThreadPoolExecutor:
    """A pool of worker threads (one per core by default) for many independent jobs whose work is native or
    numpy, submitted from Blender's thread, which keeps every bpy call; use it as a context manager."""
    return ThreadPoolExecutor(max_workers=threads or os.cpu_count() or 1, thread_name_prefix="motionkit")


def beside(work, alongside) -> tuple:
    """(work(), alongside()): work on a worker thread while alongside runs on this one (the one that may
    touch Blender). Should alongside raise, the worker is still waited for before its error goes on."""
    worker = WorkerThread(work).start()
    try:
        other = alongside()
    except BaseException:
        worker.join()
        raise
    return worker.result(), other
