"""The export dialog: printer, size, halftoning, seed, folder, workers -> a finished print job.

Defines :func:`export_job` (``job.run.run_conversion`` as a worker job), :func:`placement_combos`
(the Up, Turn and Size-of controls the Preview shares) and :class:`ExportDialog`, which runs the
job on a worker thread with a progress bar, time remaining and Cancel (the engine removes a
cancelled job's partial folder), then shows a summary from the manifest; an export that was
interrupted (the application or computer stopped, a cluster lost) is offered to resume or start
again on the next Export to the same job (:mod:`dreamprint_gui.job.resume`). "Compensate
appearance" first optimises a correction through the print proof
(:func:`dreamprint_gui.proof.compensated.run_compensated_conversion`, as ``dreamprint convert
--compensate``; written beside the job as ``NAME.correction.npz``), then converts with it; one
progress bar and time left over both. Where the slabs run is the engine's choice too
(``ConvertSettings.workers`` and ``.scheduler``); the choices persist with QSettings
(``export/...``). What is not a widget (the settings the choices make, the scheduler address,
the summary's and the pre-flight's HTML) is :mod:`.export_data`.
"""

from __future__ import annotations

import logging
import os
import time
from pathlib import Path

from PySide6.QtCore import Qt, QTimer, Signal
from PySide6.QtWidgets import (
    QButtonGroup,
    QCheckBox,
    QComboBox,
    QDialog,
    QDialogButtonBox,
    QDoubleSpinBox,
    QFileDialog,
    QFormLayout,
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QMessageBox,
    QProgressBar,
    QPushButton,
    QRadioButton,
    QSpinBox,
    QTextBrowser,
    QVBoxLayout,
    QWidget,
)

from dreamprint_gui.core.durations import clock_words
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.print_size import DEMO_HEIGHT_MM  # the default height
from dreamprint_gui.gui.export_data import (
    SCHEDULERS,
    check_scheduler_address,
    convert_settings,
    manifest_summary,
    preflight_html,
    printer_file_name,
    same_job,
)
from dreamprint_gui.gui.names import BACKGROUNDS, CONTENTS, INTENTS, printer_name
from dreamprint_gui.gui.settings import AppSettings
from dreamprint_gui.gui.workers import Task, generator_job, run_task

__all__ = ["ExportDialog", "export_job", "placement_combos"]

log = logging.getLogger(__name__)

def placement_combos(params: dict | None = None) -> tuple[QComboBox, QComboBox, QComboBox]:
    """The Up, Turn and Size-of combo boxes (``--up``, ``--rotate``, ``--fit``), set from
    ``params`` (the preview's ``params()``: up, rotate, fit)."""
    from dreamprint_gui.gui.names import FITS, TURNS, UPS

    p = params or {}
    up, turn, fit = QComboBox(), QComboBox(), QComboBox()
    for combo, items in ((up, UPS), (fit, FITS)):
        for key, name, tip in items:
            combo.addItem(name, key)
            combo.setItemData(combo.count() - 1, tip, Qt.ItemDataRole.ToolTipRole)
    for deg, name in TURNS:
        turn.addItem(name, deg)
    up.setToolTip("The source axis that becomes the print's up (build direction)")
    turn.setToolTip("Turn the print about its vertical axis (counter-clockwise from above)")
    fit.setToolTip("What the height (or box) measures: the object itself or the file's box")
    for combo, key, default in ((up, "up", "auto"), (turn, "rotate", 0), (fit, "fit",
                                                                           "occupied")):
        combo.setCurrentIndex(max(0, combo.findData(p.get(key, default))))
    return up, turn, fit


def export_job(settings, preflight=True, compensate: dict | None = None):
    """A worker job running the conversion: progress items are ``ConvertProgress``.
    ``preflight``: an estimate already made for these settings (recorded in the manifest as
    is), or True to make it first (``job.run.run_conversion``). ``compensate``: the
    optimiser's settings (``{}`` for its defaults) to compensate the appearance first; progress
    items are then ``CompensationProgress``."""
    if compensate is not None:
        from dreamprint_gui.proof.compensated import run_compensated_conversion

        return generator_job(lambda cancel: run_compensated_conversion(
            settings, cancel, preflight=preflight, **compensate))
    from dreamprint_gui.job.run import run_conversion

    return generator_job(lambda cancel: run_conversion(settings, cancel, preflight=preflight))


