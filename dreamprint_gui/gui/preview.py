"""The preview page: the source and the predicted print side by side, cameras linked.

Defines :class:`PreviewPage`. Left: the source sampled on a downsampled grid at the operator's
physical size (a voxel model sampled and drawn nearest, so its voxels stay sharp); right: each
voxel's colour and density as the engine predicts them after table lookup and density alignment
(``gamut.predicted_appearance``), so washed-out or too-opaque regions show before printing; the
footnote under them says how the preview grid relates to the print's. Controls: physical height,
density scale, background (Clear resin or nothing), content intent (auto, fog or solid:
``job.content``, with what auto picked and why), voxel edges of voxel models (sharp or
smooth), and a slice scrubber showing the halftoned material labels of any printer layer
(``job.slab.halftone_layer``) at full resolution with zoom and pan (:mod:`.layer_view`), in the
slice PNGs' own colour codes (:mod:`.materials`). The engine's pre-flight of the job
(``job.preflight``) runs after each preview; its warnings show in the Warnings box. Sampling,
prediction, halftoning and the pre-flight run on worker threads (:mod:`.workers`); the page
only draws. Problems go to the main window (signals :attr:`PreviewPage.failed` and
:attr:`PreviewPage.problem`), which says each once. Its 3D view is created when there is first
something to draw (:class:`.volume_view.ViewHost`); until then it says what is being prepared.
"""

from __future__ import annotations

import logging
import time
from html import escape
from pathlib import Path

import numpy as np
from PySide6.QtCore import Qt, QTimer, Signal
from PySide6.QtGui import QImage
from PySide6.QtWidgets import (
    QComboBox,
    QDoubleSpinBox,
    QFormLayout,
    QFrame,
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QProgressBar,
    QScrollArea,
    QSlider,
    QSplitter,
    QTabWidget,
    QVBoxLayout,
    QWidget,
)

from dreamprint_gui.gui.layer_view import LayerView, MaterialLegend
from dreamprint_gui.gui.names import (
    BACKGROUNDS,
    CONTENTS,
    LEVEL_SETS,
    SAMPLINGS,
    gui_wording,
    printer_name,
)
from dreamprint_gui.gui.preview_data import PreviewData, compute_preview, estimated_context
from dreamprint_gui.gui.volume_view import ViewHost, add_rgba_volume
from dreamprint_gui.gui.workers import Task, run_task

__all__ = ["PreviewPage"]

log = logging.getLogger(__name__)


