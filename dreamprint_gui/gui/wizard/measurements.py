"""The calibration wizard: ink measurements (or a chart) -> a fitted, saved, active profile.

Defines :class:`CalibrationWizard` (a QWizard) and its pages:

1. :class:`MeasurementsPage`: per ink, the files holding its reflectance and transmittance (any
   format ``io.spectra.read_spectra`` reads), the sample in each (the picked one is the one used:
   only its own impossible values refuse it, naming it; ``calibration_set.measured_values``),
   what each file holds when it does not say (the CLI's ``--file-quantity``: an absorbance file
   is read as T = 10^-A), and the swatch thickness, required (no default: the page names the
   inks lacking it); or a calibration set (TOML, ``io.spectra.calibration_set``; several
   thicknesses per ink). Every parsed spectrum is plotted at once, resampled onto the profile's
   grid; each file's problem shows on its own row.
   A tick, "slabs measured in air", leads to the slab page
   (:class:`~dreamprint_gui.gui.slab_page.SlabPage`, the translucency wedge): the faces'
   refractive index, k2 fitted or not, each ink's thickness series and what it can separate.
2. :class:`ChartPage` (optional): a mixture chart, recipes (``--mix-file`` CSV) and the measured
   reflectance of each patch.
3. :class:`FitPage`: runs ``calibration.calibrate_profile`` (and ``chart_calibration.fit_chart``)
   on a worker thread, showing the stage and the elapsed time, with a Stop button that returns
   the page at once (the fit has no cancel token: it is abandoned, ``workers.abandonable``,
   and its result dropped); then a table of what can be checked per ink (with several
   thicknesses, the held-out R/T error of ``calibration.leave_one_thickness_out``; with one R/T
   pair, that the fit is exact by construction), and plots: measured vs fitted R and T, the
   fitted K and S, the held-out and residual error per wavelength, the chart's cross-validated
   dE2000.
4. :class:`ChartProofPage` (after a chart calibration only): "how well does the proof predict
   your chart": the chart proof (``proof.chart``) of the fitted profile on a worker thread
   (progress per render pass, Stop), dE2000 mean, p95, max and worst patches, and the
   measured-vs-proofed picture.
5. :class:`SavePage`: name and file; saving makes the profile active (``profileSaved``).
"""

from __future__ import annotations

import datetime as _dt
import logging
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from PySide6.QtCore import Qt, QTimer, Signal
from PySide6.QtWidgets import (
    QCheckBox,
    QComboBox,
    QDoubleSpinBox,
    QFileDialog,
    QFormLayout,
    QGridLayout,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QProgressBar,
    QPushButton,
    QSpinBox,
    QTabWidget,
    QVBoxLayout,
    QWidget,
    QWizard,
    QWizardPage,
)

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.profile import INKS
from dreamprint_gui.gui.icc_export import IccExportBox, IccRequest
from dreamprint_gui.gui.settings import AppSettings
from dreamprint_gui.gui.slab_page import SlabPage, slab_fit_table
from dreamprint_gui.gui.wizard_common import ERROR_STYLE, INK_COLOURS, canvas
from dreamprint_gui.gui.workers import Task, abandonable, run_task
from dreamprint_gui.physics.slab_fit import SlabFit, SlabOptions

__all__ = ["CalibrationWizard", "MeasurementsPage", "SlabPage", "ChartPage", "FitPage",
           "ChartProofPage", "SavePage", "SPECTRA_FILTER", "INK_COLOURS", "ERROR_STYLE"]

log = logging.getLogger(__name__)

SPECTRA_FILTER = ("Spectral measurements (*.csv *.txt *.ti3 *.cgats *.jdx *.dx *.jcamp *.spdx "
                  "*.tsv);;All files (*)")


@dataclass
class _Channel:
    """One file + sample giving R or T of one ink."""

    path: str = ""
    sample: str | int | None = None
    names: list[str] = field(default_factory=list)
    file = None  # SpectraFile
    values: np.ndarray | None = None  # resampled onto the profile grid
    error: str = ""
    file_quantity: str | None = None  # what the operator says the file holds (None: the file)


# What a file holds, as the operator may state it (the CLI's --file-quantity): None = as the file
# says (a file that does not say is read as the column's quantity).
FILE_QUANTITIES = (("file says", None), ("reflectance", "reflectance"),
                   ("transmittance", "transmittance"), ("absorbance", "absorbance"))
QUANTITY_NAMES = {"R": "reflectance", "T": "transmittance"}


