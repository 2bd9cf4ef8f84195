"""The gamut page: printable gamut vs sRGB in CIELAB, the hexagon chart, a colour picker.

Defines :class:`GamutPage` and :class:`FittedImage` (an image drawn whole, scaled to fit its
widget). Left, two pages: a pyvista view with two linked cameras (the printable gamut of the
active profile, convex hull of predicted mixture colours, each vertex in its own colour; and the
sRGB gamut with the printable gamut as a wireframe inside it, the camera framing the sRGB solid
so that neither is cropped), and the paper's Fig. 7-style hexagon chart (target vs reproduced per
cell) drawn by the engine's ``gamut.charts.hexagon_chart`` on a worker thread; the axes are
named a*, b*, L*. Right, a colour picker: any colour (encoded sRGB 0-1, the scale of
``dreamprint lookup --rgb``) and optionally a density -> the voxel's six inks as ``dreamprint
lookup`` reports them (the table's C, M, Y, K, W, density-aligned with Clear; each share written
beside its bar), the colour the table prints
beside the requested one with their dE2000 and whether the requested colour is in gamut (the
engine's rule, ``evaluation.IN_GAMUT_DE2000``); both colours are marked in the 3D view. Below
it, the share of sRGB that is printable (the table nodes within that dE2000, as ``dreamprint
gamut`` reports it). An intent
selector (colorimetric / perceptual) above the picker chooses the rendering intent whose mapping
(source colour -> printed colour) the picker and the chart show: the window's tables when they
already have that intent, else that intent's tables (``gamut.get_tables``, cached on disk)
loaded or built on a worker.

"Export ICC profile" under the gamut views writes the ICC output profile of the active
profile's print under the intent shown (:class:`.icc_export.IccExportBox`, as ``dreamprint
icc``).

The page can be put on hold (:meth:`GamutPage.set_hold`): the main window holds it while the
preview starts up, so the two pages do not compete for the cores; and it draws into its 3D
view (created on first use) only while it is visible.
"""

from __future__ import annotations

import logging

from PySide6.QtCore import QRect, QSize, Qt, Signal
from PySide6.QtGui import QColor, QDoubleValidator, QImage, QPainter
from PySide6.QtWidgets import (
    QColorDialog,
    QComboBox,
    QDoubleSpinBox,
    QFormLayout,
    QGridLayout,
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QProgressBar,
    QPushButton,
    QSizePolicy,
    QSplitter,
    QTabWidget,
    QVBoxLayout,
    QWidget,
)

from dreamprint_gui.core.profile import INKS
from dreamprint_gui.gui.gamut_data import pick_colour, printable_gamut_mesh, srgb_gamut_mesh
from dreamprint_gui.gui.icc_export import IccExportBox, IccRequest
from dreamprint_gui.gui.names import INTENTS
from dreamprint_gui.gui.volume_view import ViewHost
from dreamprint_gui.gui.workers import Task, run_task

__all__ = ["GamutPage"]

log = logging.getLogger(__name__)


class FittedImage(QWidget):
    """An image drawn whole, as large as the widget allows (aspect kept, centred)."""

    def __init__(self, text: str, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.text = text
        self.image: QImage | None = None
        self.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Expanding)

    def sizeHint(self) -> QSize:  # noqa: N802 - Qt override
        return QSize(400, 300)

    def minimumSizeHint(self) -> QSize:  # noqa: N802 - Qt override
        return QSize(200, 150)

    def set_image(self, image: QImage | None) -> None:
        self.image = image
        self.update()

    def set_text(self, text: str) -> None:
        self.text = text
        self.update()

    def image_rect(self) -> QRect:
        """Where the image is drawn, in widget coordinates (empty without an image)."""
        if self.image is None or self.image.isNull():
            return QRect()
        box = self.contentsRect()
        size = self.image.size().scaled(box.size(), Qt.AspectRatioMode.KeepAspectRatio)
        return QRect(box.x() + (box.width() - size.width()) // 2,
                     box.y() + (box.height() - size.height()) // 2,
                     size.width(), size.height())

    def paintEvent(self, event) -> None:  # noqa: N802 - Qt override
        p = QPainter(self)
        r = self.image_rect()
        if r.isEmpty():
            p.drawText(self.rect(), Qt.AlignmentFlag.AlignCenter | Qt.TextFlag.TextWordWrap,
                       self.text)
        else:
            p.setRenderHint(QPainter.RenderHint.SmoothPixmapTransform, True)
            p.drawImage(r, self.image)
        p.end()


