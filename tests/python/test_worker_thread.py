"""core/worker_thread: work beside the calling thread, its result and its errors handed back."""
import threading

import pytest

from core import worker_thread


def test_beside_runs_both_and_the_work_on_another_thread():
    main = threading.get_ident()
    work, here = worker_thread.beside(lambda: threading.get_ident(), lambda: threading.get_ident())
    assert here == main and work != main


def test_an_error_on_the_worker_reaches_the_caller():
    def fail():
        raise ValueError("bone 'foot.L' at frame 3")
    with pytest.raises(ValueError, match="foot.L"):
        worker_thread.beside(fail, lambda: None)
    worker = worker_thread.WorkerThread(fail).start()
    worker.join()
    assert not worker.is_alive()
    with pytest.raises(ValueError, match="frame 3"):
        worker.result()


def test_an_error_alongside_waits_for_the_worker_first():
    finished = threading.Event()

    def slow():
        finished.wait(0.2)
        finished.set()
    with pytest.raises(KeyError):
        worker_thread.beside(slow, lambda: {}["missing"])
    assert finished.is_set()


def test_pool_maps_in_order():
    with worker_thread.pool(2) as pool:
        assert list(pool.map(lambda x: x * x, range(6))) == [0, 1, 4, 9, 16, 25]