class _InkRow:
    """The widgets of one ink on the measurements page."""

    def __init__(self, page: MeasurementsPage, ink: str, extra: bool = False) -> None:
        """``extra``: another thickness of ``ink`` (removable), not the ink's first row."""
        self.page, self.ink, self.extra = page, ink, extra
        self.channels = {"R": _Channel(), "T": _Channel()}
        self.edits: dict[str, QLineEdit] = {}
        self.combos: dict[str, QComboBox] = {}
        self.holds: dict[str, QComboBox] = {}
        self.cells: list[tuple[QWidget, int]] = []  # (widget, column) of the row's line
        name = QLabel(f"<b>{ink}</b>" if not extra else f"<b>{ink}</b> +")
        self.cells.append((name, 0))
        col = 1
        for q in ("R", "T"):
            edit = QLineEdit()
            edit.setPlaceholderText(f"{ink} {QUANTITY_NAMES[q]} file")
            edit.editingFinished.connect(lambda q=q: self.load(q, self.edits[q].text()))
            browse = QPushButton("...")
            browse.setMaximumWidth(32)
            browse.clicked.connect(lambda _=False, q=q: self.browse(q))
            combo = QComboBox()
            combo.setMinimumWidth(110)
            combo.setToolTip("the sample of the file that is this ink's "
                             f"{QUANTITY_NAMES[q]}")
            combo.currentIndexChanged.connect(lambda _i, q=q: self.sample_changed(q))
            holds = QComboBox()
            for text, _ in FILE_QUANTITIES:
                holds.addItem(text)
            holds.setToolTip("what the file holds, when it does not say (like the CLI's "
                             "--file-quantity): an absorbance file is read as T = 10^-A")
            holds.currentIndexChanged.connect(lambda _i, q=q: self.quantity_changed(q))
            self.edits[q], self.combos[q], self.holds[q] = edit, combo, holds
            self.cells += [(edit, col), (browse, col + 1), (combo, col + 2), (holds, col + 3)]
            col += 4
        # No default: a thickness the operator did not enter would silently scale K and S.
        self.thickness = QDoubleSpinBox(decimals=3, minimum=0.0, maximum=100.0, value=0.0,
                                        suffix=" mm", singleStep=0.1)
        self.thickness.setSpecialValueText("thickness?")
        self.thickness.setToolTip("the measured swatch's thickness (required for every ink "
                                  "with a measurement)")
        self.thickness.valueChanged.connect(page.changed)
        self.cells.append((self.thickness, col))
        # another thickness of this ink (the held-out check needs two), or remove this one
        self.more = QPushButton("-" if extra else "+")
        self.more.setMaximumWidth(28)
        self.more.setToolTip(f"remove this thickness of {ink}" if extra else
                             f"add another thickness of {ink} (two or more let the fit page "
                             "check the fit on a thickness it did not see)")
        self.more.clicked.connect(lambda: page.remove_row(self) if extra else page.add_row(ink))
        self.cells.append((self.more, col + 1))
        self.columns = col + 1
        self.error = QLabel("")
        self.error.setStyleSheet(ERROR_STYLE)
        self.error.setWordWrap(True)
        self.error.setVisible(False)

    def place(self, grid: QGridLayout, row: int) -> None:
        """Put the row's widgets on grid line ``row`` (its problem on the line below)."""
        for w, col in self.cells:
            grid.addWidget(w, row, col)
        grid.addWidget(self.error, row + 1, 1, 1, self.columns - 1)

    def widgets(self) -> list[QWidget]:
        return [w for w, _ in self.cells] + [self.error]

    def browse(self, q: str) -> None:
        path, _ = QFileDialog.getOpenFileName(
            self.page, f"{self.ink}: {QUANTITY_NAMES[q]}",
            self.page.settings.last_folder("spectra"), SPECTRA_FILTER)
        if path:
            self.page.settings.set_last_folder("spectra", path)
            self.edits[q].setText(path)
            self.load(q, path)

    def set_file_quantity(self, q: str, quantity: str | None) -> None:
        """State what the R or T file holds (``None``: as the file says); the file is re-read."""
        self.holds[q].setCurrentIndex([v for _, v in FILE_QUANTITIES].index(quantity))

    def quantity_changed(self, q: str) -> None:
        ch = self.channels[q]
        if ch.path:
            self.load(q, ch.path, sample=ch.sample, force=True)

    def load(self, q: str, path: str, sample: str | int | None = None,
             force: bool = False) -> None:
        """Read ``path`` as the ink's R or T; a problem is shown on this row.

        ``sample`` (name or 0-based index) is the one to pick; by default the one named after
        the ink, else the file's first usable one.
        """
        ch = self.channels[q]
        path = path.strip()
        file_quantity = FILE_QUANTITIES[self.holds[q].currentIndex()][1]
        if (path == ch.path and sample is None and ch.file is not None and not force
                and file_quantity == ch.file_quantity):
            return
        self.channels[q] = ch = _Channel(path=path, file_quantity=file_quantity)
        combo = self.combos[q]
        combo.blockSignals(True)
        combo.clear()
        combo.blockSignals(False)
        if self.edits[q].text() != path:
            self.edits[q].setText(path)
        if path:
            from dreamprint_gui.io.spectra import read_spectra

            try:
                ch.file = read_spectra(path, quantity=QUANTITY_NAMES[q],
                                       file_quantity=file_quantity)
                ch.names = list(ch.file.names)
            except DreamPrintError as exc:
                ch.error = str(exc)
            except OSError as exc:
                ch.error = f"{path}: {exc.strerror or exc}"
            if ch.file is not None:
                combo.blockSignals(True)
                combo.addItems(ch.names)
                combo.blockSignals(False)
                idx = 0
                if isinstance(sample, int) and 0 <= sample < len(ch.names):
                    idx = sample
                elif isinstance(sample, str) and sample in ch.names:
                    idx = ch.names.index(sample)
                elif self.ink in ch.names:
                    idx = ch.names.index(self.ink)
                elif not ch.file.usable[0] and any(ch.file.usable):
                    idx = ch.file.usable.index(True)   # a mixed file: its first sample of q
                combo.setCurrentIndex(idx)
                self.sample_changed(q)
                return
        self.show_errors()
        self.page.changed()

    def sample_changed(self, q: str) -> None:
        """Use the picked sample; only its own problems are its problems."""
        from dreamprint_gui.io.spectra.calibration_set import measured_values

        ch = self.channels[q]
        ch.error = ""
        ch.values = None
        if ch.file is not None and self.combos[q].count():
            i = self.combos[q].currentIndex()
            ch.sample = ch.names[i]
            try:
                ch.values = measured_values(ch.file, ch.file.sample(i), self.page.wavelengths())
            except DreamPrintError as exc:
                ch.error = str(exc)
        self.show_errors()
        self.page.changed()

    def show_errors(self) -> None:
        errors = [f"{q}: {c.error}" for q, c in self.channels.items() if c.error]
        self.error.setText("\n".join(errors))
        self.error.setVisible(bool(errors))

    def has_data(self) -> bool:
        return any(c.values is not None for c in self.channels.values())

    def lacks_thickness(self) -> bool:
        return self.has_data() and not self.thickness.value() > 0

    def measurement(self):
        from dreamprint_gui.core.calibration_types import LayerMeasurement

        R, T = self.channels["R"].values, self.channels["T"].values
        if (R is None and T is None) or not self.thickness.value() > 0:
            return None
        src = "; ".join(f"{q}: {c.path} [{c.sample}]" for q, c in self.channels.items()
                        if c.values is not None)
        return LayerMeasurement(self.ink, float(self.thickness.value()), R, T, src)

    def has_error(self) -> bool:
        return any(c.error for c in self.channels.values())