def _swatch_style(rgb) -> str:
    r, g, b = (int(round(255 * max(0.0, min(1.0, c)))) for c in rgb)
    return f"background: rgb({r},{g},{b}); border: 1px solid #555;"


class GamutPage(QWidget):
    """Gamut of the active profile, hexagon chart and colour picker."""

    rendered = Signal()
    picked = Signal(dict)
    chartReady = Signal()
    problem = Signal(str)  # a computation of the page failed (the window's status bar says it)

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.profile = None
        self.tables = None
        self.meshes = None
        self.last_pick: dict | None = None
        self._main_tables = None  # the window's tables (the preview's and export's)
        self._task: Task | None = None
        self._chart_task: Task | None = None
        self._intent_task: Task | None = None
        self._hold = False
        self._held: set[str] = set()  # work waiting for the hold to end: "meshes", "tables"
        self._draw_pending = False
        self._drawn = False

        self.view = ViewHost(self, (1, 2), "the printable gamut appears here once computed")

        # colour picker
        self.pick_button = QPushButton("Pick a colour...")
        self.pick_button.clicked.connect(self._pick_dialog)
        # encoded sRGB in 0-1, the scale of `dreamprint lookup --rgb R,G,B`
        self.spins = []
        rgb_row = QHBoxLayout()
        for ch, v in zip("RGB", (0.784, 0.471, 0.235), strict=True):
            s = QDoubleSpinBox(minimum=0.0, maximum=1.0, value=v, decimals=3, singleStep=0.01,
                               prefix=f"{ch} ")
            s.setToolTip("encoded sRGB from 0 to 1, as `dreamprint lookup --rgb R,G,B` takes it "
                         "(255 = 1.000)")
            s.valueChanged.connect(self._spins_changed)
            self.spins.append(s)
            rgb_row.addWidget(s)
        self.rgb_scale = QLabel("sRGB from 0 to 1, as <tt>dreamprint lookup --rgb</tt>")
        self.rgb_scale.setObjectName("rgbScale")
        self.rgb_scale.setWordWrap(True)
        self.density = QLineEdit()
        self.density.setPlaceholderText("the mixture's own")
        self.density.setValidator(QDoubleValidator(0.0, 1e6, 4))
        self.density.setToolTip("The voxel's density sigma in 1/mm, as `dreamprint lookup "
                                "--density`: a lower one mixes Clear into the voxel (empty: "
                                "the mixture's own density, no Clear)")
        self.density.editingFinished.connect(self._spins_changed)
        density_row = QFormLayout()
        density_row.addRow("Density (1/mm)", self.density)
        self.target_swatch = QLabel()
        self.repro_swatch = QLabel()
        for w in (self.target_swatch, self.repro_swatch):
            w.setMinimumSize(90, 60)
        self.repro_swatch.setToolTip("The colour the printer makes of the requested one: the "
                                     "colour table's ink mixture, as the model predicts it")
        sw = QGridLayout()
        self.repro_title = QLabel("printed (mapped)")
        sw.addWidget(QLabel("requested"), 0, 0, Qt.AlignmentFlag.AlignHCenter)
        sw.addWidget(self.repro_title, 0, 1, Qt.AlignmentFlag.AlignHCenter)
        sw.addWidget(self.target_swatch, 1, 0)
        sw.addWidget(self.repro_swatch, 1, 1)
        self.de_label = QLabel("dE2000 -")
        self.de_label.setObjectName("dE2000")
        self.de_label.setWordWrap(True)
        self.lab_label = QLabel("")
        self.lab_label.setWordWrap(True)
        # the voxel's six inks (Clear included), the share written beside each bar (never on
        # it, where the style overdraws the text with the bar's chunk)
        self.bars = {}
        self.bar_values = {}
        conc_form = QGridLayout()
        for row, ink in enumerate(INKS):
            bar = QProgressBar(minimum=0, maximum=1000, textVisible=False)
            bar.setMaximumHeight(14)
            value = QLabel("-")
            value.setAlignment(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)
            value.setMinimumWidth(value.fontMetrics().horizontalAdvance("100.0 %") + 4)
            self.bars[ink], self.bar_values[ink] = bar, value
            conc_form.addWidget(QLabel(ink), row, 0)
            conc_form.addWidget(bar, row, 1)
            conc_form.addWidget(value, row, 2)
        picker = QWidget()
        pl = QVBoxLayout(picker)
        pl.addWidget(self.pick_button)
        pl.addWidget(self.rgb_scale)
        pl.addLayout(rgb_row)
        pl.addLayout(density_row)
        pl.addLayout(sw)
        pl.addWidget(self.de_label)
        pl.addWidget(self.lab_label)
        cbox = QGroupBox("Inks of the voxel")
        cbox.setToolTip("The table's mixture for the colour, aligned to the density with "
                        "Clear, as `dreamprint lookup` reports it")
        cbox.setLayout(conc_form)
        pl.addWidget(cbox)
        # the printable share of sRGB (the table nodes in gamut, as `dreamprint gamut` says)
        self.fraction_label = QLabel("sRGB in gamut: - (colour tables not ready)")
        self.fraction_label.setObjectName("inGamutFraction")
        self.fraction_label.setWordWrap(True)
        gbox = QGroupBox("Printable share of sRGB")
        gl = QVBoxLayout(gbox)
        gl.addWidget(self.fraction_label)
        pl.addWidget(gbox)
        pl.addStretch(1)

        # hexagon chart (the engine draws it: gamut.charts.hexagon_chart)
        self.chart_view = FittedImage("the chart appears once the colour tables are ready")
        self.chart_image: QImage | None = None
        self.chart_stats: dict | None = None
        self.chart_status = QLabel("")
        self.chart_status.setWordWrap(True)
        chart = QWidget()
        cl = QVBoxLayout(chart)
        cl.addWidget(self.chart_view, 1)
        cl.addWidget(self.chart_status)

        # The footnote of the 3D views in the application's font, under them.
        self.axes_note = QLabel("CIELAB (D65): a* to the right, b* to the back, L* up; "
                                "grey = the achromatic axis at a* = b* = 0")
        self.axes_note.setWordWrap(True)
        self.axes_note.setContentsMargins(6, 2, 6, 2)
        solids = QWidget()
        sl = QVBoxLayout(solids)
        sl.setContentsMargins(0, 0, 0, 0)
        sl.setSpacing(0)
        sl.addWidget(self.view, 1)
        sl.addWidget(self.axes_note)

        # the large views on the left (3D solids, hexagon chart), the picker on the right
        self.pages = QTabWidget()
        self.pages.addTab(solids, "CIELAB gamut")
        self.pages.addTab(chart, "Hexagon chart")
        self.intent = QComboBox()
        for key, name, tip in INTENTS:
            self.intent.addItem(name, key)
            self.intent.setItemData(self.intent.count() - 1, tip, Qt.ItemDataRole.ToolTipRole)
        self.intent.setToolTip("Rendering intent: how colours outside the printable gamut "
                               "are mapped; the picker and the chart show its mapping")
        self.intent.currentIndexChanged.connect(self._intent_changed)
        intent_row = QFormLayout()
        intent_row.addRow("Rendering intent", self.intent)
        # the ICC profile of this profile's print under the intent shown (issue 48)
        self.printer_name = ""  # the main window's printer, named in the ICC description
        self.icc = IccExportBox(self._icc_request, getattr(parent, "settings", None), self,
                                horizontal=True)
        self.icc.setContentsMargins(6, 2, 6, 2)
        left = QWidget()
        ll = QVBoxLayout(left)
        ll.setContentsMargins(0, 0, 0, 0)
        ll.addWidget(self.pages, 1)
        ll.addWidget(self.icc)
        right = QWidget()
        rl = QVBoxLayout(right)
        rl.addLayout(intent_row)
        rl.addWidget(QLabel("<b>Colour picker</b>"))
        rl.addWidget(picker, 1)
        right.setMinimumWidth(300)

        split = QSplitter()
        split.addWidget(left)
        split.addWidget(right)
        split.setStretchFactor(0, 3)
        split.setStretchFactor(1, 1)
        lay = QHBoxLayout(self)
        lay.setContentsMargins(0, 0, 0, 0)
        lay.addWidget(split)
        self._spins_changed()

    def _icc_request(self) -> IccRequest | None:
        """The active profile's print under the intent shown, for "Export ICC profile"."""
        if self.profile is None:
            return None
        want = str(self.intent.currentData())
        tables = self.tables if getattr(self.tables, "intent", None) == want else None
        main = self._main_tables
        return IccRequest(self.profile, tables, want, None if main is None else main.size,
                          self.printer_name)

    @property
    def plotter(self):
        """The two linked 3D views (created on first use)."""
        return self.view.plotter

    @property
    def drawn(self) -> bool:
        """The 3D view shows the current profile's gamut."""
        return self._drawn

    def set_hold(self, hold: bool) -> None:
        """While held, the page only records its inputs; the work starts when released."""
        self._hold = hold
        if hold:
            return
        held, self._held = self._held, set()
        tables = self.tables  # set_profile forgets them (tables belong to a profile)
        if "meshes" in held and self.profile is not None:
            self.set_profile(self.profile)
        if "tables" in held and tables is not None:
            self.set_tables(tables)

    # inputs -----------------------------------------------------------------------------------
    def set_profile(self, profile) -> None:
        self.profile = profile
        self.tables = None
        self.meshes = None
        self._held.discard("tables")
        if self._hold:
            self._held.add("meshes")
            self.view.set_message("the printable gamut is computed once the preview is ready")
            return
        self.view.set_message("computing the printable gamut ...")

        def job(report, cancel):
            return printable_gamut_mesh(profile), srgb_gamut_mesh(profile)

        if self._task is not None:
            self._task.cancel()
        task = Task(job, "gamut-mesh")
        task.succeeded.connect(lambda m, p=profile: self._show_meshes(m, p))
        task.failed.connect(lambda msg, _tb: self._failed("The printable gamut", msg))
        self._task = run_task(task)

    def _failed(self, what: str, message: str) -> None:
        self.view.set_message(f"{what}: not available")
        self.problem.emit(f"{what} failed: {message}")

    def set_tables(self, tables) -> None:
        self.tables = tables
        self._main_tables = tables
        if self._hold:
            self._held.add("tables")
            return
        self._show_fraction()
        self._intent_changed()

    def set_intent(self, intent: str) -> None:
        """Show the mapping of rendering intent ``intent`` (an id of :data:`.names.INTENTS`)."""
        self.intent.setCurrentIndex(self.intent.findData(intent))

    def _intent_changed(self) -> None:
        main, want = self._main_tables, str(self.intent.currentData())
        self.repro_title.setText(f"printed ({want})")
        if main is None or self.profile is None or self._hold:
            return
        if getattr(main, "intent", "colorimetric") == want:
            self._apply_tables(main)
            return
        profile, objective, size = self.profile, main.objective, main.size

        def job(report, cancel):
            from dreamprint_gui.gamut import get_tables

            return get_tables(profile, objective, size, intent=want,
                              progress=lambda f: report(float(f)), notify=report)

        if self._intent_task is not None:
            self._intent_task.cancel()
        self.chart_status.setText(f"loading the {want} colour tables ...")
        self.de_label.setText(f"dE2000 - (loading the {want} colour tables)")
        task = Task(job, "intent-tables")
        # numba compiling the build's kernels (first use): its announcement and heartbeat
        task.progress.connect(lambda m: self.chart_status.setText(m) if isinstance(m, str)
                              else None)
        task.succeeded.connect(lambda t, w=want, p=profile: self._intent_ready(t, w, p))
        task.failed.connect(lambda msg, _tb: self._failed(f"The {want} colour tables", msg))
        self._intent_task = run_task(task)

    def _intent_ready(self, tables, intent: str, profile) -> None:
        if profile is self.profile and intent == self.intent.currentData():
            self._apply_tables(tables)

    def _apply_tables(self, tables) -> None:
        self.tables = tables
        self._spins_changed()
        self._draw_chart()

    def in_gamut_fraction(self) -> float | None:
        """Share of the table's sRGB nodes printable within ``IN_GAMUT_DE2000``."""
        import numpy as np

        from dreamprint_gui.gamut.evaluation import IN_GAMUT_DE2000

        if self.tables is None:
            return None
        de = np.asarray(self.tables.dE2000, dtype=np.float64).ravel()
        return float(np.mean(de <= IN_GAMUT_DE2000))

    def _show_fraction(self) -> None:
        from dreamprint_gui.gamut.evaluation import IN_GAMUT_DE2000

        f = self.in_gamut_fraction()
        if f is None:
            self.fraction_label.setText("sRGB in gamut: - (colour tables not ready)")
            return
        self.fraction_label.setText(
            f"<b>{100 * f:.0f} %</b> of sRGB is printable (reproduced within dE2000 "
            f"{IN_GAMUT_DE2000:g}, over the colour table's {self.tables.size}<sup>3</sup> "
            "nodes); the rest prints as its nearest printable colour")

    # 3D view ----------------------------------------------------------------------------------
    def _show_meshes(self, meshes, profile) -> None:
        if profile is not self.profile:
            return
        self.meshes = meshes
        self._drawn = False
        if not self.isVisible():  # drawn when the page is first shown
            self._draw_pending = True
            return
        self._draw()

    def showEvent(self, event) -> None:  # noqa: N802 - Qt override
        super().showEvent(event)
        if self._draw_pending and self.meshes is not None:
            self._draw()

    def _draw(self) -> None:
        self._draw_pending = False
        profile, meshes = self.profile, self.meshes
        printable, srgb = (m.to_pyvista() for m in meshes)
        pl = self.plotter
        pl.subplot(0, 0)
        pl.add_mesh(printable, scalars="rgb", rgb=True, name="printable", smooth_shading=True,
                    render=False)
        pl.add_text(f"Printable gamut ({profile.name})", font_size=10, name="t0", render=False)
        pl.add_axes(xlabel="a*", ylabel="b*", zlabel="L*")
        pl.subplot(0, 1)
        pl.add_mesh(srgb, scalars="rgb", rgb=True, name="srgb", opacity=0.55,
                    render=False)
        pl.add_mesh(printable, color="white", style="wireframe", name="printable_wire",
                    line_width=1, opacity=0.6, render=False)
        pl.add_text("sRGB gamut, printable as wireframe", font_size=10, name="t1",
                    render=False)
        pl.add_axes(xlabel="a*", ylabel="b*", zlabel="L*")
        pl.subplot(0, 0)
        pl.view_isometric(render=False)
        # The cameras are linked: frame the larger solid (sRGB, which holds most of the
        # printable one) so that neither view crops its solid.
        lo = [min(a, b) for a, b in zip(srgb.bounds[::2], printable.bounds[::2], strict=True)]
        hi = [max(a, b) for a, b in zip(srgb.bounds[1::2], printable.bounds[1::2], strict=True)]
        bounds = [v for pair in zip(lo, hi, strict=True) for v in pair]
        pl.renderer.reset_camera(bounds=bounds, render=False)  # the plotter's always renders
        self._drawn = True
        self._mark_pick()
        pl.render()
        self.rendered.emit()

    def _mark_pick(self) -> None:
        if self.last_pick is None or not self._drawn:
            return
        import pyvista as pv

        pl = self.plotter
        t = self.last_pick["target_Lab"]
        r = self.last_pick["Lab"]
        for i in (0, 1):
            pl.subplot(0, i)
            pl.add_mesh(pv.Sphere(radius=3.0, center=(t[1], t[2], t[0])),
                        color=self.last_pick["rgb"], name=f"target{i}", reset_camera=False,
                        render=False)
            pl.add_mesh(pv.Cube(center=(r[1], r[2], r[0]), x_length=5, y_length=5, z_length=5),
                        color=[max(0.0, min(1.0, c)) for c in self.last_pick["sRGB"]],
                        name=f"repro{i}", reset_camera=False, render=False)
            pl.add_mesh(pv.Line((t[1], t[2], t[0]), (r[1], r[2], r[0])), color="white",
                        name=f"link{i}", reset_camera=False, line_width=2, render=False)
        pl.render()

    # colour picker ----------------------------------------------------------------------------
    def _pick_dialog(self) -> None:
        r, g, b = (int(round(255 * s.value())) for s in self.spins)
        colour = QColorDialog.getColor(QColor(r, g, b), self, "Colour to reproduce")
        if colour.isValid():
            self.set_colour((colour.red() / 255, colour.green() / 255, colour.blue() / 255))

    def set_colour(self, rgb) -> None:
        for s, v in zip(self.spins, rgb, strict=True):
            s.blockSignals(True)
            s.setValue(float(v))
            s.blockSignals(False)
        self._spins_changed()

    def density_value(self) -> float | None:
        """The density the operator entered (1/mm), or None: the mixture's own."""
        text = self.density.text().strip().replace(",", ".")
        try:
            return float(text) if text else None
        except ValueError:
            return None

    def _spins_changed(self) -> None:
        rgb = [s.value() for s in self.spins]
        self.target_swatch.setStyleSheet(_swatch_style(rgb))
        if self.tables is None or self.profile is None:
            self.de_label.setText("dE2000 - (colour tables not ready)")
            return
        try:
            result = pick_colour(self.profile, self.tables, rgb, self.density_value())
        except Exception as exc:  # noqa: BLE001 - said once, by the window
            self.de_label.setText("dE2000 - (not available)")
            self.problem.emit(f"The colour lookup failed: {exc}")
            return
        from dreamprint_gui.gamut.evaluation import IN_GAMUT_DE2000

        self.last_pick = result
        self.repro_swatch.setStyleSheet(_swatch_style(result["sRGB"]))
        de = result["dE2000"]
        if de <= IN_GAMUT_DE2000:
            verdict = "<b>in gamut</b>: printed as requested"
        else:
            verdict = ("<b style='color:#c33'>out of gamut</b>: printed as the nearest "
                       "printable colour (right)")
        self.de_label.setText(f"{verdict}<br>dE2000 {de:.2f} between requested and printed")
        lt, lr = result["target_Lab"], result["Lab"]
        self.lab_label.setText(
            f"target L*a*b* {lt[0]:.1f}, {lt[1]:.1f}, {lt[2]:.1f}<br>"
            f"reproduced {lr[0]:.1f}, {lr[1]:.1f}, {lr[2]:.1f}<br>"
            f"density sigma {result['aligned_sigma_per_mm']:.2f} /mm"
            + (f" (the nearest reachable: clamped {result['density_clamped']})"
               if result["density_clamped"] else ""))
        for ink, v in result["aligned"].items():
            self.bars[ink].setValue(int(round(1000 * v)))
            self.bar_values[ink].setText(f"{100 * v:.1f} %")
        self._mark_pick()
        self.picked.emit(result)

    # hexagon chart ----------------------------------------------------------------------------
    def _draw_chart(self) -> None:
        if self.tables is None or self.profile is None:
            return
        tables, profile = self.tables, self.profile

        def job(report, cancel):
            import tempfile

            from dreamprint_gui.gamut.charts import hexagon_chart

            with tempfile.TemporaryDirectory() as d:
                path = f"{d}/hexagon.png"
                stats = hexagon_chart(tables, profile, path)
                image = QImage(path)
                return stats, image.copy()

        self.chart_status.setText("drawing the hexagon chart ...")
        task = Task(job, "hexagon-chart")
        task.succeeded.connect(self._show_chart)
        task.failed.connect(lambda msg, _tb: self._chart_failed(msg))
        self._chart_task = run_task(task)

    def _chart_failed(self, message: str) -> None:
        self.chart_status.setText("")
        self.chart_view.set_text("no chart")
        self.problem.emit(f"The hexagon chart failed: {message}")

    def _show_chart(self, result) -> None:
        self.chart_stats, self.chart_image = result
        parts = [f"HSV value {k.split('_')[1]}: mean dE2000 {v['mean']:.2f}, max {v['max']:.2f}"
                 for k, v in self.chart_stats.items()]
        self.chart_status.setText("Target colour vs reproduced colour per cell (paper Fig. 7). "
                                  + "; ".join(parts))
        self.chart_view.set_image(self.chart_image)
        self.chartReady.emit()

    def shutdown(self) -> None:
        for t in (self._task, self._chart_task, self._intent_task):
            if t is not None:
                t.cancel()
        self.icc.shutdown()
        self.view.close_view()
