"""Background work for the GUI: run engine generators and callbacks off the GUI thread.

Defines :class:`Task` (a QObject living in the GUI thread whose signals, emitted from the worker
thread, carry progress, the result, a failure or a cancellation back to the GUI thread),
:func:`run_task` (starts one on its own QThread), :func:`generator_job`, :func:`abandonable`
and :func:`wait_all`.

The engine's long operations are generators yielding progress (``job.run.run_conversion``)
or functions taking a progress callback (``gamut.get_tables``); both are driven by the same
code as on the command line. Cancel is a :class:`threading.Event` the engine checks, plus a
check between yields, so a cancelled generator is closed (its ``finally`` clean-up runs).
An engine call that cannot stop part-way (e.g. ``chart_calibration.fit_chart``) runs through
:func:`abandonable`: Cancel ends the task at once and the call's eventual result is dropped.
"""

from __future__ import annotations

import logging
import threading
import time
import traceback
from collections.abc import Callable, Generator
from typing import Any

from PySide6.QtCore import QObject, QThread, Signal

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.threads import DaemonCall

__all__ = ["Task", "Cancelled", "run_task", "generator_job", "abandonable", "wait_all"]

log = logging.getLogger(__name__)


class Cancelled(Exception):
    """Raised inside a job when the operator pressed Cancel."""


# A job is fn(report, cancel) -> result: `report(item)` sends progress to the GUI thread.
Job = Callable[[Callable[[Any], None], threading.Event], Any]


def generator_job(make: Callable[[threading.Event], Generator[Any, None, Any]]) -> Job:
    """Turn ``make(cancel) -> generator`` (yields progress, returns the result) into a job."""

    def job(report: Callable[[Any], None], cancel: threading.Event) -> Any:
        gen = make(cancel)
        try:
            while True:
                if cancel.is_set():
                    raise Cancelled()
                try:
                    item = next(gen)
                except StopIteration as stop:
                    if cancel.is_set():
                        raise Cancelled() from None
                    return stop.value
                report(item)
        finally:
            gen.close()  # runs the engine's clean-up (e.g. removes a partial job folder)

    return job


def abandonable(fn: Callable[[], Any], cancel: threading.Event, poll_s: float = 0.05,
                name: str = "abandonable") -> Any:
    """``fn()`` on a daemon thread; raises :class:`Cancelled` as soon as ``cancel`` is set.

    For engine calls with no cancel token: the caller (a task) returns at once, ``fn`` runs on
    to its end in the background and its result or error is dropped. Being a daemon thread it
    never holds up quitting the application.
    """
    call = DaemonCall(fn, name)
    while call.is_alive():
        if cancel.is_set():
            log.info("%s abandoned while running; its result will be dropped", name)
            raise Cancelled()
        call.join(poll_s)
    return call.result()


class Task(QObject):
    """One job on a worker thread. Signals are delivered in the GUI thread (queued)."""

    progress = Signal(object)
    succeeded = Signal(object)
    failed = Signal(str, str)  # one-line message for the operator, full traceback for the log
    cancelled = Signal()
    done = Signal()  # after any of the three outcomes

    def __init__(self, job: Job, name: str = "task") -> None:
        super().__init__()
        self.name = name
        self._job = job
        self.cancel_event = threading.Event()
        self.thread: QThread | None = None
        self.outcome: str | None = None  # "succeeded" | "failed" | "cancelled"

    def cancel(self) -> None:
        self.cancel_event.set()

    def run(self) -> None:
        t0 = time.monotonic()
        try:
            result = self._job(self.progress.emit, self.cancel_event)
        except Cancelled:
            self.outcome = "cancelled"
            self.cancelled.emit()
        except DreamPrintError as exc:
            self.outcome = "failed"
            self.failed.emit(str(exc), traceback.format_exc())
        except Exception as exc:  # noqa: BLE001 - reported to the operator, logged in full
            if self.cancel_event.is_set():
                self.outcome = "cancelled"
                self.cancelled.emit()
            else:
                self.outcome = "failed"
                tb = traceback.format_exc()
                log.error("%s failed:\n%s", self.name, tb)
                self.failed.emit(f"{type(exc).__name__}: {exc}", tb)
        else:
            if self.cancel_event.is_set():
                self.outcome = "cancelled"
                self.cancelled.emit()
            else:
                self.outcome = "succeeded"
                self.succeeded.emit(result)
        finally:
            log.info("task %s %s after %.2f s", self.name, self.outcome,
                     time.monotonic() - t0)
            self.done.emit()


class _Runner(QThread):
    """The worker thread of one task. The task object itself stays in the GUI thread, so its
    signals reach the GUI thread queued, whatever they are connected to (lambdas included)."""

    def __init__(self, task: Task) -> None:
        super().__init__()
        self.task = task

    def run(self) -> None:
        self.task.run()


_live: set[Task] = set()  # keeps running tasks (and their threads) alive until they finish


def run_task(task: Task) -> Task:
    """Start ``task`` on a new worker thread; it is released when it has finished."""
    thread = _Runner(task)
    thread.setObjectName(f"dreamprint-{task.name}")
    task.thread = thread
    _live.add(task)

    def finished() -> None:  # in the GUI thread
        # Join before letting go: a QThread object destroyed while its thread is still
        # unwinding aborts the process (garbage collection may run in any thread).
        thread.wait()
        _live.discard(task)

    thread.finished.connect(finished)
    thread.start()
    return task


def wait_all(timeout_ms: int = 30000) -> None:
    """Cancel and join every running task (window closing, application quitting, tests)."""
    for task in list(_live):
        task.cancel()
    for task in list(_live):
        if task.thread is not None:
            task.thread.wait(timeout_ms)
