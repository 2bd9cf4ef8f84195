"""The calibration wizard's chart page (optional): a mixture chart, recipes (``--mix-file``
CSV) and the measured reflectance of each patch (:class:`ChartPage`).
"""

from __future__ import annotations

import logging

from PySide6.QtWidgets import (
    QFileDialog,
    QFormLayout,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QPushButton,
    QSpinBox,
    QVBoxLayout,
    QWizard,
    QWizardPage,
)

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.gui.wizard.common import ERROR_STYLE, SPECTRA_FILTER, canvas

__all__ = ["ChartPage"]

log = logging.getLogger(__name__)


class ChartPage(QWizardPage):
    """Optional: a printed mixture chart to refit the inks jointly (minimising dE2000)."""

    def __init__(self, wizard: QWizard) -> None:
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