class MeasurementsPage(QWizardPage):
    """Per-ink R and T files (or a calibration set), plotted as soon as they are parsed."""

    def __init__(self, wizard: CalibrationWizard) -> None:
        super().__init__()
        self.wiz = wizard
        self.settings = wizard.settings
        self.set_measurements: list | None = None
        self.set_path: str | None = None
        self.setTitle("Ink measurements")
        self.setSubTitle("Choose, for each ink you measured, the file holding its reflectance "
                         "(R) and transmittance (T), the sample in it, what the file holds if it "
                         "does not say, and the swatch thickness; + adds another thickness of "
                         "the ink (two or more let the fit be checked). Inks you leave empty "
                         "keep the active profile's values. Or load a calibration set.")
        grid = QGridLayout()
        for c, text in enumerate(("ink", "R file", "", "R sample", "file holds", "T file", "",
                                  "T sample", "file holds", "thickness")):
            grid.addWidget(QLabel(f"<i>{text}</i>"), 0, c)
        self.grid = grid
        # every layer row, in page order; ``rows`` the first of each ink
        self.layer_rows = [_InkRow(self, ink) for ink in INKS]
        self.rows = {r.ink: r for r in self.layer_rows}
        self._relayout()
        set_row = QHBoxLayout()
        self.set_button = QPushButton("Load a calibration set (TOML)...")
        self.set_button.clicked.connect(self._browse_set)
        self.clear_set_button = QPushButton("Clear")
        self.clear_set_button.clicked.connect(lambda: self.load_set(None))
        self.set_label = QLabel("")
        self.set_label.setWordWrap(True)
        set_row.addWidget(self.set_button)
        set_row.addWidget(self.clear_set_button)
        set_row.addWidget(self.set_label, 1)
        self.slabs_box = QCheckBox("Slabs measured in air (the translucency wedge, "
                                   "`dreamprint target wedge`): fit each ink's bulk inside "
                                   "the slab's two faces")
        self.slabs_box.setToolTip("Free-standing slabs reflect at both faces; the next page "
                                  "sets the refractive index and shows each ink's thickness "
                                  "series")
        set_row.addWidget(self.slabs_box)
        self.missing = QLabel("")
        self.missing.setObjectName("missingThickness")
        self.missing.setStyleSheet(ERROR_STYLE)
        self.missing.setWordWrap(True)
        self.figure, self.canvas = canvas((7, 3))
        self.canvas.setMinimumHeight(220)
        lay = QVBoxLayout(self)
        lay.addLayout(grid)
        lay.addWidget(self.missing)
        lay.addLayout(set_row)
        lay.addWidget(self.canvas, 1)
        self.changed()

    def wavelengths(self) -> np.ndarray:
        return self.wiz.base_profile.wavelengths_nm

    def _relayout(self) -> None:
        for r in self.layer_rows:
            for w in r.widgets():
                self.grid.removeWidget(w)
        for i, r in enumerate(self.layer_rows):
            r.place(self.grid, 1 + 2 * i)

    def add_row(self, ink: str) -> _InkRow:
        """Another thickness of ``ink``: a row under the ink's last one."""
        row = _InkRow(self, ink, extra=True)
        last = max(i for i, r in enumerate(self.layer_rows) if r.ink == ink)
        self.layer_rows.insert(last + 1, row)
        self._relayout()
        enabled = self.set_measurements is None
        for w in row.widgets():
            w.setEnabled(enabled)
        self.changed()
        return row

    def remove_row(self, row: _InkRow) -> None:
        if not row.extra:
            return
        self.layer_rows.remove(row)
        for w in row.widgets():
            self.grid.removeWidget(w)
            w.deleteLater()
        self._relayout()
        self.changed()

    def _browse_set(self) -> None:
        path, _ = QFileDialog.getOpenFileName(self, "Calibration set",
                                              self.settings.last_folder("spectra"),
                                              "Calibration sets (*.toml);;All files (*)")
        if path:
            self.settings.set_last_folder("spectra", path)
            self.load_set(path)

    def load_set(self, path: str | None) -> None:
        """Use the measurements a calibration set names (instead of the rows)."""
        self.set_measurements, self.set_path = None, None
        self.set_label.setStyleSheet("")
        if path:
            from dreamprint_gui.io.spectra.calibration_set import load_calibration_set

            try:
                self.set_measurements = list(load_calibration_set(path, self.wavelengths()))
                self.set_path = path
                inks = sorted({m.ink for m in self.set_measurements}, key=INKS.index)
                self.set_label.setText(f"{Path(path).name}: {len(self.set_measurements)} "
                                       f"layers of {', '.join(inks)}")
            except DreamPrintError as exc:
                self.set_label.setText(str(exc))
                self.set_label.setStyleSheet(ERROR_STYLE)
        else:
            self.set_label.setText("")
        for row in self.layer_rows:
            for w in (*row.edits.values(), *row.combos.values(), *row.holds.values(),
                      row.thickness, row.more):
                w.setEnabled(self.set_measurements is None)
        self.changed()

    def measurements(self) -> list:
        if self.set_measurements is not None:
            return list(self.set_measurements)
        return [m for m in (row.measurement() for row in self.layer_rows) if m is not None]

    def lacking_thickness(self) -> list[str]:
        """The inks with a measurement but no thickness (none when a set is loaded)."""
        if self.set_measurements is not None:
            return []
        return list(dict.fromkeys(r.ink for r in self.layer_rows if r.lacks_thickness()))

    def changed(self) -> None:
        lacking = self.lacking_thickness()
        self.missing.setText(
            f"Enter the swatch thickness of {', '.join(lacking)}: the fit needs the thickness "
            "of every measured layer (there is no default)." if lacking else "")
        self.missing.setVisible(bool(lacking))
        self._plot()
        self.completeChanged.emit()

    def nextId(self) -> int:  # noqa: N802 - Qt override
        """The slab page when the layers are slabs measured in air, else the chart page."""
        ids = self.wiz.page_ids
        return ids[self.wiz.slab_page if self.slabs_box.isChecked() else self.wiz.chart_page]

    def isComplete(self) -> bool:  # noqa: N802 - Qt override
        # Measurements are optional when a chart is given on the next page; a row with a
        # problem or without its thickness must be fixed or cleared first.
        return self.set_measurements is not None or not any(
            r.has_error() or r.lacks_thickness() for r in self.layer_rows)

    def _plotted(self) -> list:
        """The measurements to plot: also those of rows still lacking their thickness."""
        if self.set_measurements is not None:
            return list(self.set_measurements)
        from dreamprint_gui.core.calibration_types import LayerMeasurement

        return [LayerMeasurement(r.ink, float(r.thickness.value()), r.channels["R"].values,
                                 r.channels["T"].values) for r in self.layer_rows
                if r.has_data()]

    def _plot(self) -> None:
        fig = self.figure
        fig.clear()
        ax_r, ax_t = fig.subplots(1, 2, sharex=True)
        wl = self.wavelengths()
        for m in self._plotted():
            colour = INK_COLOURS[m.ink]
            label = f"{m.ink} {m.thickness_mm:g} mm" if m.thickness_mm > 0 else \
                f"{m.ink} (thickness?)"
            if m.R is not None:
                ax_r.plot(wl, m.R, color=colour, label=label)
            if m.T is not None:
                ax_t.plot(wl, m.T, color=colour, label=label)
        for ax, title in ((ax_r, "reflectance R"), (ax_t, "transmittance T")):
            ax.set_title(title, fontsize=9)
            ax.set_xlabel("wavelength (nm)", fontsize=8)
            ax.set_ylim(-0.02, 1.02)
            ax.tick_params(labelsize=7)
            if ax.lines:
                ax.legend(fontsize=7)
        self.canvas.draw_idle()


