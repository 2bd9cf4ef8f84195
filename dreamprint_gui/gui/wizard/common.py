"""What the calibration wizard's pages share: the ink colours of its plots, the style of an
inline error, a matplotlib canvas, the file filter of spectral measurements and
:class:`TaskPage` (a page that runs one engine task at a time in the worker)."""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

from PySide6.QtWidgets import QWizardPage

from dreamprint_gui.gui.workers import Task, run_task

if TYPE_CHECKING:
    from matplotlib.backends.backend_qtagg import FigureCanvasQTAgg
    from matplotlib.figure import Figure

__all__ = ["INK_COLOURS", "ERROR_STYLE", "canvas", "SPECTRA_FILTER", "TaskPage"]

INK_COLOURS = {"C": "#00a0d0", "M": "#d0007a", "Y": "#d8c000", "K": "#202020", "W": "#999999",
               "Cl": "#60b0a0"}
ERROR_STYLE = "color: #d33;"
SPECTRA_FILTER = ("Spectral measurements (*.csv *.txt *.ti3 *.cgats *.jdx *.dx *.jcamp *.spdx "
                  "*.tsv);;All files (*)")


def canvas(figsize: tuple[float, float] = (6, 4)) -> tuple[Figure, FigureCanvasQTAgg]:
    """A (Figure, Qt canvas) pair with constrained layout."""
    from matplotlib.backends.backend_qtagg import FigureCanvasQTAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout="constrained")
    return fig, FigureCanvasQTAgg(fig)


class TaskPage(QWizardPage):
    """A page that runs one engine task at a time in the worker: its signals reach the page's
    ``_progress`` / ``_done`` / ``_failed`` / ``_finished`` only while it is the current task.
    A page has ``_set_running``, an ``elapsed`` and a ``status`` label and a ``_clock``."""

    _task: Task | None

    @property
    def running(self) -> bool:
        return self._task is not None and self._task.outcome is None \
            and not self._task.cancel_event.is_set()

    def _stop_task(self, message: str) -> bool:
        """Cancel the running task (its result is dropped): the page is ready at once, says
        how long the task ran and ``message``. False when no task was running."""
        if not self.running:
            return False
        self._task.cancel()
        self._set_running(False)
        self.elapsed.setText(f"stopped after {time.monotonic() - self._t0:.0f} s")
        self.status.setText(message)
        self.status.setStyleSheet("")
        return True

    def _start_task(self, job, name: str) -> None:
        task = Task(job, name)
        task.progress.connect(self._if_current(task, self._progress))
        task.succeeded.connect(self._if_current(task, self._done))
        task.failed.connect(self._if_current(task, self._failed))
        task.done.connect(self._if_current(task, self._finished))
        self._task = run_task(task)
        self._set_running(True)

    def _run_clock(self, running: bool) -> None:
        """Start the page's elapsed-time clock (``_tick`` each second) or stop it."""
        if running:
            self._t0 = time.monotonic()
            self._tick()
            self._clock.start()
        else:
            self._clock.stop()

    def _if_current(self, task: Task, slot):
        """``slot`` for ``task``'s signals, dropped once another task has replaced it."""
        def call(*args) -> None:
            if task is self._task:
                slot(*args)
        return call
