"""The main window: preview and gamut pages, menus, recent files, drag and drop, state.

Defines :class:`MainWindow` and :func:`classify_path` (what a dropped or opened file is: an ink
profile, a calibration set, or a volume source). The window holds the active profile, its colour
tables (``gamut.get_tables``, built on a worker thread and cached on disk by the engine) and the
active source (``io.volumes.open_source``, also on a worker thread: a large file takes time to
open), and hands them to the pages. It starts on the built-in default profile and the demo
volume. Nothing heavy runs on the GUI thread at start: the window shows first, the 3D stack is
imported on a worker meanwhile (:func:`.volume_view.import_3d`), and the gamut page is held
until the preview has rendered (or the operator opens that page) so that the two do not compete
for the cores.

Each problem is shown once, in one place: a dialog for what stopped an action (a file that
cannot be opened, tables that cannot be built), the status bar for the rest
(:meth:`MainWindow.note_problem`: a preview, a layer or a chart that failed).
"""

from __future__ import annotations

import logging
import os
from pathlib import Path

from PySide6.QtCore import Qt, Signal
from PySide6.QtGui import QAction, QDragEnterEvent, QDropEvent, QIcon, QKeySequence
from PySide6.QtWidgets import (
    QFileDialog,
    QLabel,
    QMainWindow,
    QMessageBox,
    QProgressBar,
    QTabWidget,
)

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.print_size import DEMO_HEIGHT_MM  # the default height
from dreamprint_gui.gui.names import gui_wording
from dreamprint_gui.gui.settings import AppSettings
from dreamprint_gui.gui.workers import Task, run_task

__all__ = ["MainWindow", "classify_path", "VOLUME_FILTER", "PROFILE_FILTER"]

log = logging.getLogger(__name__)

VOLUME_FILTER = ("Volumes (*.vdb *.nvdb *.vti *.vtk *.mhd *.mha *.nrrd *.nhdr *.npz *.exr "
                 "*.ply *.spz *.splat *.ksplat *.sog meta.json *.vox);;All files (*)")
PROFILE_FILTER = "Ink profiles (*.json);;All files (*)"


def classify_path(path: str) -> str:
    """``"profile"`` (ink profile JSON), ``"calibration-set"`` (TOML) or ``"volume"``."""
    if path == "demo":
        return "volume"
    suffix = Path(path).suffix.lower()
    if suffix == ".json":
        return "profile"
    if suffix == ".toml":
        return "calibration-set"
    return "volume"


