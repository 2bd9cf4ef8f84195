"""The calibration wizard's last page: name and file of the profile, and its ICC output
profile; saving makes the profile active (``profileSaved``) (:class:`SavePage`).
"""

from __future__ import annotations

import logging
from pathlib import Path

from PySide6.QtWidgets import (
    QFileDialog,
    QFormLayout,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QPushButton,
    QWizard,
    QWizardPage,
)

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.gui.icc_export import IccExportBox, IccRequest
from dreamprint_gui.gui.wizard.common import ERROR_STYLE

__all__ = ["SavePage"]

log = logging.getLogger(__name__)


class SavePage(QWizardPage):
    """Name and file of the new profile; saving makes it active."""

    def __init__(self, wizard: QWizard) -> None:
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