class PreviewPage(QWidget):
    """Source vs predicted print, with the controls that change the print."""

    rendered = Signal()  # both views drawn with current data
    failed = Signal(str)  # the preview could not be computed (the window says it, once)
    problem = Signal(str)  # something that stops nothing failed (a layer); said by the window
    paramsChanged = Signal()
    # the operator changed how the file is read (grid, level set, reader options): the window
    # opens it again with them
    interpretationChanged = Signal()
    preflightReady = Signal(object)  # the engine's Preflight of the current settings

    def __init__(self, parent: QWidget | None = None, table_size: int | None = None) -> None:
        super().__init__(parent)
        self.source_path: str | None = None
        self.profile = None  # the active InkProfile
        self.profile_path: str | None = None  # its file (None: the built-in one)
        self.tables = None
        self.printer = None
        self.ctx = None  # the engine's JobContext of the current settings
        self.table_size = table_size
        self.data: PreviewData | None = None
        self.slice_labels: np.ndarray | None = None
        self.slice_image: QImage | None = None
        self.shown_layer: int | None = None  # the layer the layer view shows
        self._task: Task | None = None
        self._slice_task: Task | None = None
        self._preflight_task: Task | None = None
        self._framing = None  # (source, size) the 3D camera was last framed for
        self._pending = False
        self._slice_pending = False
        self._await_slice = False

        self.view = ViewHost(self, (1, 2), "preparing the preview ...")

        self.height_mm = QDoubleSpinBox(suffix=" mm", decimals=1, minimum=1.0, maximum=500.0,
                                        value=40.0, singleStep=5.0)
        self.height_mm.setToolTip("Physical height of the print (z); x and y keep the aspect")
        self.density_scale = QDoubleSpinBox(decimals=3, minimum=0.001, maximum=1000.0,
                                            value=1.0, singleStep=0.1)
        self.density_scale.setToolTip("Multiplies the source's density (1/mm per source unit)")
        self.background = QComboBox()
        for key, name, tip in BACKGROUNDS:
            self.background.addItem(name, key)
            self.background.setItemData(self.background.count() - 1, tip,
                                        Qt.ItemDataRole.ToolTipRole)
        self.background.setToolTip("What voxels below the density threshold become: Clear "
                                   "resin, or no material at all")
        self.content = QComboBox()
        for key, name, tip in CONTENTS:
            self.content.addItem(name, key)
            self.content.setItemData(self.content.count() - 1, tip,
                                     Qt.ItemDataRole.ToolTipRole)
        self.content.setToolTip("What the source's density means: a fog (as stated) or a "
                                "solid object (occupied voxels print opaque)")
        self.content_note = QLabel("")  # what auto picked, and why
        self.content_note.setWordWrap(True)
        self.content_note.setObjectName("contentNote")
        self.sampling = QComboBox()
        for key, name, tip in SAMPLINGS:
            self.sampling.addItem(name, key)
            self.sampling.setItemData(self.sampling.count() - 1, tip,
                                      Qt.ItemDataRole.ToolTipRole)
        self.sampling.setToolTip("Voxel models: sharp voxel edges (nearest) or smooth "
                                 "(trilinear); other sources are always smooth")
        self.sampling.setEnabled(False)
        # How the file is read (the CLI's --option): shown for files that offer the choice
        self.grid = QComboBox()
        self.grid.setToolTip("Which of the file's scalar grids is the density "
                             "(--option grid=NAME)")
        self.level_set = QComboBox()
        for key, name, tip in LEVEL_SETS:
            self.level_set.addItem(name, key)
            self.level_set.setItemData(self.level_set.count() - 1, tip,
                                       Qt.ItemDataRole.ToolTipRole)
        self.level_set.setToolTip("How a level set (a surface) is printed: filled, or as a "
                                  "hollow shell (--option level_set=solid / shell)")
        self.shell_voxels = QDoubleSpinBox(decimals=1, minimum=0.5, maximum=50.0, value=1.0,
                                           singleStep=0.5, suffix=" file voxels")
        self.shell_voxels.setToolTip("Thickness of the shell's wall, in voxels of the file "
                                     "(--option shell_voxels=W)")
        self.reader_options = QLineEdit()
        self.reader_options.setPlaceholderText("KEY=VALUE, ...")
        self.reader_options.setToolTip("Further options of the file's reader, as the command "
                                       "line's --option KEY=VALUE (comma-separated)")
        self._interpretation_rows = (self.grid, self.level_set, self.shell_voxels,
                                     self.reader_options)
        self.waiting_for_choice: str | None = None  # the problem a choice must solve
        from dreamprint_gui.gui.export import placement_combos

        self.up, self.turn, self.fit = placement_combos()
        self.placement_note = QLabel("")  # how the print stands and what it measures
        self.placement_note.setWordWrap(True)
        self.placement_note.setObjectName("contentNote")
        self.status = QLabel("no source")
        self.status.setWordWrap(True)
        # the preview's computation: busy while preparing, the fraction while predicting
        self.busy = QProgressBar(minimum=0, maximum=0)
        self.busy.setTextVisible(False)
        self.busy.setMaximumHeight(10)
        self.busy.setVisible(False)
        self._wait: dict | None = None
        self._wait_clock = QTimer(self, interval=500)
        self._wait_clock.timeout.connect(self._tick_wait)
        # The footnote of the 3D views (preview grid, downsampling) in the application's font,
        # under the views.
        self.note = QLabel("")
        self.note.setWordWrap(True)
        self.note.setObjectName("downsampleNote")
        self.note.setContentsMargins(6, 2, 6, 2)

        form = QFormLayout()
        form.addRow("Height", self.height_mm)
        form.addRow("Density scale", self.density_scale)
        form.addRow("Background", self.background)
        form.addRow("Content", self.content)
        form.addRow("", self.content_note)
        form.addRow("Voxel edges", self.sampling)
        form.setRowVisible(self.sampling, False)  # shown for sources that offer the choice
        form.addRow("Up", self.up)
        form.addRow("Turn", self.turn)
        form.addRow("Size of", self.fit)
        form.addRow("", self.placement_note)
        form.addRow("Grid", self.grid)
        form.addRow("Level set", self.level_set)
        form.addRow("Wall", self.shell_voxels)
        form.addRow("Reader options", self.reader_options)
        for w in self._interpretation_rows:
            form.setRowVisible(w, False)  # shown for files that offer the choice
        self.form = form
        box = QGroupBox("Print")
        box.setLayout(form)

        self.slice_slider = QSlider(Qt.Orientation.Horizontal)
        self.slice_slider.setEnabled(False)
        self.slice_label = QLabel("layer -")
        self.slice_view = LayerView()
        self.legend = MaterialLegend()
        # The printer's layers at full resolution: scrubber on top, the layer with zoom and
        # pan, its materials listed beside it (one per line: the legend never wraps).
        layers = QWidget()
        ll = QVBoxLayout(layers)
        top = QHBoxLayout()
        top.addWidget(QLabel("Layer"))
        top.addWidget(self.slice_slider, 1)
        top.addWidget(self.slice_label)
        ll.addLayout(top)
        body = QHBoxLayout()
        body.addWidget(self.slice_view, 1)
        legend_col = QVBoxLayout()
        legend_col.addWidget(QLabel("<b>Materials of this layer</b><br>(slice file codes; "
                                    "Clear shown<br>light blue for legibility)"))
        legend_col.addWidget(self.legend)
        legend_col.addStretch(1)
        body.addLayout(legend_col)
        ll.addLayout(body, 1)

        side = QWidget()
        side_l = QVBoxLayout(side)
        # Pre-flight warnings of the job these settings make (job.preflight), shown here
        # only (hidden when there are none).
        self.warnings = QLabel("")
        self.warnings.setWordWrap(True)
        self.warnings.setObjectName("preflightWarnings")
        self.warnings.setTextFormat(Qt.TextFormat.RichText)
        self.warnings_box = QGroupBox("Warnings")
        wl = QVBoxLayout(self.warnings_box)
        wl.addWidget(self.warnings)
        self.warnings_box.setVisible(False)
        self.preflight = None  # the engine's Preflight of the shown settings
        side_l.addWidget(box)
        side_l.addWidget(self.status)
        side_l.addWidget(self.busy)
        side_l.addWidget(self.warnings_box)
        side_l.addStretch(1)
        side.setMinimumWidth(280)
        # The controls and warnings scroll when they outgrow the window (a file with reader
        # choices and several warnings at 1280 x 800): nothing is cut off.
        self.side_scroll = QScrollArea()
        self.side_scroll.setWidgetResizable(True)
        self.side_scroll.setFrameShape(QFrame.Shape.NoFrame)
        self.side_scroll.setHorizontalScrollBarPolicy(Qt.ScrollBarPolicy.ScrollBarAlwaysOff)
        self.side_scroll.setWidget(side)
        self.side_scroll.setMinimumWidth(300)

        views = QWidget()
        vl = QVBoxLayout(views)
        vl.setContentsMargins(0, 0, 0, 0)
        vl.setSpacing(0)
        vl.addWidget(self.view, 1)
        vl.addWidget(self.note)

        self.pages = QTabWidget()
        self.pages.addTab(views, "Source and predicted print (3D)")
        self.pages.addTab(layers, "Printer layers (halftoned, full resolution)")

        split = QSplitter()
        split.addWidget(self.pages)
        split.addWidget(self.side_scroll)
        split.setStretchFactor(0, 4)
        split.setStretchFactor(1, 1)
        lay = QHBoxLayout(self)
        lay.setContentsMargins(0, 0, 0, 0)
        lay.addWidget(split)

        self._debounce = QTimer(self, singleShot=True, interval=300)
        self._debounce.timeout.connect(self.recompute)
        self._slice_debounce = QTimer(self, singleShot=True, interval=120)
        self._slice_debounce.timeout.connect(self._compute_slice)
        for w in (self.height_mm, self.density_scale):
            w.valueChanged.connect(self._params_changed)
        for w in (self.background, self.content, self.sampling, self.up, self.turn, self.fit):
            w.currentIndexChanged.connect(self._params_changed)
        for w in (self.grid, self.level_set):
            w.currentIndexChanged.connect(self._interpretation_changed)
        self.shell_voxels.valueChanged.connect(self._interpretation_changed)
        self.reader_options.editingFinished.connect(self._interpretation_changed)
        self.slice_slider.valueChanged.connect(lambda _v: self._slice_moved())

    @property
    def plotter(self):
        """The two linked 3D views (created on first use)."""
        return self.view.plotter

    def show_waiting(self, text: str) -> None:
        """Say what the preview is waiting for: in the view until it has drawn, then below
        the controls (one place at a time)."""
        if self.data is None:
            self.view.set_message(text)
            self.status.setText("")
        else:
            self.status.setText(text)

    # inputs -----------------------------------------------------------------------------------
    def params(self) -> dict:
        return {"height_mm": float(self.height_mm.value()),
                "density_scale": float(self.density_scale.value()),
                "background": str(self.background.currentData()),
                "content": str(self.content.currentData()),
                "sampling": self.sampling.currentData() if self.sampling.isEnabled() else None,
                "up": str(self.up.currentData()), "rotate": int(self.turn.currentData()),
                "fit": str(self.fit.currentData())}

    def source_options(self) -> dict:
        """The reader options the controls ask for (the CLI's ``--option``s): Reader options,
        then Grid and Level set (a control shown for the file wins over the text). Raises
        DreamPrintError for Reader options that are not KEY=VALUE."""
        from dreamprint_gui.io.volumes.registry import parse_reader_options

        opts = parse_reader_options(self.reader_options.text())
        if self.form.isRowVisible(self.grid) and self.grid.currentData() is not None:
            opts["density_grid"] = str(self.grid.currentData())
        if self.form.isRowVisible(self.level_set) and self.level_set.currentData() is not None:
            opts["level_set"] = str(self.level_set.currentData())
            if opts["level_set"] == "shell":
                opts["shell_voxels"] = float(self.shell_voxels.value())
        return opts

    def set_choices(self, choices: dict | None) -> None:
        """Show the interpretation controls a file offers
        (``io.volumes.registry.interpretation_choices``), values unchanged."""
        c = choices or {}
        self.grid.blockSignals(True)
        keep = self.grid.currentData()
        self.grid.clear()
        self.grid.addItem("Auto (the reader's choice)", None)
        for name in c.get("grids", []):
            self.grid.addItem(name, name)
        i = self.grid.findData(keep)
        self.grid.setCurrentIndex(max(i, 0))
        self.grid.blockSignals(False)
        self.form.setRowVisible(self.grid, bool(c.get("grids")))
        self.form.setRowVisible(self.level_set, bool(c.get("level_set")))
        self._shell_row()
        self.form.setRowVisible(self.reader_options, bool(c.get("options")))

    def _shell_row(self) -> None:
        self.form.setRowVisible(self.shell_voxels, self.form.isRowVisible(self.level_set)
                                and self.level_set.currentData() == "shell")

    def hold_for_choice(self, message: str) -> None:
        """The file cannot be read as it is: say why (in the GUI's words) and wait for a
        choice of the controls above instead of computing a preview that would fail again."""
        self.waiting_for_choice = message
        self.show_waiting(gui_wording(message))

    def _interpretation_changed(self, *_args) -> None:
        """The window opens the file again with the new choice, then hands it back here
        (:meth:`set_inputs`), which recomputes; a problem comes back as :meth:`hold_for_choice`."""
        self._shell_row()
        self.paramsChanged.emit()
        self.interpretationChanged.emit()

    _KEEP = object()

    def set_params(self, height_mm: float | None = None, density_scale: float | None = None,
                   background: str | None = None, content: str | None = None,
                   sampling=_KEEP, up: str | None = None, rotate: int | None = None,
                   fit: str | None = None) -> None:
        for combo, value in ((self.up, up), (self.turn, rotate), (self.fit, fit)):
            if value is not None:
                i = combo.findData(value)
                if i >= 0:
                    combo.setCurrentIndex(i)
        if height_mm is not None:
            self.height_mm.setValue(height_mm)
        if density_scale is not None:
            self.density_scale.setValue(density_scale)
        for combo, value in ((self.background, background), (self.content, content)):
            if value is not None:
                i = combo.findData(value)
                if i >= 0:
                    combo.setCurrentIndex(i)
        if sampling is not self._KEEP:
            i = self.sampling.findData(sampling)
            if i >= 0:
                self.sampling.setCurrentIndex(i)

    def _new_source(self, path: str) -> None:
        """A new source starts on auto content and its reader's own sampling; the voxel-edge
        choice is offered only for sources that have one (voxel models)."""
        from dreamprint_gui.io.volumes.registry import reader_options

        try:
            takes = reader_options(path)
        except Exception:  # noqa: BLE001 - an unreadable file is reported when opened
            takes = set()
        for combo in (self.content, self.sampling, self.up, self.turn, self.grid,
                      self.level_set):
            combo.blockSignals(True)
            combo.setCurrentIndex(0)  # each file starts on auto content, auto up, no turn
            combo.blockSignals(False)
        self.reader_options.blockSignals(True)
        self.reader_options.setText("")  # and is read as its reader reads it by default
        self.reader_options.blockSignals(False)
        self.set_choices(None)
        self.sampling.setEnabled("sampling" in takes)
        self.form.setRowVisible(self.sampling, "sampling" in takes)
        self.content_note.setText("")
        self.placement_note.setText("")

    _UNSET = object()

    def set_inputs(self, source_path: str | None = None, profile=None,
                   profile_path=_UNSET, printer=None, tables=None) -> None:
        """Set what changed and recompute once the source, profile and tables are known.

        ``tables`` is the main window's signal that the profile's colour tables are built (and
        cached on disk), so the job context below loads them instead of building them twice.
        """
        if source_path is not None:
            if source_path != self.source_path:
                self._new_source(source_path)
            self.source_path = source_path
        if profile is not None:
            self.profile = profile
            self.tables = None  # tables belong to a profile
        if profile_path is not self._UNSET:
            self.profile_path = profile_path
        if tables is not None:
            self.tables = tables
        if printer is not None:
            self.printer = printer
        if self.ready_to_compute():
            self.recompute()
        elif self.source_path is not None and self.tables is None:
            self.show_waiting("waiting for the colour tables of the profile ...")

    def ready_to_compute(self) -> bool:
        return (self.source_path is not None and self.waiting_for_choice is None
                and self.profile is not None
                and self.tables is not None and self.printer is not None)

    def _params_changed(self) -> None:
        self.paramsChanged.emit()
        self._debounce.start()

    # computation ------------------------------------------------------------------------------
    def job_settings(self, output=None):
        """The job settings the export would use with the current controls."""
        from dreamprint_gui.gui.export_data import convert_settings

        p = self.params()
        return convert_settings(self.source_path, self.profile_path, self.printer,
                                height_mm=p["height_mm"], density_scale=p["density_scale"],
                                background=p["background"], output=output,
                                table_size=self.table_size, content=p["content"],
                                sampling=p["sampling"], up=p["up"], rotate=p["rotate"],
                                fit=p["fit"], source_options=self.source_options())

    def recompute(self) -> None:
        if not self.ready_to_compute():
            return
        if self._task is not None and self._task.outcome is None:
            self._pending = True  # one at a time; the latest settings win
            self._task.cancel()
            return
        try:
            settings = self.job_settings()
        except Exception as exc:  # noqa: BLE001 - shown inline
            self._failed(gui_wording(str(exc)), "")
            return
        previous = self.ctx
        profile = self.profile.with_settings(
            layer_thickness_mm=self.printer.layer_thickness_mm)  # as the job's tables

        def job(report, cancel):
            report(("prepare", None))
            ctx, _, _ = estimated_context(settings, previous,
                                          lambda line: report(("prepare", line)))
            report(("predict", 0.0))
            return ctx, compute_preview(
                ctx, profile, progress=lambda f: report(("predict", float(f))), cancel=cancel)

        name = Path(str(self.source_path)).name
        self._wait = {"name": name, "stage": "prepare", "fraction": None,
                      "t0": time.monotonic(), "first": previous is None}
        task = Task(job, "preview")
        task.progress.connect(self._preview_progress)
        task.succeeded.connect(self._show)
        task.failed.connect(self._failed)
        task.done.connect(self._task_done)
        self._task = run_task(task)
        self.busy.setRange(0, 0)
        self.busy.setVisible(True)
        self._tick_wait()
        self._wait_clock.start()

    def _preview_progress(self, update) -> None:
        stage, fraction = update
        if isinstance(fraction, str):   # preparing: the estimate, said before it starts
            self._wait.update(stage=stage, estimate=fraction)
            fraction = None
        else:
            self._wait.update(stage=stage, fraction=fraction)
        if fraction is None:
            self.busy.setRange(0, 0)   # no fraction to tell: a busy bar and the seconds
        else:
            self.busy.setRange(0, 100)
            self.busy.setValue(int(100 * fraction))
        self._tick_wait()

    def wait_text(self) -> str:
        """What the preview is doing, with the seconds it has taken so far."""
        w = self._wait
        secs = f"{time.monotonic() - w['t0']:.0f} s"
        if w["stage"] == "prepare":
            est = w.get("estimate")
            if est:   # "preparing: about N s (the source ... ; the colour tables ...)"
                return f"preparing {w['name']}: {est.removeprefix('preparing: ')} ... {secs}"
            return f"preparing {w['name']}: opening it, the colour tables ... {secs}"
        pct = f"{100 * (w['fraction'] or 0.0):.0f}%"
        return f"sampling {w['name']} and predicting the print ... {pct}, {secs}"

    def _tick_wait(self) -> None:
        if self._wait is not None:
            self.show_waiting(self.wait_text())

    def _stop_wait(self) -> None:
        self._wait_clock.stop()
        self._wait = None
        self.busy.setVisible(False)

    def _task_done(self) -> None:
        if not self._pending:
            self._stop_wait()
        if self._pending:
            self._pending = False
            self._task = None
            self.recompute()

    def _failed(self, message: str, _tb: str) -> None:
        self._stop_wait()
        self.show_waiting("no preview")  # the message itself: the window's status bar
        self.failed.emit(f"Preview failed: {gui_wording(message)}")

    def _show(self, result) -> None:
        if self._pending:
            return
        self._stop_wait()
        self.ctx, data = result
        self.data = data
        # The halftoned layer is computed on a worker while this thread draws the volumes.
        self._await_slice = True  # `rendered` once the halftoned layer is shown too
        self._setup_slider(at_once=True)
        pl = self.plotter
        first = not pl.renderers[0].actors
        # a voxel model sampled nearest is drawn with sharp voxels too (no blending between
        # the preview's voxels)
        sharp = getattr(self.ctx.source, "sampling", None) == "nearest"
        for i, (rgb, sigma, title) in enumerate((
                (data.source_rgb, data.source_sigma, "Source"),
                (data.print_rgb, data.print_sigma, "Predicted print"))):
            pl.subplot(0, i)
            add_rgba_volume(pl, rgb, sigma, data.voxel_mm, name=f"volume{i}",
                            interpolation="nearest" if sharp else "linear")
            box = _box(data.size_mm)
            pl.add_mesh(box, color="#888888", style="wireframe", name=f"box{i}",
                        reset_camera=False, line_width=1, render=False)
            pl.add_text(title, position="upper_left", font_size=10, name=f"title{i}",
                        color="#e6e6e6", render=False)  # readable on the dark background
        framing = (self.source_path, tuple(round(v, 3) for v in data.size_mm))
        if first or framing != self._framing:  # a new source or size: frame it whole
            pl.subplot(0, 0)
            pl.view_isometric(render=False)
            pl.renderer.reset_camera(render=False)  # the plotter-level one always renders
        self._framing = framing
        pl.render()
        self.status.setText(self.size_text())
        self.note.setText(data.downsample_note())
        choice = self.ctx.content
        if choice is None:
            self.content_note.setText("")
        elif choice.picked:
            self.content_note.setText(f"auto: {choice.mode}, {choice.reason}")
        else:
            self.content_note.setText(choice.reason)
        place = self.ctx.placement_json()
        fit = place["fit"].get("mode", "box")
        self.placement_note.setText(
            f"{gui_wording(place['orientation_text'])}; height of "
            + ("the object" if fit == "occupied" else "the file's box"))
        self._start_preflight()
        if not self.slice_slider.isEnabled():
            self._emit_rendered()

    def size_text(self) -> str:
        """The print's size as `dreamprint inspect --height-mm` states it ("the print is":
        the bounds the grid covers, occupied or the declared box as ``--fit`` says, at the
        job's scale, two decimals), then the printer grid that holds it."""
        g = self.ctx.grid
        bounds = getattr(self.ctx, "fit_bounds", None) or self.ctx.source.bounds
        lo, hi = (np.asarray(b, dtype=np.float64) for b in bounds)
        obj = (hi - lo) * g.mm_per_unit
        nx, ny, nz = g.shape_xyz
        gx, gy, gz = g.size_mm
        return (f"{Path(str(self.source_path)).name}: print "
                + " x ".join(f"{v:.2f}" for v in obj)
                + f" mm on {printer_name(self.printer)}; its grid {nx} x {ny} x {nz} voxels, "
                f"{gx:.2f} x {gy:.2f} x {gz:.2f} mm")

    # pre-flight -------------------------------------------------------------------------------
    def _start_preflight(self) -> None:
        """The engine's pre-flight of the job these settings make, on a worker; its warnings
        are shown in the Warnings box (and only there)."""
        if self._preflight_task is not None and self._preflight_task.outcome is None:
            self._preflight_task.cancel()  # its result is ignored (ctx check below)
        ctx = self.ctx

        def job(report, cancel):
            from dreamprint_gui.job.preflight import preflight

            return ctx, preflight(ctx, seed=ctx.settings.seed)  # as the export's

        task = Task(job, "preflight")
        task.succeeded.connect(self._show_preflight)
        task.failed.connect(lambda msg, _tb: self.problem.emit(f"Pre-flight failed: {msg}"))
        self._preflight_task = run_task(task)

    def _show_preflight(self, result) -> None:
        ctx, pf = result
        if ctx is not self.ctx:
            return  # an estimate of earlier settings
        self.preflight = pf
        items = "".join(f"<li>{escape(gui_wording(w.message))}</li>" for w in pf.warnings)
        self.warnings.setText(f"<ul style='margin-left: -20px'>{items}</ul>" if items else "")
        self.warnings_box.setVisible(bool(pf.warnings))
        self.preflightReady.emit(pf)

    def _emit_rendered(self) -> None:
        self._await_slice = False
        self.rendered.emit()

    # slice scrubber ---------------------------------------------------------------------------
    def _setup_slider(self, at_once: bool = False) -> None:
        if self.data is None or self.data.print_shape_xyz is None:
            self.slice_slider.setEnabled(False)
            return
        nz = self.data.print_shape_xyz[2]
        keep = self.slice_slider.value() if self.slice_slider.isEnabled() else nz // 2
        self.slice_slider.blockSignals(True)
        self.slice_slider.setRange(0, nz - 1)
        self.slice_slider.setValue(min(keep, nz - 1))
        self.slice_slider.blockSignals(False)
        self.slice_slider.setEnabled(True)
        self._slice_moved(at_once)

    def layer_z_mm(self, layer: int) -> tuple[float, float]:
        """The bottom and top of printer layer ``layer`` above the build plate, in mm (layer 0
        is the first printed, each one layer thickness high)."""
        t = float(self.printer.voxel_mm[2]) if self.printer is not None else 0.0
        return layer * t, (layer + 1) * t

    def _layer_text(self, layer: int) -> str:
        nz = self.slice_slider.maximum() + 1
        z0, z1 = self.layer_z_mm(layer)
        return f"layer {layer} of {nz}, z {z0:.3f}-{z1:.3f} mm"

    def _slice_moved(self, at_once: bool = False) -> None:
        self.slice_label.setText(self._layer_text(self.slice_slider.value()))
        if at_once:  # new preview data: no dragging to wait for
            self._slice_debounce.stop()
            self._compute_slice()
        else:
            self._slice_debounce.start()

    def _compute_slice(self) -> None:
        if self.data is None or self.ctx is None:
            return
        if self._slice_task is not None and self._slice_task.outcome is None:
            self._slice_pending = True
            return
        layer = int(self.slice_slider.value())
        ctx = self.ctx

        def job(report, cancel):
            from dreamprint_gui.job.slab import halftone_layer

            return ctx, layer, np.asarray(halftone_layer(ctx.settings, layer, context=ctx))

        task = Task(job, "slice")
        task.succeeded.connect(self._show_slice)
        task.failed.connect(self._slice_failed)
        task.done.connect(self._slice_done)
        self._slice_task = run_task(task)

    def _slice_failed(self, message: str, _tb: str) -> None:
        self.legend.clear()
        self.slice_label.setText(f"layer {self.slice_slider.value()}: not available")
        self.problem.emit(f"Layer {self.slice_slider.value()} failed: {message}")
        if self._await_slice and not self._slice_pending:
            self._emit_rendered()

    def _slice_done(self) -> None:
        if self._slice_pending:
            self._slice_pending = False
            self._slice_task = None
            self._compute_slice()

    def _show_slice(self, result) -> None:
        ctx, layer, labels = result
        if ctx is not self.ctx or self._slice_pending:
            return  # a layer of earlier settings; the current one is on its way
        from dreamprint_gui.gui.materials import label_colours

        colours, names = label_colours(self.printer)
        self.slice_labels = labels
        rgb = colours[np.clip(labels, 0, len(colours) - 1)]
        h, w = labels.shape
        img = QImage(np.ascontiguousarray(rgb).data, w, h, 3 * w,
                     QImage.Format.Format_RGB888).copy()
        # Voxels are anisotropic (e.g. 84 x 28 um): scale to physical proportions.
        vx, vy = (self.printer.voxel_mm[0], self.printer.voxel_mm[1]) if self.printer else (1, 1)
        self.slice_image = img  # rows as in the slice PNG
        self.slice_view.set_layer(img, (vx, vy))
        counts = np.bincount(labels.ravel(), minlength=len(names))
        self.legend.set_counts(colours, names, counts)
        self.slice_label.setText(f"{self._layer_text(layer)} ({w} x {h} voxels)")
        self.shown_layer = layer
        if self._await_slice:
            self._emit_rendered()

    def shutdown(self) -> None:
        for t in (self._task, self._slice_task, self._preflight_task):
            if t is not None:
                t.cancel()
        self.view.close_view()


def _box(size_mm):
    import pyvista as pv

    sx, sy, sz = size_mm
    return pv.Box(bounds=(0, sx, 0, sy, 0, sz))