class ChartPage(QWizardPage):
    """Optional: a printed mixture chart to refit the inks jointly (minimising dE2000)."""

    def __init__(self, wizard: CalibrationWizard) -> None:
        super().__init__()
        self.wiz = wizard
        self.recipes = None
        self.reflectance = None
        self.setTitle("Mixture chart (optional)")
        self.setSubTitle("A chart of printed mixtures refits the inks jointly to its measured "
                         "reflectance and reports the cross-validated dE2000. Leave empty to "
                         "skip.")
        self.recipes_edit = QLineEdit()
        self.recipes_edit.setPlaceholderText("recipes CSV: a header naming inks, one row per patch")
        self.spectra_edit = QLineEdit()
        self.spectra_edit.setPlaceholderText("measured reflectance of each patch, same order")
        form = QFormLayout()
        for label, edit, filt in (("Recipes", self.recipes_edit, "CSV (*.csv);;All files (*)"),
                                  ("Reflectance", self.spectra_edit, SPECTRA_FILTER)):
            row = QHBoxLayout()
            row.addWidget(edit, 1)
            b = QPushButton("...")
            b.setMaximumWidth(32)
            b.clicked.connect(lambda _=False, e=edit, f=filt: self._browse(e, f))
            row.addWidget(b)
            edit.editingFinished.connect(self.load)
            form.addRow(label, row)
        self.folds = QSpinBox(minimum=2, maximum=20, value=5)
        self.folds.setToolTip("k-fold cross-validation: each patch's dE2000 is predicted by a "
                              "fit that did not see it")
        form.addRow("Cross-validation folds", self.folds)
        self.error = QLabel("")
        self.error.setStyleSheet(ERROR_STYLE)
        self.error.setWordWrap(True)
        self.info = QLabel("")
        self.figure, self.canvas = canvas((6, 2.5))
        lay = QVBoxLayout(self)
        lay.addLayout(form)
        lay.addWidget(self.error)
        lay.addWidget(self.info)
        lay.addWidget(self.canvas, 1)

    def _browse(self, edit: QLineEdit, filt: str) -> None:
        path, _ = QFileDialog.getOpenFileName(self, "Chart file",
                                              self.wiz.settings.last_folder("spectra"), filt)
        if path:
            edit.setText(path)
            self.load()

    def load(self) -> None:
        """Parse both files; the problem of either shows on this page."""
        self.recipes = self.reflectance = None
        self.error.setText("")
        self.info.setText("")
        rp, sp = self.recipes_edit.text().strip(), self.spectra_edit.text().strip()
        if rp or sp:
            try:
                if not (rp and sp):
                    raise DreamPrintError("give both the recipes and the reflectance file")
                from dreamprint_gui.io.chart_files import read_chart

                files = read_chart(rp, sp, self.wiz.base_profile.wavelengths_nm)
                recipes, refl = files.recipes, files.reflectance
                self.recipes, self.reflectance = recipes, refl
                self.info.setText(f"{len(recipes)} patches")
            except DreamPrintError as exc:
                self.error.setText(str(exc))
        self._plot()
        self.completeChanged.emit()

    def isComplete(self) -> bool:  # noqa: N802 - Qt override
        return not self.error.text()

    def _plot(self) -> None:
        self.figure.clear()
        if self.reflectance is not None:
            ax = self.figure.subplots()
            ax.plot(self.wiz.base_profile.wavelengths_nm, self.reflectance.T, lw=0.8)
            ax.set_xlabel("wavelength (nm)", fontsize=8)
            ax.set_title("patch reflectance", fontsize=9)
            ax.tick_params(labelsize=7)
        self.canvas.draw_idle()


def _held_out(measurements: list, base) -> dict[str, tuple[list, list[str]]]:
    """Leave-one-thickness-out of each ink with several thicknesses (worker thread)."""
    from dreamprint_gui.physics.calibration import leave_one_thickness_out

    out = {}
    for ink in INKS:
        layers = [m for m in measurements if m.ink == ink]
        if len({m.thickness_mm for m in layers}) > 1:
            out[ink] = leave_one_thickness_out(layers, base.wavelengths_nm.size)
    return out


def _fmt_err(x: float | None) -> str:
    if x is None:
        return "-"
    return "&lt; 0.0001" if x < 5e-5 else f"{x:.4f}"


FIT_TABLE_HEAD = ("<tr><th align='left'>ink</th><th align='left'>layers</th>"
                  "<th>held-out rms R</th><th>held-out rms T</th><th>worst held out</th>"
                  "<th>fit residual R / T<br>(worst wavelength)</th>"
                  "<th align='left'>what this says</th></tr>")


