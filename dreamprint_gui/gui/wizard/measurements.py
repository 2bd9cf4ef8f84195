"""The calibration wizard's first page: per ink, the files of its reflectance and transmittance.

:class:`MeasurementsPage`: per ink, the files holding its reflectance and transmittance (any
format ``io.spectra.read_spectra`` reads), the sample in each (the picked one is the one used:
only its own impossible values refuse it, naming it; ``calibration_set.measured_values``),
what each file holds when it does not say (the CLI's ``--file-quantity``: an absorbance file
is read as T = 10^-A), and the swatch thickness, required (no default: the page names the
inks lacking it); or a calibration set (TOML, ``io.spectra.calibration_set``; several
thicknesses per ink). Every parsed spectrum is plotted at once, resampled onto the profile's
grid; each file's problem shows on its own row. A tick, "slabs measured in air", leads to
the slab page (:mod:`.slabs`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from PySide6.QtWidgets import (
    QCheckBox,
    QComboBox,
    QDoubleSpinBox,
    QFileDialog,
    QGridLayout,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QPushButton,
    QVBoxLayout,
    QWidget,
    QWizard,
    QWizardPage,
)

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.profile import INKS
from dreamprint_gui.gui.wizard.common import ERROR_STYLE, INK_COLOURS, SPECTRA_FILTER, canvas

__all__ = ["MeasurementsPage", "FILE_QUANTITIES", "QUANTITY_NAMES"]

log = logging.getLogger(__name__)


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

    def __init__(self, wizard: QWizard) -> None:
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