class MainWindow(QMainWindow):
    """DreamPrint's main window."""

    profileChanged = Signal(object)
    sourceChanged = Signal(object)
    tablesReady = Signal(object)
    ready = Signal()  # the preview has rendered the current source with the current profile
    openFailed = Signal(str, str)  # path, problem: a volume could not be opened

    def __init__(self, settings: AppSettings | None = None, table_size: int | None = None,
                 with_gamut: bool = True) -> None:
        super().__init__()
        self.settings = settings or AppSettings()
        self.table_size = table_size
        self.profile = None
        self.profile_path: str | None = None
        self.tables = None
        self.source = None
        self.source_path: str | None = None
        self.printer = None
        self._tables_task: Task | None = None
        self._tables_for: str | None = None
        self._source_task: Task | None = None
        self._source_request: str | None = None
        self._warm_task: Task | None = None
        self.interactive = True  # False: no message boxes (screenshot runs, tests)
        self.last_error: str | None = None
        self.problem_box: QMessageBox | None = None  # the dialog of the last stopping problem

        self.setWindowTitle("DreamPrint")
        self.setAcceptDrops(True)
        from dreamprint_gui.core.resources import resource_path

        try:
            self.setWindowIcon(QIcon(str(resource_path("icons", "dreamprint.svg"))))
        except DreamPrintError:
            pass

        from dreamprint_gui.gui.preview import PreviewPage

        self.tabs = QTabWidget()
        self.preview = PreviewPage(self, table_size=table_size)
        self.tabs.addTab(self.preview, "Preview")
        self.gamut = None
        if with_gamut:
            from dreamprint_gui.gui.gamut_view import GamutPage

            self.gamut = GamutPage(self)
            self.gamut.set_hold(True)  # until the preview is ready or the page is opened
            self.tabs.addTab(self.gamut, "Gamut")
        from dreamprint_gui.gui.proof_view import ProofPage

        self.proof = ProofPage(self, lambda: self.preview.job_settings()
                               if self.preview.source_path else None)
        self.tabs.addTab(self.proof, "Print proof")
        self.setCentralWidget(self.tabs)
        self.preview.rendered.connect(self.ready)
        self.ready.connect(self._release_gamut)
        self.tabs.currentChanged.connect(self._tab_changed)
        # Problems that do not stop an action (a preview, a layer, the gamut page) go to the
        # status bar, once; the pages themselves only say what they are waiting for.
        self.preview.failed.connect(self.note_problem)
        self.preview.interpretationChanged.connect(
            lambda: self.preview.source_path and self.set_source(self.preview.source_path,
                                                                 reopen=True))
        self.preview.problem.connect(self.note_problem)
        if self.gamut is not None:
            self.gamut.problem.connect(self.note_problem)
        self.preview.set_params(
            height_mm=self.settings.get("preview/height_mm", DEMO_HEIGHT_MM, float),
            density_scale=self.settings.get("preview/density_scale", 1.0, float),
            background=self.settings.get("preview/background", "clear", str),
            fit=self.settings.get("preview/fit", "occupied", str))

        self.profile_label = QLabel()
        self.source_label = QLabel()
        self.progress = QProgressBar(maximumWidth=200)
        self.progress.setVisible(False)
        sb = self.statusBar()
        sb.addPermanentWidget(self.source_label)
        sb.addPermanentWidget(self.profile_label)
        sb.addPermanentWidget(self.progress)
        self._build_menus()

        geo, state = self.settings.window_state()
        if geo is not None:
            self.restoreGeometry(geo)
        else:
            self.resize(1280, 800)
        if state is not None:
            self.restoreState(state)
        # The window starts on the preview (not the last session's page): what was opened
        # shows first.

    def _tab_changed(self, index: int) -> None:
        if self.gamut is not None and self.tabs.widget(index) is self.gamut:
            self._release_gamut()

    def _release_gamut(self) -> None:
        if self.gamut is not None:
            self.gamut.set_hold(False)

    def warm_up(self) -> None:
        """Import the 3D stack on a worker while the window is already showing."""
        if self._warm_task is not None:
            return
        from dreamprint_gui.gui.volume_view import import_3d

        self._warm_task = run_task(Task(lambda report, cancel: import_3d(), "import-3d"))

    # menus ------------------------------------------------------------------------------------
    def _build_menus(self) -> None:
        m = self.menuBar().addMenu("&File")
        self.act_open = QAction("&Open volume...", self, shortcut=QKeySequence.StandardKey.Open)
        self.act_open.triggered.connect(self.open_dialog)
        m.addAction(self.act_open)
        act = QAction("Open &demo volume", self)
        act.triggered.connect(lambda: self.open_path("demo"))
        m.addAction(act)
        act = QAction("Open ink &profile...", self)
        act.triggered.connect(self.open_profile_dialog)
        m.addAction(act)
        act = QAction("Use the &built-in profile", self)
        act.triggered.connect(self.use_default_profile)
        m.addAction(act)
        self.recent_menu = m.addMenu("Open &recent")
        self._fill_recent()
        m.addSeparator()
        self.act_export = QAction("&Export print job...", self, shortcut="Ctrl+E")
        self.act_export.triggered.connect(self.export_dialog)
        m.addAction(self.act_export)
        m.addSeparator()
        act = QAction("&Quit", self, shortcut=QKeySequence.StandardKey.Quit)
        act.triggered.connect(self.close)
        m.addAction(act)

        c = self.menuBar().addMenu("&Calibration")
        self.act_wizard = QAction("&Calibrate inks...", self)
        self.act_wizard.triggered.connect(self.calibration_wizard)
        c.addAction(self.act_wizard)

        h = self.menuBar().addMenu("&Help")
        act = QAction("&Log file", self)
        act.triggered.connect(self._show_log_path)
        h.addAction(act)
        act = QAction("&About DreamPrint", self)
        act.triggered.connect(self._about)
        h.addAction(act)

        tb = self.addToolBar("Main")
        tb.setObjectName("mainToolbar")
        tb.addAction(self.act_open)
        tb.addAction(self.act_wizard)
        tb.addAction(self.act_export)

    def _fill_recent(self) -> None:
        self.recent_menu.clear()
        files = self.settings.recent_files()
        for f in files:
            act = QAction(f, self)
            act.triggered.connect(lambda _=False, f=f: self.open_path(f))
            self.recent_menu.addAction(act)
        if files:
            self.recent_menu.addSeparator()
            act = QAction("Clear list", self)
            act.triggered.connect(self._clear_recent)
            self.recent_menu.addAction(act)
        self.recent_menu.setEnabled(bool(files))

    def _clear_recent(self) -> None:
        self.settings.clear_recent()
        self._fill_recent()

    # opening ----------------------------------------------------------------------------------
    def open_dialog(self) -> None:
        path, _ = QFileDialog.getOpenFileName(self, "Open volume",
                                              self.settings.last_folder("volume"), VOLUME_FILTER)
        if path:
            self.open_path(path)

    def open_profile_dialog(self) -> None:
        path, _ = QFileDialog.getOpenFileName(self, "Open ink profile",
                                              self.settings.last_folder("profile"),
                                              PROFILE_FILTER)
        if path:
            self.open_path(path)

    def open_path(self, path: str | os.PathLike) -> bool:
        """Open a volume, an ink profile or a calibration set; a problem goes to one dialog.

        A profile opens at once (False if it cannot be read). A volume opens on a worker
        thread and the preview page is shown: True means the opening has started; a problem
        is reported when it is found (a dialog, or the status bar when not interactive, and
        :attr:`openFailed`).
        """
        path = str(path)
        kind = classify_path(path)
        if kind == "volume":
            self.tabs.setCurrentWidget(self.preview)  # the file is what the operator sees next
        try:
            if kind == "profile":
                from dreamprint_gui.core.profile import load_profile

                self.set_profile(load_profile(path), path)
                self.settings.set_last_folder("profile", path)
            elif kind == "calibration-set":
                self.calibration_wizard(calibration_set=path)
                return True
            else:
                self.set_source(path)
                return True
        except DreamPrintError as exc:
            self._file_problem(str(exc))
            return False
        self._remember(path)
        return True

    def _remember(self, path: str) -> None:
        self.settings.add_recent(path)
        self._fill_recent()

    def _file_problem(self, message: str, title: str = "cannot open") -> None:
        """A problem that stopped an action: one dialog (status bar when not interactive)."""
        self.last_error = message
        if self.statusBar().currentMessage().startswith(("Opening ", "Loading ")):
            self.statusBar().clearMessage()  # the action it announced has stopped
        if not (self.isVisible() and self.interactive):
            self.statusBar().showMessage(message, 15000)
            return
        if self.problem_box is not None:
            self.problem_box.close()
        box = QMessageBox(QMessageBox.Icon.Warning, f"DreamPrint: {title}", message,
                          QMessageBox.StandardButton.Ok, self)
        box.setAttribute(Qt.WidgetAttribute.WA_DeleteOnClose)
        box.destroyed.connect(lambda _=None, box=box: self._box_gone(box))
        self.problem_box = box
        box.open()  # window-modal but not blocking: workers keep reporting meanwhile

    def _box_gone(self, box) -> None:
        if self.problem_box is box:
            self.problem_box = None

    def note_problem(self, message: str) -> None:
        """A problem that stops nothing (a preview, a layer, a chart): the status bar, once."""
        self.last_error = message
        self.statusBar().showMessage(message, 30000)

    def set_source(self, path: str, *, reopen: bool = False) -> Task | None:
        """Open the volume ``path`` on a worker thread as a job would read it
        (``job.plan.source_options_for``): a new file with its reader's defaults and content
        auto (a level set as a solid), ``reopen`` with the preview's interpretation controls.
        It becomes the source once open. A file that needs a choice the preview offers (which
        grid, how to read a level set) is handed to the preview with the problem, which waits
        for that choice. Returns the opening task, or None when the preview's reader options
        cannot be read (the preview then says why and waits for a choice)."""
        name = "demo volume" if path == "demo" else Path(path).name
        self._source_request = path
        if self._source_task is not None and self._source_task.outcome is None:
            self._source_task.cancel()  # its result is ignored (see _source_opened)
        self._say_waiting(f"opening {name} ...")
        try:
            options = self.preview.source_options() if reopen else {}
        except DreamPrintError as exc:
            self.preview.hold_for_choice(str(exc))
            return None
        content = self.preview.params()["content"] if reopen else "auto"

        def job(report, cancel):
            from dreamprint_gui.io.volumes import open_source
            from dreamprint_gui.io.volumes.registry import interpretation_choices
            from dreamprint_gui.job.plan import source_options_for

            choices = interpretation_choices(path)
            try:
                return open_source(path, **source_options_for(path, options, content)), \
                    choices, None
            except DreamPrintError as exc:
                if not (choices["grids"] or choices["level_set"] or reopen):
                    raise
                return None, choices, str(exc)

        task = Task(job, "open-source")
        task.succeeded.connect(lambda src, path=path: self._source_opened(path, src))
        task.failed.connect(lambda msg, _tb, path=path: self._source_failed(path, msg))
        self._source_task = run_task(task)
        return task

    def _say_waiting(self, text: str) -> None:
        """What is being waited for, in one place: the preview's view while it has nothing to
        show, else the status bar."""
        if self.preview.data is None:
            self.preview.show_waiting(text)
        else:
            self.statusBar().showMessage(text[:1].upper() + text[1:])

    def _source_opened(self, path: str, result) -> None:
        if path != self._source_request:
            return  # another file was asked for since
        source, choices, problem = result
        new = path != self.preview.source_path
        if problem is not None:  # the preview's controls can solve it: they wait for a choice
            self.source, self.source_path = None, path
            self.source_label.setText(f"Source: {Path(path).name} (choose how to read it)")
            if self.statusBar().currentMessage().startswith("Opening "):
                self.statusBar().clearMessage()
            self.preview.hold_for_choice(problem)
            self.preview.set_inputs(source_path=path, printer=self._ensure_printer())
            self.preview.set_choices(choices)
            self._file_problem(gui_wording(problem))
            return
        self.source, self.source_path = source, path
        name = "demo volume" if path == "demo" else Path(path).name
        self.source_label.setText(f"Source: {name}")
        self.setWindowTitle(f"DreamPrint - {name}")
        if self.statusBar().currentMessage().startswith("Opening "):
            self.statusBar().clearMessage()
        if path != "demo":
            self.settings.set_last_folder("volume", path)
        self._remember(path)
        self.sourceChanged.emit(source)
        self.preview.waiting_for_choice = None
        self.preview.set_inputs(source_path=path, printer=self._ensure_printer())
        if new:
            self.preview.set_choices(choices)

    def _source_failed(self, path: str, message: str) -> None:
        if path != self._source_request:
            return
        self._source_request = self.source_path  # the previous source stays
        if self.source is None:
            self.preview.show_waiting("no volume open")
        self._file_problem(gui_wording(message))
        self.openFailed.emit(path, message)

    def _ensure_printer(self):
        if self.printer is None:
            from dreamprint_gui.core.printer import DEFAULT_PRINTER, load_printer

            name = self.settings.get("export/printer", DEFAULT_PRINTER, str)
            try:
                self.printer = load_printer(name)
            except DreamPrintError:
                self.printer = load_printer(DEFAULT_PRINTER)
        return self.printer

    def set_printer(self, printer) -> None:
        """A printer with another layer thickness needs other tables (sigma is per layer)."""
        old = self._ensure_printer()
        self.printer = printer
        if self.gamut is not None:
            self.gamut.printer_name = printer.display_name
        if self.profile is not None and old.layer_thickness_mm != printer.layer_thickness_mm:
            self.tables = None
            self.preview.set_inputs(profile=self.profile, profile_path=self.profile_path,
                                    printer=printer)
            self._build_tables(self.profile)
        else:
            self.preview.set_inputs(printer=printer)

    def use_default_profile(self) -> None:
        from dreamprint_gui.core.profile import default_profile

        self.set_profile(default_profile(), None)

    def set_profile(self, profile, path: str | None) -> None:
        """Make ``profile`` active: rebuild (or fetch cached) tables, refresh every page."""
        self.profile, self.profile_path = profile, path
        self.tables = None
        self.profile_label.setText(f"Profile: {profile.name}")
        self.profileChanged.emit(profile)
        self.preview.set_inputs(profile=profile, profile_path=path)
        if self.gamut is not None:
            from dreamprint_gui.job.plan import profile_for_printer

            self.gamut.printer_name = self._ensure_printer().display_name
            self.gamut.set_profile(profile_for_printer(profile, self._ensure_printer()))
        self._build_tables(profile)

    def _build_tables(self, profile) -> None:
        if self._tables_task is not None and self._tables_task.outcome is None:
            self._tables_task.cancel()
        size = self.table_size
        # The tables of the job: the profile at the printer's layer thickness (the density
        # of eq. 9 is per layer), so the preview, the gamut page and the export share them.
        from dreamprint_gui.job.plan import profile_for_printer

        eff = profile_for_printer(profile, self._ensure_printer())

        def job(report, cancel):
            from dreamprint_gui.gamut import get_tables

            kwargs = {} if size is None else {"size": size}
            return get_tables(eff, progress=lambda f: report(float(f)), notify=report, **kwargs)

        task = Task(job, "tables")
        self._tables_for = profile.fingerprint()
        fp = self._tables_for
        task.progress.connect(self._tables_progress)
        task.succeeded.connect(lambda t, fp=fp: self._tables_done(t, fp))
        task.failed.connect(self._tables_failed)
        self.progress.setVisible(True)
        self.progress.setValue(0)
        self._say_waiting("loading the colour tables of the profile ...")
        self._tables_task = run_task(task)

    def _tables_progress(self, fraction: float | str) -> None:
        if isinstance(fraction, str):  # numba compiling the build's kernels (first use)
            self._say_waiting(fraction)
            return
        self.progress.setValue(int(100 * fraction))
        if fraction < 1.0:  # reported during a build only (a cached table loads in one go)
            text = (f"building the colour tables of the profile: {100 * fraction:.0f}% "
                    "(first start with this profile only; they are cached afterwards)")
            self._say_waiting(text)

    def _tables_done(self, tables, fingerprint: str) -> None:
        if fingerprint != self._tables_for:
            return  # a newer profile is being built
        self.progress.setVisible(False)
        self.tables = tables
        what = "loaded from the cache" if getattr(tables, "cached", False) else (
            f"built in {getattr(tables, 'build_seconds', 0):.1f} s")
        self.statusBar().showMessage(f"Colour tables {what}", 8000)
        self.tablesReady.emit(tables)
        self.preview.set_inputs(tables=tables)
        if self.gamut is not None:
            self.gamut.set_tables(tables)

    def _tables_failed(self, message: str, _tb: str) -> None:
        self.progress.setVisible(False)
        self.preview.show_waiting("no colour tables")
        self._file_problem(f"Cannot build the colour tables: {message}", "no colour tables")

    # actions ----------------------------------------------------------------------------------
    def calibration_wizard(self, calibration_set: str | None = None) -> None:
        from dreamprint_gui.gui.wizard.calibration import CalibrationWizard

        wiz = CalibrationWizard(self, settings=self.settings, calibration_set=calibration_set)
        wiz.profileSaved.connect(lambda prof, path: self.set_profile(prof, path))
        wiz.open()
        self._wizard = wiz

    def export_dialog(self) -> None:
        from dreamprint_gui.gui.export import ExportDialog

        if self.source is None or self.profile is None:
            QMessageBox.information(self, "DreamPrint", "Open a volume first.")
            return
        try:
            params = {**self.preview.params(), "source_options": self.preview.source_options()}
        except DreamPrintError as exc:
            self._file_problem(gui_wording(str(exc)), "cannot export")
            return
        dlg = ExportDialog(self, source_path=self.source_path, profile_path=self.profile_path,
                           settings=self.settings, preview_params=params,
                           source_name="demo" if self.source_path == "demo" else None,
                           table_size=self.table_size, context=self.preview.ctx)
        dlg.printerChanged.connect(self.set_printer)
        dlg.open()
        self._export = dlg

    def _show_log_path(self) -> None:
        from dreamprint_gui.gui.crash import log_file

        QMessageBox.information(self, "DreamPrint log", f"The log file is\n{log_file()}")

    def _about(self) -> None:
        from importlib.metadata import PackageNotFoundError, version

        try:
            v = version("dreamprint")
        except PackageNotFoundError:
            v = "development"
        QMessageBox.about(self, "About DreamPrint",
                          f"DreamPrint {v}\nRadiance volumes to full-colour PolyJet print jobs.")

    # drag and drop ----------------------------------------------------------------------------
    def dragEnterEvent(self, event: QDragEnterEvent) -> None:  # noqa: N802 - Qt override
        if event.mimeData().hasUrls() and any(u.isLocalFile() for u in event.mimeData().urls()):
            event.acceptProposedAction()

    def dropEvent(self, event: QDropEvent) -> None:  # noqa: N802 - Qt override
        for url in event.mimeData().urls():
            if url.isLocalFile():
                self.open_path(url.toLocalFile())
        event.acceptProposedAction()

    # state ------------------------------------------------------------------------------------
    def closeEvent(self, event) -> None:  # noqa: N802 - Qt override
        self.settings.save_window_state(self.saveGeometry(), self.saveState())
        for k, v in self.preview.params().items():
            if k not in ("content", "sampling", "up", "rotate"):  # per source: each starts on auto
                self.settings.set(f"preview/{k}", v)
        self.settings.sync()
        from dreamprint_gui.gui.workers import wait_all

        for task in (self._tables_task, self._source_task):
            if task is not None:
                task.cancel()
        self.preview.shutdown()
        if self.gamut is not None:
            self.gamut.shutdown()
        wait_all(10000)
        super().closeEvent(event)