def _fit_row(fit, layers: list, held: list, notes: list[str]) -> str:
    """One ink's row of the fit table: what can be checked of its fit.

    Held-out error (leave-one-thickness-out) with several thicknesses; one layer with R and T
    is fitted exactly by construction, which the row says instead of a zero residual.
    """
    from dreamprint_gui.physics.calibration import exact_by_construction

    ts = sorted({m.thickness_mm for m in layers})
    layer_text = f"{len(layers)} at {', '.join(f'{t:g}' for t in ts)} mm"
    cells = [f"<b>{fit.ink}</b>", layer_text]
    s = fit.summary()
    residual = f"{_fmt_err(s['max_rms_R'])} / {_fmt_err(s['max_rms_T'])}"
    if exact_by_construction(layers):
        cells += ["-", "-", "-", "-",
                  "exact by construction (one R and T pair, two unknowns per wavelength): "
                  "nothing to check; measure a second thickness"]
    elif len(layers) == 1:
        q = "T" if layers[0].R is None else "R"
        cells += ["-", "-", "-", "-",
                  f"only {q}: matched exactly, K and S not separable; measure R and T"]
    elif held:
        worst = max(held, key=lambda h: max(h.overall_R or 0.0, h.overall_T or 0.0))
        rms = {q: [getattr(h, f"overall_{q}") for h in held] for q in "RT"}
        agg = {q: (None if all(v is None for v in vals) else
                   float(np.sqrt(np.mean([v * v for v in vals if v is not None]))))
               for q, vals in rms.items()}
        per = "; ".join(f"{h.thickness_mm:g} mm: R {_fmt_err(h.overall_R)}, "
                        f"T {_fmt_err(h.overall_T)}" for h in held)
        cells += [_fmt_err(agg["R"]), _fmt_err(agg["T"]), f"{worst.thickness_mm:g} mm",
                  residual, f"each thickness predicted from the others ({per})"]
    elif len(ts) == 1:
        cells += ["-", "-", "-", residual,
                  "one thickness: nothing to hold out; the residual is the repeats' spread"]
    else:
        cells += ["-", "-", "-", residual, ""]
    if notes:
        cells[-1] += ("; " if cells[-1] else "") + "; ".join(notes)
    aligns = ["left", "left", "center", "center", "center", "center", "left"]
    return "<tr>" + "".join(f"<td align='{a}'>{c}</td>" for a, c in
                            zip(aligns, cells, strict=True)) + "</tr>"


class _TaskPage(QWizardPage):
    """A page that runs one engine task at a time in the worker: its signals reach the page's
    ``_progress`` / ``_done`` / ``_failed`` / ``_finished`` only while it is the current task."""

    _task: Task | None

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