class ExportDialog(QDialog):
    """Choose the job's settings and run it with progress, time remaining and Cancel."""

    printerChanged = Signal(object)
    finished_job = Signal(dict)

    def __init__(self, parent: QWidget | None, *, source_path: str, profile_path: str | None,
                 settings: AppSettings | None = None, preview_params: dict | None = None,
                 source_name: str | None = None, table_size: int | None = None,
                 context=None) -> None:
        super().__init__(parent)
        from dreamprint_gui.core.printer import DEFAULT_PRINTER, builtin_printers

        self.settings = settings or AppSettings()
        self.source_path = source_path
        self.profile_path = profile_path
        self.table_size = table_size
        self.task: Task | None = None
        self.manifest: dict | None = None
        self.elapsed_s: float | None = None  # the last job's wall-clock time, Export to done
        self._t_start = 0.0
        self.target: str | None = None
        self.setWindowTitle("Export print job")
        self.setMinimumWidth(560)
        pp = preview_params or {}
        self.context = context  # the preview's JobContext: reused when the job's source matches
        self.sampling_choice = pp.get("sampling")  # the preview's voxel-edge choice
        # how the preview reads the file (grid, level set, reader options): the job's too
        self.source_options = dict(pp.get("source_options") or {})
        self.preflight = None  # the engine's Preflight of the current settings
        self._preflight_settings = None  # the settings it estimated
        self._preflight_task: Task | None = None
        self._preflight_pending = False

        self.printer = QComboBox()
        self.printer.setEditable(False)
        for name in builtin_printers():
            self.printer.addItem(printer_name(name), name)
            self.printer.setItemData(self.printer.count() - 1, f"id {name}",
                                     Qt.ItemDataRole.ToolTipRole)
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
                                     value=float(pp.get("height_mm", DEMO_HEIGHT_MM)))
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
        for key, name, tip in BACKGROUNDS:
            self.background.addItem(name, key)
            self.background.setItemData(self.background.count() - 1, tip,
                                        Qt.ItemDataRole.ToolTipRole)
        self.background.setCurrentIndex(max(0, self.background.findData(
            pp.get("background", "clear"))))
        self.content = QComboBox()
        for key, name, tip in CONTENTS:
            self.content.addItem(name, key)
            self.content.setItemData(self.content.count() - 1, tip,
                                     Qt.ItemDataRole.ToolTipRole)
        self.content.setCurrentIndex(max(0, self.content.findData(pp.get("content", "auto"))))
        self.up, self.turn, self.fit = placement_combos(pp)
        self.halftone = QComboBox()
        self.halftone.addItem("blue noise (low noise, default)", "blue-noise")
        self.halftone.addItem("random (paper's stochastic)", "random")
        self.halftone.setCurrentIndex(max(0, self.halftone.findData(
            self.settings.get("export/halftone", "blue-noise", str))))
        self.intent = QComboBox()  # rendering intent (ConvertSettings.intent; "" = profile's)
        self.intent.addItem("The profile's (colorimetric unless it says otherwise)", "")
        for key, name, tip in INTENTS:
            self.intent.addItem(name, key)
            self.intent.setItemData(self.intent.count() - 1, tip, Qt.ItemDataRole.ToolTipRole)
        self.intent.setCurrentIndex(max(0, self.intent.findData(
            self.settings.get("export/intent", "", str))))
        self.seed = QSpinBox(minimum=0, maximum=2**31 - 1,
                             value=self.settings.get("export/seed", 0, int))
        self.folder = QLineEdit(self.settings.last_folder("export"))
        browse = QPushButton("...")
        browse.setMaximumWidth(32)
        browse.clicked.connect(self._browse)
        default_name = (source_name or Path(str(source_path)).stem or "job") + "-job"
        self.job_name = QLineEdit(default_name)
        self.overwrite = QCheckBox("replace an existing job of that name")
        self.compensate = QCheckBox("Compensate appearance")
        self.compensate.setToolTip(
            "Before converting, optimise a correction of the job's colours and densities "
            "through the print proof (Mitsuba; minutes, about 5 for a 20 mm object), written "
            "beside the job as NAME.correction.npz")
        self.compensation_options: dict = {}  # the optimiser's settings (tests: small ones)
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
        form.addRow("Content", self.content)
        place_row = QHBoxLayout()  # one row: the dialog fits a 1280 x 800 screen
        for name, combo in (("Up", self.up), ("Turn", self.turn), ("Size of", self.fit)):
            if place_row.count():
                place_row.addSpacing(12)
            place_row.addWidget(QLabel(name))
            place_row.addWidget(combo, 1)
        form.addRow("Placement", place_row)
        form.addRow("Halftoning", self.halftone)
        form.addRow("Rendering intent", self.intent)
        form.addRow("Appearance", self.compensate)
        form.addRow("Seed", self.seed)
        form.addRow("Folder", frow)
        form.addRow("Job name", self.job_name)
        form.addRow("", self.overwrite)
        form.addRow("Run on", run_row)
        form.addRow("Workers", self.workers)

        self.progress = QProgressBar(minimum=0, maximum=1000)
        self.progress.setValue(0)
        self.remaining = QLabel("")
        self.remaining.setWordWrap(True)
        self.error = QLabel("")
        self.error.setStyleSheet("color: #d33;")
        self.error.setWordWrap(True)
        # The finished job's summary: the whole of it, scrolling inside its own box if the
        # screen is small (the form is hidden then, the summary restates the settings).
        self.summary = QTextBrowser()
        self.summary.setObjectName("jobSummary")
        self.summary.setOpenExternalLinks(False)
        self.summary.setMinimumHeight(120)
        self.summary.setVisible(False)
        # Before Export: the engine's pre-flight of these settings (grid, slices, disk, time,
        # material fractions, warnings), recomputed when a setting changes.
        self.preflight_view = QTextBrowser()
        self.preflight_view.setObjectName("preflight")
        self.preflight_view.setMinimumHeight(150)
        self.preflight_box = QGroupBox("Pre-flight estimate")
        pl = QVBoxLayout(self.preflight_box)
        pl.addWidget(self.preflight_view)
        self._preflight_debounce = QTimer(self, singleShot=True, interval=400)
        self._preflight_debounce.timeout.connect(self.update_preflight)
        self.buttons = QDialogButtonBox()
        self.start_button = self.buttons.addButton("Export",
                                                   QDialogButtonBox.ButtonRole.AcceptRole)
        self.cancel_button = self.buttons.addButton(QDialogButtonBox.StandardButton.Cancel)
        self.close_button = self.buttons.addButton(QDialogButtonBox.StandardButton.Close)
        self.close_button.setVisible(False)
        self.start_button.clicked.connect(self.start)
        self.cancel_button.clicked.connect(self._cancel_clicked)
        self.close_button.clicked.connect(self.accept)

        self.form_box = QWidget()
        self.form_box.setLayout(form)
        form.setContentsMargins(0, 0, 0, 0)
        lay = QVBoxLayout(self)
        lay.addWidget(self.form_box)
        lay.addWidget(self.preflight_box, 1)
        lay.addWidget(self.progress)
        lay.addWidget(self.remaining)
        lay.addWidget(self.error)
        lay.addWidget(self.summary, 1)
        lay.addWidget(self.buttons)
        self._form_widgets = [self.printer, self.by_height, self.by_box, self.height, *self.box,
                              self.density_scale, self.background, self.content,
                              self.up, self.turn, self.fit, self.halftone, self.intent,
                              self.compensate, self.seed,
                              self.folder, browse, self.job_name, self.overwrite,
                              self.scheduler, self.scheduler_address, self.workers]
        self._printer_obj = None
        self._update_printer()
        for w in (self.height, *self.box, self.density_scale, self.seed):
            w.valueChanged.connect(self._settings_changed)
        for w in (self.background, self.content, self.halftone, self.printer):
            w.currentIndexChanged.connect(self._settings_changed)
        for w in (self.by_height, self.by_box):
            w.toggled.connect(self._settings_changed)
        QTimer.singleShot(0, self.update_preflight)

    # pre-flight -------------------------------------------------------------------------------
    def _settings_changed(self, *_args) -> None:
        if self.task is None or self.task.outcome is not None:
            self._preflight_debounce.start()

    def update_preflight(self) -> None:
        """Estimate the job of the current settings on a worker (``job.preflight``)."""
        if self._preflight_task is not None and self._preflight_task.outcome is None:
            self._preflight_pending = True  # one at a time; the latest settings win
            return
        try:
            settings = self.settings_for_job()
        except DreamPrintError as exc:
            self.preflight = None
            self.preflight_view.setPlainText(f"no estimate: {exc}")
            return
        previous = self.context

        def job(report, cancel):
            from dreamprint_gui.gui.preview_data import estimated_context
            from dreamprint_gui.job.preflight import preflight

            ctx, est, took = estimated_context(settings, previous, report)
            pf = preflight(ctx, seed=settings.seed, notify=report)  # each step as it starts
            if est is not None:   # preparing as estimated before it started, and as it took
                pf.prepare_estimate, pf.prepared_seconds = est.to_json(), took
            return settings, pf

        self.preflight_view.setPlainText("estimating the job ...")
        task = Task(job, "export-preflight")
        task.progress.connect(lambda line: self.preflight_view.setPlainText(
            f"estimating the job ... {line}"))
        task.succeeded.connect(self._show_preflight)
        task.failed.connect(lambda msg, _tb: self.preflight_view.setPlainText(
            f"no estimate: {msg}"))
        task.done.connect(self._preflight_done)
        self._preflight_task = run_task(task)

    def _preflight_done(self) -> None:
        if self._preflight_pending:
            self._preflight_pending = False
            self._preflight_task = None
            self.update_preflight()

    def _show_preflight(self, result) -> None:
        settings, pf = result
        if self._preflight_pending:
            return
        self.preflight = pf
        self._preflight_settings = settings
        self.preflight_view.setHtml(preflight_html(pf))
        self._fit_text(self.preflight_view, 150)

    # choices ----------------------------------------------------------------------------------
    def _printer_chosen(self, index: int) -> None:
        if self.printer.itemData(index) == "":
            path, _ = QFileDialog.getOpenFileName(self, "Printer profile",
                                                  self.settings.last_folder("printer"),
                                                  "Printer profiles (*.toml)")
            if path:
                self.printer.insertItem(index, printer_file_name(path), path)
                self.printer.setCurrentIndex(index)
            else:
                self.printer.setCurrentIndex(0)
        self._update_printer()

    def _update_printer(self) -> None:
        from dreamprint_gui.core.printer import load_printer

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
                                  f"tray {tx:.0f} x {ty:.0f} x {tz:.0f} mm (id {p.name})")
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
            content=str(self.content.currentData()), sampling=self.sampling_choice,
            intent=str(self.intent.currentData()) or None, up=str(self.up.currentData()),
            rotate=int(self.turn.currentData()), fit=str(self.fit.currentData()),
            source_options=self.source_options)

    # running ----------------------------------------------------------------------------------
    def start(self) -> None:
        self.error.setText("")
        self.summary.setVisible(False)
        try:
            settings = self.settings_for_job()
        except DreamPrintError as exc:
            self.error.setText(str(exc))
            return
        settings = self._resume_or_restart(settings)
        if settings is None:
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
        self._t_start = time.monotonic()
        self.elapsed_s = None
        same = same_job(settings, self._preflight_settings) and self.preflight is not None
        comp = dict(self.compensation_options) if self.compensate.isChecked() else None
        task = Task(export_job(settings, self.preflight if same else True, comp), "export")
        task.progress.connect(self._progress)
        task.succeeded.connect(self._succeeded)
        task.failed.connect(self._failed)
        task.cancelled.connect(self._cancelled)
        self.task = run_task(task)

    def _resume_or_restart(self, settings):
        """``settings`` to resume or to start again when an earlier export of this job was
        interrupted (the application or computer stopped, the cluster lost) and left finished
        layers (:func:`dreamprint_gui.job.resume.find_interrupted`); None if the operator
        chose neither. An existing finished job is the engine's to refuse, as without this."""
        from dataclasses import replace

        from dreamprint_gui.job.resume import find_interrupted

        if settings.overwrite or Path(settings.output).exists():
            return settings
        left = find_interrupted(settings.output)
        if left is None:
            return settings
        choice = self.ask_resume(Path(settings.output).name, left[1], left[2])
        if choice == "resume":
            return replace(settings, resume=True)
        if choice == "restart":
            return replace(settings, overwrite=True)
        return None

    def ask_resume(self, name: str, done: int, total: int) -> str | None:
        """Ask whether to resume an interrupted export: "resume", "restart" or None."""
        box = QMessageBox(QMessageBox.Icon.Question, "DreamPrint: interrupted export",
                          f"An earlier export of \u201c{name}\u201d was interrupted with {done} "
                          f"of {total} layers done.\n\nResume converts only the missing layers "
                          "(the same slices as an uninterrupted export, if the settings are "
                          "the same; otherwise it is refused). Start again discards them.",
                          QMessageBox.StandardButton.NoButton, self)
        resume = box.addButton("Resume", QMessageBox.ButtonRole.AcceptRole)
        restart = box.addButton("Start again", QMessageBox.ButtonRole.DestructiveRole)
        box.addButton(QMessageBox.StandardButton.Cancel)
        box.setDefaultButton(resume)
        box.exec()
        clicked = box.clickedButton()
        return "resume" if clicked is resume else "restart" if clicked is restart else None

    def _progress(self, p) -> None:
        if hasattr(p, "fraction"):  # compensating, then converting: one bar over both
            self.progress.setValue(int(1000 * p.fraction))
            c = p.inner
            what = (f"layer {c.layers_done} of {c.layers_total}"
                    if p.stage == "converting" and getattr(c, "layers_total", 0)
                    else f"{'compensating appearance' if p.stage == 'compensating' else p.stage}"
                         f"{': ' + p.message if p.message else ''}")
            self.remaining.setText(f"{what}; elapsed {clock_words(p.elapsed_s)}; "
                                   f"remaining {clock_words(p.eta_s)}")
            return
        if p.layers_total:
            self.progress.setValue(int(1000 * p.layers_done / p.layers_total))
        if p.stage == "converting" and p.layers_total:
            self.remaining.setText(
                f"layer {p.layers_done} of {p.layers_total}; elapsed "
                f"{clock_words(p.elapsed_s)}; remaining {clock_words(p.eta_s)}")
        else:
            self.remaining.setText(p.message or p.stage)

    def _finish_run(self) -> None:
        for w in self._form_widgets:
            w.setEnabled(True)
        self.start_button.setEnabled(True)

    def _succeeded(self, manifest: dict) -> None:
        self.manifest = manifest
        self.elapsed_s = time.monotonic() - self._t_start  # Export to here, as the operator waited
        self.progress.setValue(1000)
        self.remaining.setText("done")
        self.summary.setHtml(manifest_summary(manifest, str(self.target), self.elapsed_s))
        self.form_box.setVisible(False)
        self.preflight_box.setVisible(False)
        self.summary.setVisible(True)
        self._fit_text(self.summary, 120, widen=True)
        self.start_button.setVisible(False)
        self.cancel_button.setVisible(False)
        self.close_button.setVisible(True)
        self._finish_run()
        self.finished_job.emit(manifest)

    def _fit_text(self, box: QTextBrowser, least: int, widen: bool = False) -> None:
        """Make the dialog tall enough for the whole text of ``box`` (within the screen; the
        box scrolls beyond that); ``widen``: first wide enough that long lines (the job's
        warnings) wrap into few lines (up to 900 px, 70 % of the screen)."""
        doc = box.document()
        screen = self.screen().availableGeometry() if self.screen() else None
        if widen:
            wide = min(900, int(0.7 * screen.width())) if screen is not None else 900
            if self.width() < wide:
                self.setMinimumWidth(wide)
                self.resize(wide, self.size().height())  # (self.height: a spin box)
                self.layout().activate()
        doc.setTextWidth(box.viewport().width())
        need = int(doc.size().height()) + 2 * box.frameWidth() + 8
        limit = int(0.9 * screen.height()) if screen is not None else 900
        other = self.sizeHint().height() - max(box.sizeHint().height(), box.minimumHeight())
        box.setMinimumHeight(max(least, min(need, limit - other)))
        self.adjustSize()

    def _failed(self, message: str, _tb: str) -> None:
        from dreamprint_gui.job.resume import find_interrupted

        if self.target is not None and find_interrupted(self.target) is not None:
            message = message.replace("run the same command with --resume",
                                      "Export again to resume")
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
        self._preflight_debounce.stop()
        if self._preflight_task is not None:
            self._preflight_task.cancel()  # an estimate nobody will read
        if self.task is not None and self.task.outcome is None:
            self.task.cancel()
            if self.task.thread is not None:
                self.task.thread.wait(30000)
        super().closeEvent(event)
