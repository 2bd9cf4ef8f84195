"""The calibration wizard end to end: measurement files -> fit -> saved, active profile.

The measurements are generated from a known profile with the engine's forward model (eqs. 3-4)
and written in two instrument formats, so the fitted K and S have a known answer; a real sample
file from ../shared/data and a damaged file check parsing and the inline errors.
"""

from __future__ import annotations

import numpy as np
import pytest
from PySide6.QtWidgets import QWizard

from dreamprint_gui.core.profile import INKS, default_profile, load_profile
from dreamprint_gui.gui.wizard import CalibrationWizard
from dreamprint_gui.io.spectra import Sample, write_spectra
from dreamprint_gui.physics.kubelka_munk import reflectance_transmittance

THICKNESS_MM = 0.4


@pytest.fixture
def truth():
    """A profile differing from the default one, so a fit that ignored the files would fail."""
    base = default_profile()
    scale = np.linspace(0.7, 1.3, base.wavelengths_nm.size)
    return base.with_settings(name="truth", K=base.K * scale, S=base.S * scale[::-1])


@pytest.fixture
def measurement_files(tmp_path, truth):
    wl = truth.wavelengths_nm
    R, T = reflectance_transmittance(truth.K, truth.S, THICKNESS_MM)
    r_samples = [Sample(ink, wl, R[i]) for i, ink in enumerate(INKS)]
    t_samples = [Sample(ink, wl, T[i]) for i, ink in enumerate(INKS)]
    r_path, t_path = tmp_path / "inks_R.csv", tmp_path / "inks_T.csv"
    write_spectra(r_path, r_samples, quantity="reflectance", format="csv-rows")
    write_spectra(t_path, t_samples, quantity="transmittance", format="csv-columns")
    return r_path, t_path


def _load_rows(wiz, r_path, t_path, inks=INKS):
    page = wiz.measurements_page
    for ink in inks:
        row = page.rows[ink]
        row.thickness.setValue(THICKNESS_MM)
        row.load("R", str(r_path))
        row.load("T", str(t_path))
    return page


def test_wizard_end_to_end(qtbot, tmp_path, truth, measurement_files):
    r_path, t_path = measurement_files
    wiz = CalibrationWizard(None, base_profile=default_profile())
    qtbot.addWidget(wiz)
    wiz.show()
    page = _load_rows(wiz, r_path, t_path)
    # each row picked the sample named after its ink, and every spectrum is plotted
    assert [page.rows[i].combos["R"].currentText() for i in INKS] == list(INKS)
    axes = page.figure.axes
    assert len(axes[0].lines) == len(INKS) and len(axes[1].lines) == len(INKS)
    assert page.isComplete()

    wiz.next()  # chart page (left empty)
    assert wiz.currentPage() is wiz.chart_page and wiz.chart_page.isComplete()
    wiz.next()  # fit page: the fit runs on a worker thread
    fit_page = wiz.fit_page
    with qtbot.waitSignal(fit_page.fitted, timeout=60000):
        pass
    profile, fits, chart_fit = fit_page.result
    assert chart_fit is None and {f.ink for f in fits} == set(INKS)
    # noise-free forward data: the inversion recovers K and S (closed form round trip)
    for i, ink in enumerate(INKS[:5]):
        np.testing.assert_allclose(profile.K[i], truth.K[i], rtol=2e-3, err_msg=ink)
        np.testing.assert_allclose(profile.S[i], truth.S[i], rtol=2e-3, err_msg=ink)
    R_fit, T_fit = reflectance_transmittance(profile.K, profile.S, THICKNESS_MM)
    R_true, T_true = reflectance_transmittance(truth.K, truth.S, THICKNESS_MM)
    np.testing.assert_allclose(R_fit, R_true, atol=1e-5)
    np.testing.assert_allclose(T_fit, T_true, atol=1e-5)
    # plots, not tables: measured dots and fitted lines per ink, residual curves
    assert len(fit_page.fit_fig.axes) == 2 * len(INKS)
    assert sum(len(ax.lines) for ax in fit_page.res_fig.axes) == 2 * len(INKS)

    wiz.next()
    save = wiz.save_page
    out = tmp_path / "my-inks.json"
    save.name_edit.setText("my inks")
    save.path_edit.setText(str(out))
    with qtbot.waitSignal(wiz.profileSaved, timeout=5000) as blocker:
        wiz.button(QWizard.WizardButton.FinishButton).click()
    saved, path = blocker.args
    assert path == str(out) and saved.name == "my inks"
    loaded = load_profile(out)
    np.testing.assert_allclose(loaded.K, profile.K)
    assert loaded.provenance["measurements"]


