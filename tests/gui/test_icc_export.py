""""Export ICC profile" in the GUI (issue 48): beside the gamut view, on the wizard's last page."""

from __future__ import annotations

from dreamprint_gui.core.profile import default_profile
from dreamprint_gui.gamut import get_tables, lcms
from dreamprint_gui.gui.gamut_view import GamutPage
from dreamprint_gui.gui.icc_export import IccExportBox, IccRequest
from dreamprint_gui.gui.wizard.calibration import CalibrationWizard


def test_export_box_writes_the_profile_and_says_its_figures(qtbot, tmp_path, table_size):
    profile = default_profile()
    tables = get_tables(profile, size=table_size)
    box = IccExportBox(lambda: IccRequest(profile, tables, "colorimetric", table_size, "J850"))
    qtbot.addWidget(box)
    box.cgats.setChecked(True)
    path = tmp_path / "j850.icc"
    with qtbot.waitSignal(box.exported, timeout=120000) as sig:
        box.export_to(str(path))
        assert not box.button.isEnabled()  # one export at a time
    report = sig.args[0]
    assert lcms.profile_info(path.read_bytes())["description"].startswith("DreamPrint J850")
    assert (tmp_path / "j850.ti3").read_text().startswith("CTI3")
    text = box.status.text()
    assert text.startswith("Wrote j850.icc (ICC 2.4, colorimetric intent)")
    assert f"{report['check']['a2b_dE2000']['mean']:.2f} (mean)" in text
    assert report["check"]["a2b_dE2000"]["mean"] <= 1.0
    qtbot.waitUntil(box.button.isEnabled)
    # a folder that does not exist: one line, nothing written
    bad = tmp_path / "missing" / "p.icc"
    with qtbot.waitSignal(box.failed, timeout=30000) as sig:
        box.export_to(str(bad))
    assert "does not exist" in sig.args[0] and "Traceback" not in box.status.text()
    assert box.status.text().startswith("ICC export failed:")
    assert not bad.parent.exists()


def test_gamut_page_and_wizard_offer_the_export(qtbot, table_size):
    page = GamutPage()
    qtbot.addWidget(page)
    assert page.icc.button.text() == "Export ICC profile..."
    assert page._icc_request() is None  # no profile yet
    profile = default_profile()
    page.profile = profile
    page.printer_name = "Stratasys J850"
    page.set_intent("perceptual")
    req = page._icc_request()
    assert req.profile is profile and req.intent == "perceptual"
    assert req.tables is None and req.printer == "Stratasys J850"  # built on export
    page.shutdown()

    wiz = CalibrationWizard()
    qtbot.addWidget(wiz)
    assert wiz.save_page.icc.button.text() == "Export ICC profile..."
    assert wiz.save_page._icc_request() is None  # nothing fitted yet
    wiz.fit_page.result = (profile, None, None)
    wiz.save_page.name_edit.setText("my-inks")
    assert wiz.save_page._icc_request().profile.name == "my-inks"
