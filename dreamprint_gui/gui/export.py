"""The export dialog: printer, size, halftoning, seed, folder, workers -> a finished print job.

Defines :func:`convert_settings` (the GUI's choices as the engine's ``ConvertSettings``, the
same object ``dreamprint convert`` builds), :func:`export_job` (``pipeline.run_conversion`` as
a worker job) and :class:`ExportDialog`, which runs it on a worker thread with a progress bar,
time remaining and Cancel (the engine removes a cancelled job's partial folder), then shows a
summary from the manifest. Where the slabs run is the engine's choice too
(``ConvertSettings.workers`` and ``.scheduler``): this computer's threads or processes with a
worker count, or a ``dask.distributed`` cluster by address (:data:`SCHEDULERS`,
:func:`check_scheduler_address`); the choices persist with QSettings (``export/...``).
"""

from __future__ import annotations

import logging
import math
import os
from pathlib import Path

from PySide6.QtCore import Signal
from PySide6.QtWidgets import (
    QButtonGroup,
    QCheckBox,
    QComboBox,
    QDialog,
    QDialogButtonBox,
    QDoubleSpinBox,
    QFileDialog,
    QFormLayout,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QProgressBar,
    QPushButton,
    QRadioButton,
    QSpinBox,
    QTextBrowser,
    QVBoxLayout,
    QWidget,
)

from ..errors import DreamPrintError
from .settings import AppSettings
from .workers import Task, generator_job, run_task

__all__ = ["ExportDialog", "convert_settings", "export_job", "format_duration",
           "manifest_summary", "check_scheduler_address", "SCHEDULERS"]

log = logging.getLogger(__name__)

# (settings value, label); "distributed" takes an address (ConvertSettings.scheduler).
SCHEDULERS = (("threads", "this computer, threads (default)"),
              ("processes", "this computer, processes"),
              ("distributed", "Dask cluster (dask.distributed)"))


def check_scheduler_address(address: str) -> str:
    """A dask.distributed scheduler address as the engine takes it (``tcp://host:port``)."""
    a = address.strip()
    if not a:
        raise DreamPrintError("give the Dask scheduler's address, e.g. tcp://host:8786")
    if "://" not in a:
        a = "tcp://" + a  # what dask.distributed assumes for host:port
    scheme, _, rest = a.partition("://")
    host, _, port = rest.rpartition(":")
    if scheme in ("tcp", "tls", "ws", "wss"):
        ok = bool(host) and port.isdigit() and 0 < int(port) < 65536
    else:  # an in-process cluster, or UCX: no port to check
        ok = scheme in ("inproc", "ucx") and bool(rest)
    if not ok:
        raise DreamPrintError(f"'{address}' is not a Dask scheduler address "
                              "(like tcp://host:8786)")
    return a


def convert_settings(source_path: str, profile_path: str | None, printer, *,
                     height_mm: float | None = None,
                     size_mm: tuple[float, float, float] | None = None,
                     density_scale: float = 1.0, background: str = "clear",
                     halftone: str = "blue-noise", seed: int = 0,
                     output: str | os.PathLike | None = None, overwrite: bool = False,
                     workers: int | None = None, scheduler: str | None = None,
                     table_size: int | None = None, intent: str | None = None):
    """The engine's ``ConvertSettings`` for the GUI's choices (printer: name, path or profile)."""
    from ..engine.pipeline import ConvertSettings

    if printer is not None and not isinstance(printer, str | os.PathLike):
        printer = printer.path or printer.name
    extra = {} if table_size is None else {"table_size": int(table_size)}
    if intent is not None:
        extra["intent"] = intent
    return ConvertSettings(source=str(source_path), output=output, profile=profile_path,
                           printer=printer, height_mm=height_mm,
                           size_mm=None if size_mm is None else tuple(size_mm),
                           density_scale=float(density_scale), halftone=halftone,
                           seed=int(seed), workers=workers, scheduler=scheduler,
                           background=background,
                           overwrite=overwrite, **extra)