def test_real_instrument_file_and_inline_errors(qtbot, tmp_path, shared_data):
    wiz = CalibrationWizard(None, base_profile=default_profile())
    qtbot.addWidget(wiz)
    page = wiz.measurements_page
    row = page.rows["C"]
    xrite = shared_data / "spectra" / "formats" / "X-Rite_Digital_Colour_Checker.txt"
    row.load("R", str(xrite))
    assert row.combos["R"].count() == 10  # every patch of the file is offered
    assert row.channels["R"].values is not None and not row.error.isVisibleTo(page)
    assert len(page.figure.axes[0].lines) == 1

    bad = tmp_path / "garbled.csv"
    bad.write_bytes(b"\x00\x01garbage,,,\nnot,a,spectrum\n")
    row_m = page.rows["M"]
    row_m.load("T", str(bad))  # no exception: the problem shows on the row
    assert row_m.error.isVisibleTo(page)
    assert "garbled.csv" in row_m.error.text()
    assert not page.isComplete()
    row_m.load("T", "")  # clearing the file clears the problem
    assert not row_m.error.isVisibleTo(page) and page.isComplete()

    missing = tmp_path / "absent.csv"
    row_m.load("R", str(missing))
    assert "absent.csv" in row_m.error.text()


def test_cary_file_with_mixed_y_modes(qtbot, tmp_path):
    """A Cary export with %R, %T and Abs samples: the T row reads the Abs sample as T = 10^-A,
    picks a usable sample by itself, and names the quantity of one it cannot use."""
    wl = default_profile().wavelengths_nm
    r, t = 0.3 + 0.2 * np.sin(wl / 50), 0.2 + 0.1 * np.cos(wl / 40)
    rows = ["white,,cyan T,,cyan A,", "Wavelength (nm),%R,Wavelength (nm),%T,Wavelength (nm),Abs"]
    rows += [f"{w:g},{100 * a:.8f},{w:g},{100 * b:.8f},{w:g},{-np.log10(b):.10f}"
             for w, a, b in zip(wl, r, t, strict=True)]
    p = tmp_path / "mixed.csv"
    p.write_text("\n".join(rows) + "\n")
    wiz = CalibrationWizard(None, base_profile=default_profile())
    qtbot.addWidget(wiz)
    row = wiz.measurements_page.rows["C"]
    row.load("T", str(p))
    assert row.combos["T"].count() == 3 and row.combos["T"].currentIndex() == 1
    np.testing.assert_allclose(row.channels["T"].values, t, atol=1e-9)
    row.combos["T"].setCurrentIndex(2)
    np.testing.assert_allclose(row.channels["T"].values, t, rtol=1e-8)
    row.combos["T"].setCurrentIndex(0)
    assert row.channels["T"].values is None
    assert "holds reflectance, not transmittance" in row.error.text()
    row.load("R", str(p))
    np.testing.assert_allclose(row.channels["R"].values, r, atol=1e-9)


def test_chart_only_calibration(qtbot, tmp_path, truth):
    """A mixture chart alone: the refit brings the prediction closer to the measured patches
    than the base profile, and the cross-validated dE2000 is reported and plotted."""
    from dreamprint_gui.physics.mixture import predict

    rng = np.random.default_rng(3)
    recipes = rng.dirichlet(np.ones(5) * 0.6, size=14)
    R = predict(truth, recipes, thickness_mm=np.inf).R
    rec_path = tmp_path / "recipes.csv"
    rec_path.write_text("C,M,Y,K,W\n" + "\n".join(",".join(f"{v:.10f}" for v in r)
                                                 for r in recipes) + "\n")
    spec_path = tmp_path / "patches.csv"
    wl = truth.wavelengths_nm
    write_spectra(spec_path, [Sample(f"P{i}", wl, R[i]) for i in range(len(R))],
                  quantity="reflectance", format="csv-rows")

    wiz = CalibrationWizard(None, base_profile=default_profile())
    qtbot.addWidget(wiz)
    wiz.show()
    assert wiz.measurements_page.isComplete()  # measurements are optional with a chart
    wiz.next()
    chart = wiz.chart_page
    chart.recipes_edit.setText(str(rec_path))
    chart.spectra_edit.setText(str(spec_path))
    chart.folds.setValue(2)  # the refit is slow (about a second per fit); keep the test short
    chart.load()
    assert not chart.error.text() and chart.info.text() == "14 patches"
    wiz.next()
    with qtbot.waitSignal(wiz.fit_page.fitted, timeout=120000):
        pass
    _, fits, chart_fit = wiz.fit_page.result
    assert fits == [] and chart_fit is not None
    report = chart_fit.report()
    assert report["fit_dE2000"]["mean"] < report["base_dE2000"]["mean"]
    assert "cross-validated dE2000" in wiz.fit_page.status.text()
    assert len(wiz.fit_page.chart_fig.axes[0].patches) == 2 * 14  # fit and CV bars


