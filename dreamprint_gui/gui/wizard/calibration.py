"""The calibration wizard: its pages in order, and what they share at run time.

:class:`CalibrationWizard` (a QWizard) holds the base profile, the application's settings
and the default profile name the pages read, and abandons a fit or chart proof still running
when it closes.
"""

from __future__ import annotations

import datetime as _dt

from PySide6.QtCore import Signal
from PySide6.QtWidgets import QWidget, QWizard

from dreamprint_gui.gui.settings import AppSettings
from dreamprint_gui.gui.wizard.chart import ChartPage
from dreamprint_gui.gui.wizard.chart_proof import ChartProofPage
from dreamprint_gui.gui.wizard.fit import FitPage
from dreamprint_gui.gui.wizard.measurements import MeasurementsPage
from dreamprint_gui.gui.wizard.save import SavePage
from dreamprint_gui.gui.wizard.slabs import SlabPage
from dreamprint_gui.physics.slab_fit import SlabOptions

__all__ = ["CalibrationWizard"]


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
