"""Logging to a file and the global exception hook of the desktop application.

Defines :func:`log_file` (platformdirs user log folder), :func:`setup_logging` and
:func:`install_exception_hook`: any exception that escapes to the event loop (or a Python
thread) is written in full to the log and shown as a dialog with a short message and the log's
path, instead of a traceback on a terminal the operator may not have.
"""

from __future__ import annotations

import logging
import os
import sys
import threading
import traceback
from pathlib import Path
from types import TracebackType

from PySide6.QtCore import QObject, Qt, Signal, Slot
from PySide6.QtWidgets import QApplication, QMessageBox

from dreamprint_gui.core.errors import DreamPrintError

__all__ = ["log_file", "setup_logging", "install_exception_hook", "short_message"]

log = logging.getLogger("dreamprint_gui")


def log_file() -> Path:
    """``<user log dir>/dreamprint-gui.log`` (``DREAMPRINT_LOG_DIR`` overrides the folder)."""
    import platformdirs

    folder = os.environ.get("DREAMPRINT_LOG_DIR") or platformdirs.user_log_dir(
        "dreamprint", appauthor=False)
    return Path(folder) / "dreamprint-gui.log"


def setup_logging(level: int = logging.INFO) -> Path:
    """Log the application's messages to :func:`log_file` (and warnings to stderr)."""
    path = log_file()
    path.parent.mkdir(parents=True, exist_ok=True)
    root = logging.getLogger()
    if not any(getattr(h, "_dreamprint", False) for h in root.handlers):
        handler = logging.FileHandler(path, encoding="utf-8")
        handler._dreamprint = True  # type: ignore[attr-defined]
        handler.setFormatter(logging.Formatter(
            "%(asctime)s %(levelname)s %(threadName)s %(name)s: %(message)s"))
        root.addHandler(handler)
        root.setLevel(min(root.level or level, level))
    return path


def short_message(exc: BaseException) -> str:
    """One line for the operator: the DreamPrint problem as is, else type and message."""
    if isinstance(exc, DreamPrintError):
        return str(exc)
    text = str(exc).strip().splitlines()
    first = text[0] if text else ""
    if len(first) > 300:
        first = first[:297] + "..."
    return f"{type(exc).__name__}: {first}" if first else type(exc).__name__


class _Reporter(QObject):
    """Shows the dialog in the GUI thread whatever thread the exception came from."""

    report = Signal(str, str)

    def __init__(self) -> None:
        super().__init__()
        self.report.connect(self._show, Qt.ConnectionType.QueuedConnection)
        self._showing = False
        self.shown: list[str] = []  # messages shown so far (tests read this)
        self.interactive = True

    @Slot(str, str)
    def _show(self, message: str, path: str) -> None:
        self.shown.append(message)
        if self._showing or not self.interactive:
            return  # one dialog at a time; the rest are in the log
        self._showing = True
        try:
            box = QMessageBox(QApplication.activeWindow())
            box.setIcon(QMessageBox.Icon.Critical)
            box.setWindowTitle("DreamPrint: unexpected error")
            box.setText(message)
            box.setInformativeText(f"The details are in the log file:\n{path}")
            box.exec()
        finally:
            self._showing = False


_reporter: _Reporter | None = None


def install_exception_hook(interactive: bool = True) -> _Reporter:
    """Route uncaught exceptions (GUI thread and Python threads) to the log and a dialog."""
    global _reporter
    if _reporter is None:
        _reporter = _Reporter()
    _reporter.interactive = interactive
    path = setup_logging()

    def hook(exc_type: type[BaseException], exc: BaseException,
             tb: TracebackType | None) -> None:
        if issubclass(exc_type, KeyboardInterrupt):
            QApplication.quit()
            return
        log.error("uncaught exception:\n%s",
                  "".join(traceback.format_exception(exc_type, exc, tb)))
        assert _reporter is not None
        _reporter.report.emit(short_message(exc), str(path))

    def thread_hook(args: threading.ExceptHookArgs) -> None:
        if args.exc_value is not None:
            hook(args.exc_type, args.exc_value, args.exc_traceback)

    sys.excepthook = hook
    threading.excepthook = thread_hook
    return _reporter