def test_chart_file_problem_is_inline(qtbot, tmp_path):
    wiz = CalibrationWizard(None, base_profile=default_profile())
    qtbot.addWidget(wiz)
    chart = wiz.chart_page
    bad = tmp_path / "recipes.csv"
    bad.write_text("C,M,Q\n0.5,0.5,0\n")
    chart.recipes_edit.setText(str(bad))
    chart.spectra_edit.setText(str(tmp_path / "absent.csv"))
    chart.load()
    assert chart.error.text() and not chart.isComplete()


def test_calibration_set_fills_the_page(qtbot, tmp_path):
    from pathlib import Path

    set_path = Path(__file__).resolve().parents[1] / "data" / "calibration_set" / "set.toml"
    wiz = CalibrationWizard(None, base_profile=default_profile(),
                            calibration_set=str(set_path))
    qtbot.addWidget(wiz)
    page = wiz.measurements_page
    assert page.set_measurements, page.set_label.text()
    assert page.isComplete() and not page.rows["C"].edits["R"].isEnabled()
    n_lines = sum(len(ax.lines) for ax in page.figure.axes)
    assert n_lines == sum((m.R is not None) + (m.T is not None) for m in page.set_measurements)
    bad = tmp_path / "bad.toml"
    bad.write_text("[inks\n")
    page.load_set(str(bad))
    assert page.set_measurements is None and "bad.toml" in page.set_label.text()


def test_stopping_a_running_chart_fit(qtbot, tmp_path, truth, monkeypatch):
    """Stop returns the page at once; the abandoned fit's result, when it comes, is dropped."""
    import threading

    from dreamprint_gui.physics import chart_calibration
    from dreamprint_gui.physics.mixture import predict

    started, release, returned = threading.Event(), threading.Event(), threading.Event()

    def slow_fit(profile, recipes, reflectance, **kw):  # stands in for a minute-long fit
        started.set()
        release.wait(60)
        returned.set()
        return chart_calibration.ChartFit.__new__(chart_calibration.ChartFit)

    monkeypatch.setattr(chart_calibration, "fit_chart", slow_fit)
    rng = np.random.default_rng(4)
    recipes = rng.dirichlet(np.ones(5), size=12)
    R = predict(truth, recipes, thickness_mm=np.inf).R
    rec_path, spec_path = tmp_path / "recipes.csv", tmp_path / "patches.csv"
    rec_path.write_text("C,M,Y,K,W\n" + "\n".join(",".join(f"{v:.10f}" for v in r)
                                                 for r in recipes) + "\n")
    write_spectra(spec_path, [Sample(f"P{i}", truth.wavelengths_nm, R[i])
                              for i in range(len(R))], quantity="reflectance",
                  format="csv-rows")
    wiz = CalibrationWizard(None, base_profile=default_profile())
    qtbot.addWidget(wiz)
    wiz.show()
    wiz.next()
    wiz.chart_page.recipes_edit.setText(str(rec_path))
    wiz.chart_page.spectra_edit.setText(str(spec_path))
    wiz.chart_page.load()
    wiz.next()
    page = wiz.fit_page
    fitted: list = []
    page.fitted.connect(fitted.append)
    assert started.wait(30) and page.running
    assert page.stop_button.isVisibleTo(wiz) and not page.again_button.isVisibleTo(wiz)
    qtbot.waitUntil(lambda: "12 patches" in page.elapsed.text(), timeout=10000)

    page.stop_button.click()  # returns at once although the fit is still running
    assert not returned.is_set()
    assert not page.running and not page.isComplete()
    assert page.again_button.isVisibleTo(wiz) and not page.stop_button.isVisibleTo(wiz)
    assert "stopped" in page.status.text() and "stopped after" in page.elapsed.text()

    release.set()
    assert returned.wait(30)
    qtbot.wait(300)  # the late result would arrive by now: it is dropped
    assert page.result is None and fitted == [] and not page.isComplete()