def export_job(settings):
    """A worker job running the conversion: progress items are ``ConvertProgress``."""
    from ..engine.pipeline import run_conversion

    return generator_job(lambda cancel: run_conversion(settings, cancel))


def format_duration(seconds: float | None) -> str:
    if seconds is None or not math.isfinite(seconds):
        return "estimating ..."
    seconds = max(0, int(round(seconds)))
    h, rem = divmod(seconds, 3600)
    m, s = divmod(rem, 60)
    return f"{h} h {m:02d} min" if h else (f"{m} min {s:02d} s" if m else f"{s} s")


def manifest_summary(manifest: dict, target: str) -> str:
    """HTML summary of a finished job from its manifest (what the operator checks)."""
    nx, ny, nz = manifest["grid_dimensions"]
    sx, sy, sz = manifest["physical_size_mm"]
    total = max(1, int(manifest.get("total_voxels", nx * ny * nz)))
    rows = []
    for lab, n in manifest.get("voxel_counts", {}).items():
        name = manifest.get("labels", {}).get(lab, {}).get("material", "")
        rows.append(f"<tr><td>{lab}</td><td>{name}</td><td align=right>{n:,}</td>"
                    f"<td align=right>{100 * n / total:.2f} %</td></tr>")
    clamped = manifest.get("clamped_density") or {}
    clamp_text = ", ".join(f"{k} {v:,.0f}" if isinstance(v, int | float) else f"{k} {v}"
                           for k, v in clamped.items()) or "none"
    t = manifest.get("timings_s", {})
    ex = manifest.get("execution") or {}
    run_on = (f"; run on {ex.get('scheduler', 'threads')}"
              + (f", {ex['workers']} workers" if ex.get("workers") else "")
              + (f", {ex['slabs']} slabs" if ex.get("slabs") else "")) if ex else ""
    return (
        f"<p><b>Job complete</b>: {target}</p>"
        f"<p>{nz} slices of {nx} x {ny} voxels ({total:,} voxels), "
        f"{sx:.2f} x {sy:.2f} x {sz:.2f} mm, printer {manifest['printer'].get('name', '')}, "
        f"halftoning {manifest.get('halftoning', {}).get('method', '')}, "
        f"seed {manifest.get('seed')}</p>"
        f"<table cellspacing=6><tr><th>label</th><th>material</th><th>voxels</th>"
        f"<th>share</th></tr>{''.join(rows)}</table>"
        f"<p>Density targets clamped: {clamp_text}</p>"
        f"<p>Time {format_duration(t.get('total'))}"
        + (f", {t['voxels_per_second']:.3g} voxels/s" if "voxels_per_second" in t else "")
        + run_on + "</p>")