class FitPage(_TaskPage):
    """Fits on a worker thread; plots measured vs fitted R and T, residuals, chart dE2000."""

    fitted = Signal(object)

    def __init__(self, wizard: CalibrationWizard) -> None:
        super().__init__()
        self.wiz = wizard
        self.result = None  # (profile, fits, chart_fit)
        self.held_out: dict[str, tuple[list, list[str]]] = {}
        self.error_text = ""
        self._task: Task | None = None
        self.setTitle("Fit")
        self.setSubTitle("Kubelka-Munk K and S per wavelength, fitted to your measurements.")
        self.status = QLabel("")
        self.status.setWordWrap(True)
        self.busy = QProgressBar(minimum=0, maximum=0)  # no fraction to show: a busy bar
        self.busy.setTextVisible(False)
        self.busy.setMaximumWidth(160)
        self.elapsed = QLabel("")
        self.elapsed.setObjectName("fitElapsed")
        self.stop_button = QPushButton("Stop")
        self.stop_button.setToolTip("Stop fitting: the page returns at once and the running "
                                    "fit's result is discarded")
        self.stop_button.clicked.connect(self.stop)
        self.again_button = QPushButton("Fit again")
        self.again_button.clicked.connect(self.start)
        run_row = QHBoxLayout()
        run_row.addWidget(self.busy)
        run_row.addWidget(self.elapsed, 1)
        run_row.addWidget(self.stop_button)
        run_row.addWidget(self.again_button)
        self._stage = ""
        self._t0 = 0.0
        self._clock = QTimer(self, interval=500)
        self._clock.timeout.connect(self._tick)
        self.tabs = QTabWidget()
        self.fit_fig, self.fit_canvas = canvas((8, 4.5))
        self.ks_fig, self.ks_canvas = canvas((8, 4.5))
        self.res_fig, self.res_canvas = canvas((8, 3))
        self.chart_fig, self.chart_canvas = canvas((8, 3))
        self.tabs.addTab(self.fit_canvas, "Measured vs fitted")
        self.tabs.addTab(self.ks_canvas, "Fitted K and S")
        self.tabs.addTab(self.res_canvas, "Held-out and residual error")
        self.tabs.addTab(self.chart_canvas, "Chart dE2000")
        lay = QVBoxLayout(self)
        lay.addLayout(run_row)
        lay.addWidget(self.status)
        lay.addWidget(self.tabs, 1)
        self._set_running(False)

    def initializePage(self) -> None:  # noqa: N802 - Qt override
        self.start()

    @property
    def running(self) -> bool:
        return self._task is not None and self._task.outcome is None \
            and not self._task.cancel_event.is_set()

    def _set_running(self, running: bool) -> None:
        self.busy.setVisible(running)
        self.stop_button.setVisible(running)
        self.again_button.setVisible(not running)
        self._run_clock(running)

    def _tick(self) -> None:
        self.elapsed.setText(f"{self._stage} {time.monotonic() - self._t0:.0f} s")

    def _progress(self, stage: str) -> None:
        self._stage = stage
        self._tick()

    def stop(self) -> None:
        """Abandon the running fit: the page is ready again at once, its result is dropped."""
        if not self.running:
            return
        self._task.cancel()
        self._set_running(False)
        self.elapsed.setText(f"stopped after {time.monotonic() - self._t0:.0f} s")
        self.status.setText("The fit was stopped. Change the inputs (Back) or fit again.")
        self.status.setStyleSheet("")
        self.completeChanged.emit()

    def start(self) -> None:
        """Fit the current inputs on a worker thread (a running fit is abandoned first)."""
        self.stop()
        self.result = None
        self.error_text = ""
        self.completeChanged.emit()
        measurements = self.wiz.measurements_page.measurements()
        chart = self.wiz.chart_page
        recipes, refl, folds = chart.recipes, chart.reflectance, int(chart.folds.value())
        base = self.wiz.base_profile
        name = self.wiz.default_name
        slabs = self.wiz.slab_options()

        def job(report, cancel):
            from dreamprint_gui.physics.calibration import calibrate_profile

            if not measurements and recipes is None:
                raise DreamPrintError("nothing to fit: choose ink measurements (first page) or "
                                      "a mixture chart (second page)")
            held: dict[str, tuple[list, list[str]]] = {}
            if measurements:
                report("fitting K and S of each ink" + (" inside the slabs' faces:" if slabs
                                                        else ":"))
                profile, fits = abandonable(
                    lambda: calibrate_profile(measurements, base, name=name, slabs=slabs),
                    cancel, name="calibrate-profile")
                if not slabs and any(len({m.thickness_mm for m in measurements
                                          if m.ink == f.ink}) > 1 for f in fits):
                    report("holding out each thickness in turn:")
                    held = abandonable(lambda: _held_out(measurements, base), cancel,
                                       name="leave-one-thickness-out")
            else:
                profile, fits = base.with_settings(name=name), []
            chart_fit = None
            if recipes is not None:
                from dreamprint_gui.physics.chart_calibration import fit_chart

                n = len(recipes)
                report(f"refitting the inks to the chart's {n} patches with "
                       f"{folds}-fold cross-validation (this can take a minute):")
                start = profile

                def step(done: int, total: int) -> None:
                    report(f"refitting the inks to the chart's {n} patches: fit {done + 1} "
                           f"of {total} (all patches, then each of the {total - 1} folds):"
                           if done < total else
                           f"refitted to the chart's {n} patches ({total} fits):")

                chart_fit = abandonable(
                    lambda: fit_chart(start, recipes, refl, name=name, folds=folds,
                                      progress=step), cancel, name="fit-chart")
                profile = chart_fit.profile
            return profile, fits, chart_fit, measurements, held

        self.status.setText("")
        self.status.setStyleSheet("")
        self._stage = "fitting:"
        self._start_task(job, "calibration")

    def _finished(self) -> None:
        if self._task.outcome != "cancelled":  # a stop has already reset the page
            self._set_running(False)
            self.elapsed.setText(f"fitted in {time.monotonic() - self._t0:.0f} s"
                                 if self._task.outcome == "succeeded" else "")
        self.completeChanged.emit()

    def cleanupPage(self) -> None:  # noqa: N802 - Qt override
        self.stop()

    def isComplete(self) -> bool:  # noqa: N802 - Qt override
        return self.result is not None

    def nextId(self) -> int:  # noqa: N802 - Qt override
        """The chart proof page only after a chart calibration."""
        ids = self.wiz.page_ids
        with_chart = self.result is not None and self.result[2] is not None
        return ids[self.wiz.chart_proof_page if with_chart else self.wiz.save_page]

    def _failed(self, message: str, _tb: str) -> None:
        self.error_text = message
        self.status.setText(f"The fit failed: {message}")
        self.status.setStyleSheet(ERROR_STYLE)

    def _done(self, result) -> None:
        profile, fits, chart_fit, measurements, held = result
        self.result = (profile, fits, chart_fit)
        self.held_out = held
        text = ""
        if fits and isinstance(fits[0], SlabFit):
            text = slab_fit_table(fits)
        elif fits:
            rows = [_fit_row(f, [m for m in measurements if m.ink == f.ink],
                             *held.get(f.ink, ([], []))) for f in fits]
            text = ("<table cellspacing='0' cellpadding='3'>" + FIT_TABLE_HEAD + "".join(rows)
                    + "</table>")
        if chart_fit is not None:
            cv = chart_fit.report()["cross_validated_dE2000"]
            text += (f"<b>chart</b>: cross-validated dE2000 mean {cv['mean']:.2f}, "
                     f"p95 {cv['p95']:.2f}, max {cv['max']:.2f}")
        self.status.setText(text)
        self._plot_fit(profile, measurements, fits)
        self._plot_ks(profile, [f.ink for f in fits])
        self._plot_residuals(fits, held)
        self._plot_chart(chart_fit)
        self.tabs.setTabEnabled(3, chart_fit is not None)
        self.fitted.emit(self.result)

    def _plot_fit(self, profile, measurements, fits=()) -> None:
        from dreamprint_gui.physics.kubelka_munk import reflectance_transmittance

        slab_fits = {f.ink: f for f in fits if isinstance(f, SlabFit)}

        fig = self.fit_fig
        fig.clear()
        inks = [ink for ink in INKS if any(m.ink == ink for m in measurements)]
        axes = np.atleast_1d(fig.subplots(2, max(1, len(inks)), sharex=True, sharey="row",
                                          squeeze=False))
        wl = profile.wavelengths_nm
        for j, ink in enumerate(inks):
            i = INKS.index(ink)
            for m in (m for m in measurements if m.ink == ink):
                R, T = (slab_fits[ink].predict(m.thickness_mm) if ink in slab_fits else
                        reflectance_transmittance(profile.K[i], profile.S[i], m.thickness_mm))
                for row, meas, fit in ((0, m.R, R), (1, m.T, T)):
                    ax = axes[row, j]
                    if meas is not None:
                        ax.plot(wl, meas, "o", ms=2.5, color=INK_COLOURS[ink], alpha=0.7)
                        ax.plot(wl, fit, "-", lw=1.2, color="#333")
            axes[0, j].set_title(ink, fontsize=9)
        for row, q in enumerate(("R", "T")):
            axes[row, 0].set_ylabel(f"{q} (dots measured, line fitted)", fontsize=7)
            for ax in axes[row]:
                ax.tick_params(labelsize=6)
        for ax in axes[1]:
            ax.set_xlabel("nm", fontsize=7)
        self.fit_canvas.draw_idle()

    def _plot_ks(self, profile, inks: list[str]) -> None:
        """The fitted K and S (1/mm) of each fitted ink, on a log scale."""
        fig = self.ks_fig
        fig.clear()
        inks = [ink for ink in INKS if ink in inks]
        if not inks:
            self.ks_canvas.draw_idle()
            return
        axes = fig.subplots(1, len(inks), sharey=True, squeeze=False)[0]
        wl = profile.wavelengths_nm
        for ax, ink in zip(axes, inks, strict=True):
            i = INKS.index(ink)
            ax.plot(wl, profile.K[i], "-", color=INK_COLOURS[ink], lw=1.5, label="K")
            ax.plot(wl, profile.S[i], "--", color="#555", lw=1.2, label="S")
            ax.set_yscale("log")
            ax.set_title(ink, fontsize=9)
            ax.set_xlabel("wavelength (nm)", fontsize=7)
            ax.tick_params(labelsize=6)
            ax.legend(fontsize=7)
        axes[0].set_ylabel("K (absorption), S (scattering): 1/mm", fontsize=7)
        self.ks_canvas.draw_idle()

    def _plot_residuals(self, fits, held) -> None:
        """Held-out error per wavelength (solid) where there is one, else the fit residual
        (dotted; exactly zero for one layer, which is said in the title)."""
        fig = self.res_fig
        fig.clear()
        ax_r, ax_t = fig.subplots(1, 2, sharey=True)
        wl = self.wiz.base_profile.wavelengths_nm
        for f in fits:
            colour = INK_COLOURS[f.ink]
            outs = held.get(f.ink, ([], []))[0]
            for ax, q in ((ax_r, "R"), (ax_t, "T")):
                curves = [getattr(h, f"rms_{q}") for h in outs
                          if np.isfinite(getattr(h, f"rms_{q}")).any()]
                if curves:
                    with np.errstate(invalid="ignore"):
                        ho = np.sqrt(np.nanmean(np.square(curves), axis=0))
                    ax.plot(wl, ho, "-", color=colour, label=f"{f.ink} held out")
                res = getattr(f, f"rms_{q}")
                if np.isfinite(res).any():
                    ax.plot(wl, res, ":", color=colour, label=f"{f.ink} fit residual")
        for ax, q in ((ax_r, "R"), (ax_t, "T")):
            ax.set_title(f"rms error of {q} per wavelength", fontsize=9)
            ax.set_xlabel("wavelength (nm)", fontsize=8)
            ax.tick_params(labelsize=7)
            if ax.lines:
                ax.legend(fontsize=6)
        self.res_canvas.draw_idle()

    def _plot_chart(self, chart_fit) -> None:
        fig = self.chart_fig
        fig.clear()
        if chart_fit is None:
            self.chart_canvas.draw_idle()
            return
        ax = fig.subplots()
        x = np.arange(chart_fit.cv_dE2000.size)
        ax.bar(x - 0.2, chart_fit.fit_dE2000, 0.4, label="fit (own patches)")
        ax.bar(x + 0.2, chart_fit.cv_dE2000, 0.4, label=f"cross-validated ({chart_fit.folds} "
               "folds)")
        ax.set_xlabel("patch", fontsize=8)
        ax.set_ylabel("dE2000", fontsize=8)
        ax.legend(fontsize=7)
        self.chart_canvas.draw_idle()



