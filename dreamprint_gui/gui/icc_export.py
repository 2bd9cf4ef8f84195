""""Export ICC profile": the button, its file dialog and the export on a worker (issue 48).

Defines :class:`IccExportBox`: a button, a check box and a status line (in a row or a
column). The button asks for a file name (``*.icc``; "also write the characterisation file"
writes ``NAME.ti3`` beside it), then runs the engine's
:func:`dreamprint_gui.gamut.icc_export.export_icc` (what ``dreamprint icc`` runs) on a worker
thread, the colour tables loaded or built first when the page has none. The status line says
what it is doing, then the file written and the figures of its check (Little CMS's read-back
against DreamPrint's prediction), or the problem in one line. Used under the gamut views (the
active profile, the intent shown there) and on the calibration wizard's last page (the profile
just fitted).
"""

from __future__ import annotations

import logging
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from PySide6.QtCore import Signal
from PySide6.QtWidgets import (
    QCheckBox,
    QFileDialog,
    QHBoxLayout,
    QLabel,
    QPushButton,
    QVBoxLayout,
    QWidget,
)

from dreamprint_gui.gui.workers import Task, run_task

if TYPE_CHECKING:  # not loaded with the window: the export imports the engine when it runs
    from dreamprint_gui.core.profile import InkProfile
    from dreamprint_gui.gamut.tables import ColourTables

__all__ = ["IccExportBox", "IccRequest", "summary"]

log = logging.getLogger(__name__)


@dataclass
class IccRequest:
    """What to export: the ink profile, its tables when already loaded (else built from
    ``intent`` / ``size``), and the printer's name for the description."""

    profile: InkProfile
    tables: ColourTables | None = None
    intent: str | None = None
    size: int | None = None
    printer: str = ""


def summary(report: dict) -> str:
    """The status line after an export: the file and its check's figures."""
    a, r = report["check"]["a2b_dE2000"], report["check"]["round_trip_dE2000"]
    text = (f"Wrote {Path(report['path']).name} (ICC {report['icc_version']}, "
            f"{report['intent']} intent). Read back by Little CMS: the print's colour within "
            f"dE2000 {a['mean']:.2f} (mean), {a['p95']:.2f} (p95) of DreamPrint's; B2A then "
            f"A2B {r['mean']:.2f} (mean).")
    if "cgats" in report:
        text += f" Characterisation: {Path(report['cgats']['path']).name}."
    return text


def _file_name(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "-", text).strip("-") or "printer"


class IccExportBox(QWidget):
    """Button + status line (module doc); ``request()`` gives what to export, or None."""

    exported = Signal(dict)
    failed = Signal(str)

    def __init__(self, request: Callable[[], IccRequest | None], settings=None,
                 parent: QWidget | None = None, horizontal: bool = False) -> None:
        super().__init__(parent)
        self._request = request
        self._settings = settings
        self._task: Task | None = None
        self.button = QPushButton("Export ICC profile...")
        self.button.setToolTip("Write an ICC output profile of the print (device RGB -> the "
                               "colour DreamPrint predicts it prints) for soft proofs in "
                               "Photoshop, GIMP, Krita, darktable..., as `dreamprint icc`")
        self.button.clicked.connect(self._ask)
        self.cgats = QCheckBox("also write the characterisation file (.ti3)")
        self.cgats.setToolTip("RGB -> predicted XYZ, Lab and spectra in ArgyllCMS's layout, "
                              "beside the profile, for tools that build their own profiles")
        self.status = QLabel("")
        self.status.setObjectName("iccStatus")
        self.status.setWordWrap(True)
        lay = QHBoxLayout(self) if horizontal else QVBoxLayout(self)
        lay.setContentsMargins(0, 0, 0, 0)
        lay.addWidget(self.button)
        lay.addWidget(self.cgats)
        lay.addWidget(self.status, 1)

    @property
    def running(self) -> bool:
        return self._task is not None and self._task.outcome is None

    def _folder(self) -> str:
        if self._settings is not None:
            return self._settings.last_folder("icc")
        return str(Path.home())

    def _ask(self) -> None:
        req = self._request()
        if req is None:
            self.status.setText("Nothing to export yet (no profile).")
            return
        name = _file_name(f"{req.profile.name}-{req.intent or 'colorimetric'}") + ".icc"
        path, _ = QFileDialog.getSaveFileName(self, "Export ICC profile",
                                              str(Path(self._folder()) / name),
                                              "ICC profiles (*.icc *.icm)")
        if path:
            self.export_to(path, req)

    def export_to(self, path: str, req: IccRequest | None = None) -> None:
        """Export to ``path`` (the file dialog's choice, or a caller's) on a worker."""
        req = req or self._request()
        if req is None or self.running:
            return
        if not path.lower().endswith((".icc", ".icm")):
            path += ".icc"
        cgats = str(Path(path).with_suffix(".ti3")) if self.cgats.isChecked() else None
        if self._settings is not None:
            self._settings.set_last_folder("icc", path)

        def job(report, cancel):
            from dreamprint_gui.gamut import get_tables
            from dreamprint_gui.gamut.icc_export import check_outputs, export_icc

            check_outputs(path, cgats)
            tables = req.tables
            if tables is None:
                kwargs = {} if req.size is None else {"size": req.size}
                tables = get_tables(req.profile, intent=req.intent, progress=lambda f: report(
                    f"building the colour tables: {int(100 * f)} %"), notify=report, **kwargs)
            return export_icc(path, req.profile, tables, printer=req.printer, cgats=cgats,
                              progress=report)

        task = Task(job, "icc-export")
        task.progress.connect(lambda msg: self.status.setText(f"{str(msg).capitalize()} ..."))
        task.succeeded.connect(self._done)
        task.failed.connect(self._failed)
        task.done.connect(lambda: self.button.setEnabled(True))
        self.button.setEnabled(False)
        self.status.setStyleSheet("")
        self.status.setText("Exporting the ICC profile ...")
        self._task = run_task(task)

    def _done(self, report: dict) -> None:
        self.status.setText(summary(report))
        self.exported.emit(report)

    def _failed(self, message: str, _tb: str) -> None:
        self.status.setStyleSheet("color: #b00020;")
        self.status.setText(f"ICC export failed: {message}")
        self.failed.emit(message)

    def shutdown(self) -> None:
        """The box is going away: an export under way writes its file, unreported (it has no
        point at which to stop without leaving a half-built profile)."""
        task, self._task = self._task, None
        if task is not None:
            for sig in (task.progress, task.succeeded, task.failed, task.done):
                try:
                    sig.disconnect()
                except (RuntimeError, TypeError):
                    pass