class ExportDialog(QDialog):
    """Choose the job's settings and run it with progress, time remaining and Cancel."""

    printerChanged = Signal(object)
    finished_job = Signal(dict)

    def __init__(self, parent: QWidget | None, *, source_path: str, profile_path: str | None,
                 settings: AppSettings | None = None, preview_params: dict | None = None,
                 source_name: str | None = None, table_size: int | None = None) -> None:
        super().__init__(parent)
        from ..engine.printer import DEFAULT_PRINTER, builtin_printers

        self.settings = settings or AppSettings()
        self.source_path = source_path
        self.profile_path = profile_path
        self.table_size = table_size
        self.task: Task | None = None
        self.manifest: dict | None = None
        self.target: str | None = None
        self.setWindowTitle("Export print job")
        self.setMinimumWidth(560)
        pp = preview_params or {}

        self.printer = QComboBox()
        self.printer.setEditable(False)
        for name in builtin_printers():
            self.printer.addItem(name, name)
        self.printer.addItem("Printer file (TOML)...", "")
        self.printer.setCurrentIndex(max(0, self.printer.findData(
            self.settings.get("export/printer", DEFAULT_PRINTER, str))))
        self.printer.activated.connect(self._printer_chosen)
        self.printer_info = QLabel("")
        self.printer_info.setWordWrap(True)

        self.by_height = QRadioButton("Height")
        self.by_box = QRadioButton("Fit in box")
        group = QButtonGroup(self)
        group.addButton(self.by_height)
        group.addButton(self.by_box)
        self.height = QDoubleSpinBox(suffix=" mm", decimals=2, minimum=0.1, maximum=500,
                                     value=float(pp.get("height_mm", 40.0)))
        self.box = [QDoubleSpinBox(suffix=" mm", decimals=1, minimum=0.1, maximum=500, value=v)
                    for v in (100.0, 100.0, 100.0)]
        self.by_height.setChecked(True)
        size_row = QHBoxLayout()
        size_row.addWidget(self.by_height)
        size_row.addWidget(self.height)
        size_row.addWidget(self.by_box)
        for b in self.box:
            size_row.addWidget(b)
        self.density_scale = QDoubleSpinBox(decimals=3, minimum=0.0, maximum=1000.0,
                                            value=float(pp.get("density_scale", 1.0)))
        self.background = QComboBox()
        self.background.addItem("clear", "clear")
        self.background.addItem("empty", "empty")
        self.background.setCurrentIndex(max(0, self.background.findData(
            pp.get("background", "clear"))))
        self.halftone = QComboBox()
        self.halftone.addItem("blue noise (low noise, default)", "blue-noise")
        self.halftone.addItem("random (paper's stochastic)", "random")
        self.halftone.setCurrentIndex(max(0, self.halftone.findData(
            self.settings.get("export/halftone", "blue-noise", str))))
        self.intent = QComboBox()  # rendering intent (ConvertSettings.intent)
        self.intent.addItem("colorimetric (nearest printable colour)", "colorimetric")
        self.intent.addItem("perceptual (compress sRGB into the gamut)", "perceptual")
        self.intent.setCurrentIndex(max(0, self.intent.findData(
            self.settings.get("export/intent", "colorimetric", str))))
        self.seed = QSpinBox(minimum=0, maximum=2**31 - 1,
                             value=self.settings.get("export/seed", 0, int))
        self.folder = QLineEdit(self.settings.last_folder("export"))
        browse = QPushButton("...")
        browse.setMaximumWidth(32)
        browse.clicked.connect(self._browse)
        default_name = (source_name or Path(str(source_path)).stem or "job") + "-job"
        self.job_name = QLineEdit(default_name)
        self.overwrite = QCheckBox("replace an existing job of that name")
        frow = QHBoxLayout()
        frow.addWidget(self.folder, 1)
        frow.addWidget(browse)

        cores = os.cpu_count() or 1
        self.workers = QSpinBox(minimum=0, maximum=max(256, 4 * cores))
        self.workers.setSpecialValueText(f"all cores ({cores})")  # 0: the engine's default
        self.workers.setValue(self.settings.get("export/workers", 0, int) or 0)
        self.workers.setToolTip("Slabs converted at the same time on this computer")
        self.scheduler = QComboBox()
        for value, label in SCHEDULERS:
            self.scheduler.addItem(label, value)
        self.scheduler.setCurrentIndex(max(0, self.scheduler.findData(
            self.settings.get("export/scheduler", "threads", str))))
        self.scheduler_address = QLineEdit(self.settings.get("export/scheduler_address", "",
                                                             str))
        self.scheduler_address.setPlaceholderText("tcp://host:8786")
        self.scheduler_address.setToolTip(
            "The cluster's scheduler; its workers must see the job's folder (shared storage)")
        self.scheduler.currentIndexChanged.connect(self._scheduler_changed)
        run_row = QHBoxLayout()
        run_row.addWidget(self.scheduler, 1)
        run_row.addWidget(self.scheduler_address, 1)
        self._scheduler_changed()

        form = QFormLayout()
        form.addRow("Printer", self.printer)
        form.addRow("", self.printer_info)
        form.addRow("Size", size_row)
        form.addRow("Density scale", self.density_scale)
        form.addRow("Background", self.background)
        form.addRow("Halftoning", self.halftone)
        form.addRow("Rendering intent", self.intent)
        form.addRow("Seed", self.seed)
        form.addRow("Folder", frow)
        form.addRow("Job name", self.job_name)
        form.addRow("", self.overwrite)
        form.addRow("Run on", run_row)
        form.addRow("Workers", self.workers)

        self.progress = QProgressBar(minimum=0, maximum=1000)
        self.progress.setValue(0)
        self.remaining = QLabel("")
        self.error = QLabel("")
        self.error.setStyleSheet("color: #d33;")
        self.error.setWordWrap(True)
        self.summary = QTextBrowser()
        self.summary.setVisible(False)
        self.buttons = QDialogButtonBox()
        self.start_button = self.buttons.addButton("Export",
                                                   QDialogButtonBox.ButtonRole.AcceptRole)
        self.cancel_button = self.buttons.addButton(QDialogButtonBox.StandardButton.Cancel)
        self.close_button = self.buttons.addButton(QDialogButtonBox.StandardButton.Close)
        self.close_button.setVisible(False)
        self.start_button.clicked.connect(self.start)
        self.cancel_button.clicked.connect(self._cancel_clicked)
        self.close_button.clicked.connect(self.accept)

        lay = QVBoxLayout(self)
        lay.addLayout(form)
        lay.addWidget(self.progress)
        lay.addWidget(self.remaining)
        lay.addWidget(self.error)
        lay.addWidget(self.summary, 1)
        lay.addWidget(self.buttons)
        self._form_widgets = [self.printer, self.by_height, self.by_box, self.height, *self.box,
                              self.density_scale, self.background, self.halftone, self.intent,
                              self.seed,
                              self.folder, browse, self.job_name, self.overwrite,
                              self.scheduler, self.scheduler_address, self.workers]
        self._printer_obj = None
        self._update_printer()

    # choices ----------------------------------------------------------------------------------
    def _printer_chosen(self, index: int) -> None:
        if self.printer.itemData(index) == "":
            path, _ = QFileDialog.getOpenFileName(self, "Printer profile",
                                                  self.settings.last_folder("printer"),
                                                  "Printer profiles (*.toml)")
            if path:
                self.printer.insertItem(index, Path(path).stem, path)
                self.printer.setCurrentIndex(index)
            else:
                self.printer.setCurrentIndex(0)
        self._update_printer()

    def _update_printer(self) -> None:
        from ..engine.printer import load_printer

        spec = self.printer.currentData()
        try:
            p = load_printer(spec)
        except DreamPrintError as exc:
            self.printer_info.setText(f"<span style='color:#d33'>{exc}</span>")
            self._printer_obj = None
            return
        self._printer_obj = p
        vx, vy, vz = (v * 1000 for v in p.voxel_mm)
        tx, ty, tz = p.tray_mm
        self.printer_info.setText(f"voxel {vx:.0f} x {vy:.0f} x {vz:.0f} um, "
                                  f"tray {tx:.0f} x {ty:.0f} x {tz:.0f} mm")
        self.printerChanged.emit(p)

    def _scheduler_changed(self) -> None:
        cluster = self.scheduler.currentData() == "distributed"
        self.scheduler_address.setVisible(cluster)
        self.workers.setEnabled(not cluster)  # a cluster has its own workers
        self.workers.setToolTip("The cluster's own workers run the slabs" if cluster else
                                "Slabs converted at the same time on this computer")

    def scheduler_choice(self) -> tuple[int | None, str | None]:
        """(workers, scheduler) for ``ConvertSettings``; None means the engine's default."""
        kind = self.scheduler.currentData()
        if kind == "distributed":
            return None, check_scheduler_address(self.scheduler_address.text())
        workers = int(self.workers.value()) or None
        return workers, (None if kind == "threads" else kind)

    def _browse(self) -> None:
        folder = QFileDialog.getExistingDirectory(self, "Folder for the job", self.folder.text())
        if folder:
            self.folder.setText(folder)

    def target_path(self) -> str:
        return str(Path(self.folder.text().strip() or ".") / self.job_name.text().strip())

    def settings_for_job(self):
        if self._printer_obj is None:
            raise DreamPrintError("choose a valid printer")
        if not self.job_name.text().strip():
            raise DreamPrintError("give the job a name")
        height = size = None
        if self.by_height.isChecked():
            height = float(self.height.value())
        else:
            size = tuple(float(b.value()) for b in self.box)
        workers, scheduler = self.scheduler_choice()
        return convert_settings(
            self.source_path, self.profile_path, self.printer.currentData(),
            height_mm=height, size_mm=size, density_scale=float(self.density_scale.value()),
            background=str(self.background.currentData()),
            halftone=str(self.halftone.currentData()), seed=int(self.seed.value()),
            output=self.target_path(), overwrite=self.overwrite.isChecked(),
            workers=workers, scheduler=scheduler, table_size=self.table_size,
            intent=str(self.intent.currentData()))

    # running ----------------------------------------------------------------------------------
    def start(self) -> None:
        self.error.setText("")
        self.summary.setVisible(False)
        try:
            settings = self.settings_for_job()
        except DreamPrintError as exc:
            self.error.setText(str(exc))
            return
        self.settings.set("export/printer", self.printer.currentData())
        self.settings.set("export/halftone", self.halftone.currentData())
        self.settings.set("export/intent", self.intent.currentData())
        self.settings.set("export/seed", int(self.seed.value()))
        self.settings.set("export/workers", int(self.workers.value()))
        self.settings.set("export/scheduler", self.scheduler.currentData())
        self.settings.set("export/scheduler_address", self.scheduler_address.text().strip())
        self.settings.set_last_folder("export", self.folder.text().strip() or ".")
        self.target = settings.output
        for w in self._form_widgets:
            w.setEnabled(False)
        self.start_button.setEnabled(False)
        self.progress.setValue(0)
        self.remaining.setText("preparing ...")
        task = Task(export_job(settings), "export")
        task.progress.connect(self._progress)
        task.succeeded.connect(self._succeeded)
        task.failed.connect(self._failed)
        task.cancelled.connect(self._cancelled)
        self.task = run_task(task)

    def _progress(self, p) -> None:
        if p.layers_total:
            self.progress.setValue(int(1000 * p.layers_done / p.layers_total))
        if p.stage == "converting" and p.layers_total:
            self.remaining.setText(
                f"layer {p.layers_done} of {p.layers_total}; elapsed "
                f"{format_duration(p.elapsed_s)}; remaining {format_duration(p.eta_s)}")
        else:
            self.remaining.setText(p.message or p.stage)

    def _finish_run(self) -> None:
        for w in self._form_widgets:
            w.setEnabled(True)
        self.start_button.setEnabled(True)

    def _succeeded(self, manifest: dict) -> None:
        self.manifest = manifest
        self.progress.setValue(1000)
        self.remaining.setText("done")
        self.summary.setHtml(manifest_summary(manifest, str(self.target)))
        self.summary.setVisible(True)
        self.start_button.setVisible(False)
        self.cancel_button.setVisible(False)
        self.close_button.setVisible(True)
        self._finish_run()
        self.finished_job.emit(manifest)

    def _failed(self, message: str, _tb: str) -> None:
        self.error.setText(message)
        self.remaining.setText("")
        self._finish_run()

    def _cancelled(self) -> None:
        self.remaining.setText("cancelled; no job was written")
        self.progress.setValue(0)
        self._finish_run()

    def _cancel_clicked(self) -> None:
        if self.task is not None and self.task.outcome is None:
            self.remaining.setText("cancelling ...")
            self.task.cancel()
        else:
            self.reject()

    def closeEvent(self, event) -> None:  # noqa: N802 - Qt override
        if self.task is not None and self.task.outcome is None:
            self.task.cancel()
            if self.task.thread is not None:
                self.task.thread.wait(30000)
        super().closeEvent(event)
