"""The worker that drives engine generators off the GUI thread."""

from __future__ import annotations

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.gui.workers import Task, generator_job, run_task


def _counting(n: int, closed: list, block_at: int | None = None):
    def make(cancel):
        def gen():
            try:
                for i in range(n):
                    if i == block_at:
                        cancel.wait(10)  # the GUI cancels on receiving item block_at - 1
                    yield i
                return "result"
            finally:
                closed.append(True)  # the engine's clean-up ran
        return gen()
    return make


def test_progress_then_result(qtbot):
    closed: list = []
    task = Task(generator_job(_counting(5, closed)), "count")
    seen: list = []
    task.progress.connect(seen.append)
    with qtbot.waitSignal(task.succeeded, timeout=5000) as blocker:
        run_task(task)
    assert blocker.args == ["result"]
    qtbot.waitUntil(lambda: seen == [0, 1, 2, 3, 4], timeout=2000)
    assert closed == [True]
    assert task.outcome == "succeeded"
    task.thread.wait(2000)


def test_cancel_closes_the_generator(qtbot):
    closed: list = []
    task = Task(generator_job(_counting(1000, closed, block_at=3)), "count")
    seen: list = []
    task.progress.connect(seen.append)
    task.progress.connect(lambda i: task.cancel() if i == 2 else None)
    with qtbot.waitSignal(task.cancelled, timeout=5000):
        run_task(task)
    assert task.outcome == "cancelled"
    assert closed == [True]
    assert max(seen) <= 3


def test_failure_gives_one_line(qtbot):
    def job(report, cancel):
        raise DreamPrintError("cannot read", "/some/file.vdb")

    task = Task(job, "bad")
    with qtbot.waitSignal(task.failed, timeout=5000) as blocker:
        run_task(task)
    message, tb = blocker.args
    assert message == "/some/file.vdb: cannot read"
    assert "Traceback" in tb


def test_unexpected_failure_names_the_type(qtbot):
    def job(report, cancel):
        return 1 / 0

    task = Task(job, "bad")
    with qtbot.waitSignal(task.failed, timeout=5000) as blocker:
        run_task(task)
    assert blocker.args[0].startswith("ZeroDivisionError")


def test_abandonable_returns_at_once_on_cancel():
    import threading

    import pytest

    from dreamprint_gui.gui.workers import Cancelled, abandonable

    release, finished, cancel = threading.Event(), threading.Event(), threading.Event()

    def slow():  # an engine call with no cancel token
        release.wait(30)
        finished.set()
        return "late result"

    cancel.set()
    with pytest.raises(Cancelled):
        abandonable(slow, cancel)
    assert not finished.is_set()  # the caller did not wait for the call to end
    release.set()
    assert finished.wait(30)  # the abandoned call runs to its end in the background

    assert abandonable(lambda: 42, threading.Event()) == 42

    def broken():
        raise DreamPrintError("bad chart", "chart.csv")

    with pytest.raises(DreamPrintError, match="bad chart"):
        abandonable(broken, threading.Event())


def test_cycles_are_collected_on_the_gui_thread(qtbot):
    """A worker that leaves cyclic garbage does not collect it (a cycle holding a Qt object
    must not be destroyed there); the GUI thread's collector does (gui/gc_guard.py)."""
    import threading

    from dreamprint_gui.gui.gc_guard import GuiThreadCollector

    where: list[int] = []

    class Cycle:
        def __init__(self) -> None:
            self.me = self

        def __del__(self) -> None:
            where.append(threading.get_ident())

    def churn() -> None:
        for _ in range(5000):  # several times generation 0's threshold (700)
            Cycle()

    collector = GuiThreadCollector(interval_ms=20)
    try:
        worker = threading.Thread(target=churn)
        worker.start()
        worker.join()
        assert where == []  # automatic collection would have run in the worker
        qtbot.waitUntil(lambda: len(where) == 5000, timeout=5000)
        assert set(where) == {threading.get_ident()}  # by this timer or the fixture's
    finally:
        collector.stop()


def test_collector_takes_the_generations_past_their_thresholds(qtbot):
    """``check`` collects as CPython would after an allocation: nothing below generation 0's
    threshold, the oldest generation whose count passed its threshold above it."""
    import gc

    from dreamprint_gui.gui.gc_guard import GuiThreadCollector

    collector = GuiThreadCollector(interval_ms=3_600_000)  # checked by hand only
    try:
        gc.collect()
        assert collector.check() == -1 and collector.collections == 0
        kept = [[[] for _ in range(2 * collector.thresholds[0])]]  # allocated, not freed
        assert collector.check() == 0 and collector.collections == 1
        gens = []
        for _ in range(collector.thresholds[1] + 1):
            kept.append([[] for _ in range(collector.thresholds[0] + 10)])
            gens.append(collector.check())
        assert gens[:-1] == [0] * collector.thresholds[1] and gens[-1] == 1
    finally:
        collector.stop()