class ChartProofPage(_TaskPage):
    """After a chart calibration: how well does the print proof predict your chart? Renders
    each patch with the fitted profile as ``dreamprint proof --chart`` does, on a worker
    thread (progress per render pass, Stop), and shows dE2000 against the measurements, the
    worst patches and the measured-vs-proofed picture."""

    def __init__(self, wizard: CalibrationWizard) -> None:
        super().__init__()
        self.wiz = wizard
        self.report: dict | None = None
        self.picture: np.ndarray | None = None
        self.error_text = ""
        self._task: Task | None = None
        self.setTitle("Chart proof (optional)")
        self.setSubTitle("How well does the print proof predict your chart? Each patch is "
                         "rendered with the fitted profile as the proof renders a print, and "
                         "compared with your measurement. Skip with Next.")
        from dreamprint_gui.proof.chart import GEOMETRIES

        self.geometry = QComboBox()
        self.geometry.addItems(list(GEOMETRIES))
        self.geometry.setToolTip("The instrument's geometry: d:8 (sphere, specular included) or "
                                 "45:0 (most hand-held spectrophotometers)")
        self.spp = QSpinBox(minimum=16, maximum=4096, value=256, singleStep=64)
        self.spp.setToolTip("Samples per pixel: more is less noise and longer")
        self.run_button = QPushButton("Proof the chart")
        self.run_button.clicked.connect(self.start)
        self.stop_button = QPushButton("Stop")
        self.stop_button.clicked.connect(self.stop)
        self.bar = QProgressBar(minimum=0, maximum=1)
        self.bar.setMaximumWidth(200)
        self.elapsed = QLabel("")
        row = QHBoxLayout()
        row.addWidget(QLabel("Geometry"))
        row.addWidget(self.geometry)
        row.addWidget(QLabel("Samples per pixel"))
        row.addWidget(self.spp)
        row.addWidget(self.run_button)
        row.addWidget(self.stop_button)
        row.addWidget(self.bar)
        row.addWidget(self.elapsed, 1)
        self.status = QLabel("")
        self.status.setWordWrap(True)
        self.image = QLabel("")
        self.image.setObjectName("chartProofPicture")
        self.image.setAlignment(Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignTop)
        self.legend = QLabel("")
        lay = QVBoxLayout(self)
        lay.addLayout(row)
        lay.addWidget(self.status)
        lay.addWidget(self.legend)
        lay.addWidget(self.image, 1)
        self._t0 = 0.0
        self._clock = QTimer(self, interval=500)
        self._clock.timeout.connect(self._tick)
        self._set_running(False)

    @property
    def running(self) -> bool:
        return self._task is not None and self._task.outcome is None \
            and not self._task.cancel_event.is_set()

    def _set_running(self, running: bool) -> None:
        self.run_button.setEnabled(not running)
        self.stop_button.setVisible(running)
        self.bar.setVisible(running)
        self._run_clock(running)

    def _tick(self) -> None:
        self.elapsed.setText(f"rendering {time.monotonic() - self._t0:.0f} s")

    def _inputs(self):
        fit = self.wiz.fit_page.result
        chart = self.wiz.chart_page
        if fit is None or chart.recipes is None or chart.reflectance is None:
            raise DreamPrintError("no chart calibration to proof: give a mixture chart (second "
                                  "page) and fit")
        return fit[0], chart.recipes, chart.reflectance

    def start(self) -> None:
        """Render the chart with the fitted profile on a worker thread."""
        self.stop()
        self.report = self.picture = None
        self.error_text = ""
        self.image.clear()
        self.legend.setText("")
        try:
            profile, recipes, refl = self._inputs()
        except DreamPrintError as exc:
            self._failed(str(exc), "")
            return
        geometry, spp = self.geometry.currentText(), int(self.spp.value())

        def job(report, cancel):
            from dreamprint_gui.proof.chart import (
                ChartSettings,
                chart_from_arrays,
                chart_picture,
                proof_chart,
            )

            chart = chart_from_arrays(recipes, refl, profile, geometry=geometry)
            s = ChartSettings(recipes="(calibration wizard)", geometry=geometry, spp=spp)
            rep, band_R, bands = proof_chart(chart, s, progress=lambda d, t: report((d, t)),
                                             cancelled=cancel.is_set)
            return rep, chart_picture(chart, band_R, bands)

        self.status.setText("")
        self.status.setStyleSheet("")
        self.bar.setMaximum(1)
        self.bar.setValue(0)
        self._start_task(job, "chart-proof")

    def _progress(self, item) -> None:
        done, total = item
        self.bar.setMaximum(int(total))
        self.bar.setValue(int(done))

    def stop(self) -> None:
        """Stop the running proof: the page is ready at once; the render ends after its
        current pass and its result is dropped."""
        if not self.running:
            return
        self._task.cancel()
        self._set_running(False)
        self.elapsed.setText(f"stopped after {time.monotonic() - self._t0:.0f} s")
        self.status.setText("The chart proof was stopped.")
        self.status.setStyleSheet("")

    def _finished(self) -> None:
        if self._task.outcome != "cancelled":
            self._set_running(False)
            self.elapsed.setText(f"rendered in {time.monotonic() - self._t0:.0f} s"
                                 if self._task.outcome == "succeeded" else "")

    def _failed(self, message: str, _tb: str) -> None:
        self.error_text = message
        self.status.setText(f"The chart proof failed: {message}")
        self.status.setStyleSheet(ERROR_STYLE)

    def _done(self, result) -> None:
        from PySide6.QtGui import QImage, QPixmap

        rep, picture = result
        self.report, self.picture = rep, picture
        de = rep["de2000"]
        worst = ", ".join(f"#{w['patch']} ({w['de2000']:.1f})" for w in de["worst_patches"])
        self.status.setText(
            f"<b>{rep['patches_count']} patches</b>, {rep['geometry']}, surface "
            f"{rep['optics']['surface']}, phase {rep['optics']['phase']}: dE2000 mean "
            f"<b>{de['mean']:.2f}</b>, p95 {de['p95']:.2f}, max {de['max']:.2f}; worst patches "
            f"{worst}.<br>The profile was fitted to these patches: this checks that the proof "
            "renders what the calibration predicts; the Fit page's cross-validated figure says "
            "how well new mixtures are predicted.")
        self.legend.setText("Each square: measured (left half), proofed (right half).")
        h, w = picture.shape[:2]
        img = QImage(np.ascontiguousarray(picture).data, w, h, 3 * w,
                     QImage.Format.Format_RGB888).copy()
        self.image.setPixmap(QPixmap.fromImage(img))

    def cleanupPage(self) -> None:  # noqa: N802 - Qt override
        self.stop()


