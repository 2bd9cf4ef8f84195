"""Python's cyclic garbage collector, run on the GUI thread only.

Defines :class:`GuiThreadCollector`: while it runs, automatic collection is off and a timer on
the GUI thread collects whenever the generation counts pass the interpreter's thresholds (the
same rule CPython applies after an allocation, applied every ``interval_ms`` instead).

Why: CPython collects reference cycles in whichever thread happens to allocate when a
threshold is passed, and in a GUI that is most often a worker (a conversion, the gamut's
charts, the pre-flight). A cycle that holds a Qt or VTK object then destroys that object in the
worker, which Qt does not allow: the test suite crashed so (a segmentation fault in a gamut
chart task, "Garbage-collecting", on a fresh machine, 2026-11-29). The remedy is the one
Kovid Goyal gave on the PyQt list in 2011 and Qt applications still use; the ``qtpygc``
package wraps it with QtPy and heapdict for a priority scheme DreamPrint does not need, so it
is written here (30 lines). Objects freed by reference counting are not concerned; cyclic
garbage waits for the next tick (at most one collection a tick, so a cycle that reached the
oldest generation, collected every ~120th, may wait ~30 s, as under CPython's own rule).
"""

from __future__ import annotations

import gc

from PySide6.QtCore import QObject, QTimer

__all__ = ["GuiThreadCollector"]


class GuiThreadCollector(QObject):
    """Disables automatic collection and collects from a timer on the creating (GUI) thread.

    :meth:`stop` ends it (the object's destruction with its parent only stops the timer)."""

    def __init__(self, interval_ms: int = 250, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self._was_enabled = gc.isenabled()
        self.thresholds = gc.get_threshold()
        self.collections = 0
        gc.disable()
        self._timer = QTimer(self)
        self._timer.timeout.connect(self.check)
        self._timer.start(interval_ms)

    def check(self) -> int:
        """Collect the generations whose counts passed their thresholds; returns the oldest
        generation collected, -1 for none."""
        counts = gc.get_count()
        gen = -1
        for g in range(3):
            if counts[g] <= self.thresholds[g]:
                break
            gen = g
        if gen >= 0:
            gc.collect(gen)
            self.collections += 1
        return gen

    def stop(self, enable: bool = True) -> None:
        """Stop the timer and collect what is left, here. Automatic collection is then back as
        it was before, unless ``enable`` is false: an application about to exit keeps it off,
        as threads that outlive the wait for them (an abandoned engine call) may still run."""
        self._timer.stop()
        gc.collect()
        if enable and self._was_enabled:
            gc.enable()
