"""The wizard's slab page (issue 43): real instrument files per slab, a thickness per row, the
series and what it separates, the fit inside both faces, the Clear marked measured."""

from __future__ import annotations

import numpy as np

from dreamprint_gui.core.profile import default_profile, ink_origins
from dreamprint_gui.gui.wizard.calibration import CalibrationWizard

XRITE = "X-Rite_Digital_Colour_Checker.txt"
RESIN = "resin_PR48_absorbance_2015-07-27.csv"


def _clear_series(wiz, formats, thicknesses=(1.0, 2.0, 4.0)):
    """Clear slabs: R from the Spectrolino export's samples X1.., T from the resin's real
    absorbance (stated as absorbance), one row per thickness."""
    page = wiz.measurements_page
    rows = [page.rows["Cl"]] + [page.add_row("Cl") for _ in thicknesses[1:]]
    for k, (row, t) in enumerate(zip(rows, thicknesses, strict=True)):
        row.thickness.setValue(t)
        row.load("R", str(formats / XRITE), sample=f"X{k + 1}")
        row.set_file_quantity("T", "absorbance")
        row.load("T", str(formats / RESIN))
    return page


def test_slab_page_series_fit_and_origin(qtbot, shared_data):
    formats = shared_data / "spectra" / "formats"
    wiz = CalibrationWizard(None, base_profile=default_profile())
    qtbot.addWidget(wiz)
    wiz.show()
    page = _clear_series(wiz, formats)
    assert page.isComplete() and len(page.measurements()) == 3
    page.slabs_box.setChecked(True)
    wiz.next()
    slab = wiz.slab_page
    assert wiz.currentPage() is slab and slab.isComplete()
    text = slab.series.text()
    # these real files are no slabs in air: the Spectrolino's R excludes the specular part,
    # the liquid resin's T exceeds what two faces pass; the page says both before any fit
    assert "1, 2, 4 mm" in text and "measured without the specular component (SCE)" in text
    assert "exceeds what the two faces of n 1.5 pass (0.922)" in text
    assert "k1 0.040" in slab.faces.text() and "k2 0.596" in slab.faces.text()
    # T and R against thickness at three wavelengths
    assert len(slab.figure.axes[0].lines) == 3 and len(slab.figure.axes[1].lines) == 3
    slab.fit_k2.setChecked(True)
    wiz.next()  # chart page (empty)
    wiz.next()  # fit
    with qtbot.waitSignal(wiz.fit_page.fitted, timeout=120000):
        pass
    profile, fits, _ = wiz.fit_page.result
    assert fits[0].k2_fitted and fits[0].ink == "Cl"
    text = wiz.fit_page.status.text()
    assert "per slab: dE2000 R / T" in text and "4 mm:" in text
    assert text.count("does not fit") == 3  # no slab reads like a slab in air
    assert ink_origins(profile)["Cl"] == "measured"
    assert np.isfinite(profile.K).all()


def test_one_thickness_is_said_on_the_slab_page(qtbot, shared_data):
    formats = shared_data / "spectra" / "formats"
    wiz = CalibrationWizard(None, base_profile=default_profile())
    qtbot.addWidget(wiz)
    wiz.show()
    page = _clear_series(wiz, formats, thicknesses=(2.0,))
    page.slabs_box.setChecked(True)
    wiz.next()
    text = wiz.slab_page.series.text()
    assert "one thickness (2 mm) cannot separate the slab&#x27;s faces from its bulk" in text


def test_without_the_tick_the_chart_page_follows(qtbot, shared_data):
    wiz = CalibrationWizard(None, base_profile=default_profile())
    qtbot.addWidget(wiz)
    wiz.show()
    _clear_series(wiz, shared_data / "spectra" / "formats", thicknesses=(2.0,))
    wiz.next()
    assert wiz.currentPage() is wiz.chart_page and wiz.slab_options() is None