class SavePage(QWizardPage):
    """Name and file of the new profile; saving makes it active."""

    def __init__(self, wizard: CalibrationWizard) -> None:
        super().__init__()
        self.wiz = wizard
        self.saved_path: str | None = None
        self.setTitle("Save the profile")
        self.setSubTitle("The saved profile becomes the active one.")
        self.name_edit = QLineEdit(wizard.default_name)
        self.path_edit = QLineEdit(str(Path(wizard.settings.last_folder("profile"))
                                       / f"{wizard.default_name}.json"))
        browse = QPushButton("...")
        browse.setMaximumWidth(32)
        browse.clicked.connect(self._browse)
        row = QHBoxLayout()
        row.addWidget(self.path_edit, 1)
        row.addWidget(browse)
        self.error = QLabel("")
        self.error.setStyleSheet(ERROR_STYLE)
        self.error.setWordWrap(True)
        # the ICC output profile of the print with the profile just fitted (issue 48)
        self.icc = IccExportBox(self._icc_request, wizard.settings, self)
        self.icc.setToolTip("For soft proofs in other applications: the print with the fitted "
                            "inks, the colour table built first (about half a minute)")
        form = QFormLayout(self)
        form.addRow("Name", self.name_edit)
        form.addRow("File", row)
        form.addRow(self.error)
        form.addRow("ICC profile", self.icc)
        self.setFinalPage(True)

    def _icc_request(self) -> IccRequest | None:
        fit = self.wiz.fit_page.result
        if fit is None:
            return None
        name = self.name_edit.text().strip() or self.wiz.default_name
        return IccRequest(fit[0].with_settings(name=name))

    def _browse(self) -> None:
        path, _ = QFileDialog.getSaveFileName(self, "Save ink profile", self.path_edit.text(),
                                              "Ink profiles (*.json)")
        if path:
            self.path_edit.setText(path)

    def validatePage(self) -> bool:  # noqa: N802 - Qt override
        from dreamprint_gui.core.profile import save_profile

        fit = self.wiz.fit_page.result
        if fit is None:
            self.error.setText("nothing fitted yet")
            return False
        name = self.name_edit.text().strip() or self.wiz.default_name
        path = self.path_edit.text().strip()
        if not path:
            self.error.setText("choose a file")
            return False
        if not path.lower().endswith(".json"):
            path += ".json"
        profile = fit[0].with_settings(name=name)
        try:
            save_profile(profile, path)
        except DreamPrintError as exc:
            self.error.setText(str(exc))
            return False
        self.saved_path = path
        self.wiz.settings.set_last_folder("profile", path)
        self.wiz.profileSaved.emit(profile, path)
        return True


class CalibrationWizard(QWizard):
    """From measurements to an active profile, without a terminal."""

    profileSaved = Signal(object, str)

    def __init__(self, parent: QWidget | None = None, settings: AppSettings | None = None,
                 base_profile=None, calibration_set: str | None = None) -> None:
        super().__init__(parent)
        from dreamprint_gui.core.profile import default_profile

        self.settings = settings or AppSettings()
        self.base_profile = base_profile or getattr(parent, "profile", None) or default_profile()
        self.default_name = f"calibrated-{_dt.date.today().isoformat()}"
        self.setWindowTitle("DreamPrint: calibrate inks")
        self.setWizardStyle(QWizard.WizardStyle.ClassicStyle)
        self.setOption(QWizard.WizardOption.NoBackButtonOnLastPage, False)
        self.measurements_page = MeasurementsPage(self)
        self.slab_page = SlabPage(self)
        self.chart_page = ChartPage(self)
        self.fit_page = FitPage(self)
        self.chart_proof_page = ChartProofPage(self)
        self.save_page = SavePage(self)
        self.page_ids = {p: self.addPage(p) for p in (
            self.measurements_page, self.slab_page, self.chart_page, self.fit_page,
            self.chart_proof_page, self.save_page)}
        self.resize(1000, 720)
        if calibration_set:
            self.measurements_page.load_set(calibration_set)

    def slab_options(self) -> SlabOptions | None:
        """The slab fit's options when the measurements are slabs measured in air, else None
        (:class:`~dreamprint_gui.physics.slab_fit.SlabOptions`, as ``calibrate --slabs``)."""
        if not self.measurements_page.slabs_box.isChecked():
            return None
        return self.slab_page.options()

    def done(self, result: int) -> None:
        """Closing the wizard (Cancel, Esc, Finish) abandons a fit or chart proof still
        running."""
        self.fit_page.stop()
        self.chart_proof_page.stop()
        self.save_page.icc.shutdown()  # an ICC export under way finishes its file unseen
        super().done(result)
