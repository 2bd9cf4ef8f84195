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
from dreamprint_gui.gui.wizard.calibration import CalibrationWizard
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
    row.thickness.setValue(0.5)
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
    # each fit of the refit was said as it started (issue 46: a minute with one message)
    qtbot.waitUntil(lambda: "refitted to the chart's 14 patches (3 fits)"
                    in wiz.fit_page._stage, timeout=5000)

    # after a chart calibration the wizard offers the chart proof (issue 28)
    wiz.next()
    page = wiz.chart_proof_page
    assert wiz.currentPage() is page and page.isComplete()     # optional: Next skips it
    page.spp.setValue(16)
    page.run_button.click()
    assert page.running and page.stop_button.isVisibleTo(wiz)
    qtbot.waitUntil(lambda: page.report is not None or bool(page.error_text), timeout=300000)
    assert not page.error_text, page.error_text
    rep = page.report
    assert rep["patches_count"] == 14 and rep["optics"]["surface"] == "none"
    import colour

    de = [colour.delta_E(r["measured_lab"], r["proof_lab"], method="CIE 2000")
          for r in rep["patches"]]
    assert rep["de2000"]["mean"] == pytest.approx(np.mean(de), abs=2e-3)
    assert f"{rep['de2000']['mean']:.2f}" in page.status.text()
    assert f"#{rep['de2000']['worst_patches'][0]['patch']} " in page.status.text()
    pix = page.image.pixmap()
    assert not pix.isNull() and (pix.width(), pix.height()) == page.picture.shape[1::-1]
    assert not page.running and page.bar.value() == page.bar.maximum() == 4  # 12 bands / 3
    wiz.next()
    assert wiz.currentPage() is wiz.save_page


def _chart_proof_page(qtbot, truth, profile=None):
    """The chart proof page with a fitted profile and a chart in place (no fit run)."""
    from dreamprint_gui.physics.mixture import predict

    recipes = np.random.default_rng(5).dirichlet(np.ones(5), size=6)
    recipes = np.hstack([recipes, np.zeros((6, 1))])
    wiz = CalibrationWizard(None, base_profile=default_profile())
    qtbot.addWidget(wiz)
    wiz.chart_page.recipes = recipes
    wiz.chart_page.reflectance = predict(truth, recipes[:, :5], thickness_mm=np.inf).R
    wiz.fit_page.result = (profile or truth, [], object())
    return wiz, wiz.chart_proof_page


def test_chart_proof_stops_at_once_and_errors_are_one_line(qtbot, truth):
    wiz, page = _chart_proof_page(qtbot, truth)
    wiz.show()
    page.spp.setValue(4096)
    page.run_button.click()
    assert page.running
    page.stop_button.click()                    # returns at once; the pass ends in the back
    assert not page.running and "stopped" in page.status.text()
    assert page.run_button.isEnabled() and not page.stop_button.isVisibleTo(wiz)
    qtbot.wait(200)
    assert page.report is None

    d = truth.to_json_dict()
    d["proof"] = {"surface": "glossy"}
    from dreamprint_gui.core.profile import profile_from_dict

    wiz2, page2 = _chart_proof_page(qtbot, truth, profile_from_dict(d))
    page2.geometry.setCurrentText("45:0")
    page2.run_button.click()
    qtbot.waitUntil(lambda: bool(page2.error_text), timeout=30000)
    assert "cannot be proofed at 45:0" in page2.status.text()
    assert "Traceback" not in page2.status.text() and "\n" not in page2.error_text
    assert page2.report is None and page2.run_button.isEnabled()

    wiz2.chart_page.recipes = None                    # no chart: said, nothing runs
    page2.run_button.click()
    assert "no chart calibration" in page2.status.text() and not page2.running


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


def _wizard_fitting_a_chart(qtbot, tmp_path, truth):
    """A wizard whose fit page has started fitting a 12-patch chart."""
    from dreamprint_gui.physics.mixture import predict

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
    return wiz


def test_a_chart_fit_shows_its_iterations(qtbot, tmp_path, truth, monkeypatch):
    """A fit (seconds each on a real chart) shows its iterations as they go (issue 46)."""
    import threading

    from dreamprint_gui.physics import chart_calibration

    release = threading.Event()

    def fit_reporting(profile, recipes, reflectance, progress=None, **kw):
        progress(0, 3)
        progress(0, 3, "fit 1: iteration 4 of at most 100")
        release.wait(60)
        raise chart_calibration.DreamPrintError("stopped by the test")

    monkeypatch.setattr(chart_calibration, "fit_chart", fit_reporting)
    wiz = _wizard_fitting_a_chart(qtbot, tmp_path, truth)
    page = wiz.fit_page
    qtbot.waitUntil(lambda: "iteration 4 of at most 100" in page.elapsed.text(), timeout=10000)
    assert "fit 1 of 3" in page.elapsed.text()
    release.set()
    qtbot.waitUntil(lambda: not page.running, timeout=10000)


def test_stopping_a_running_chart_fit(qtbot, tmp_path, truth, monkeypatch):
    """Stop returns the page at once; the abandoned fit's result, when it comes, is dropped."""
    import threading

    from dreamprint_gui.physics import chart_calibration

    started, release, returned = threading.Event(), threading.Event(), threading.Event()

    def slow_fit(profile, recipes, reflectance, **kw):  # stands in for a minute-long fit
        started.set()
        release.wait(60)
        returned.set()
        return chart_calibration.ChartFit.__new__(chart_calibration.ChartFit)

    monkeypatch.setattr(chart_calibration, "fit_chart", slow_fit)
    wiz = _wizard_fitting_a_chart(qtbot, tmp_path, truth)
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


# -- issue 27: a wizard to trust ----------------------------------------------------------------

FILTERS = ["600LP", "600LP1", "600LP2", "550LP", "600SP800N", "600SP800N1", "530SP", "GSBS",
           "550LP2", "530SP2", "530SP_HI"]


def _edge(wl, cut, width=6.0):
    return 1.0 / (1.0 + np.exp(-(wl - cut) / width))


def _write_cary_filters(path):
    """A Cary export of 11 filters laid out like WrightTools' datasets/Cary/filters.csv: 600LP
    in Abs from 800 to 200 nm on the scan's uneven 5 nm steps, its blocked band saturating
    (alternating 10 and about 3.7), the others in %T over 750-450 nm with the instrument's noise;
    600LP1 dips below 0 % and 550LP2 exceeds 100 % beyond the tolerance. Returns 600LP's T."""
    rng = np.random.default_rng(0)
    cols = []
    wl = np.arange(800.0, 199.0, -5.0) + rng.uniform(-0.08, 0.08, 121)
    t_600lp = 0.94 * _edge(wl, 600.0)
    blocked = wl < 590
    A = -np.log10(np.maximum(t_600lp, 1e-4)) + rng.normal(0, 0.3, wl.size) * blocked
    A[blocked & (np.arange(wl.size) % 2 == 0)] = 10.0
    cols.append(("600LP", "Abs", wl, A))
    for name in FILTERS[1:]:
        w = np.arange(750.0, 449.0, -1.0)
        cut = float(name[:3]) if name[:3].isdigit() else 500.0
        T = 100 * (0.9 * _edge(w, cut) if "LP" in name else 0.9 * (1 - _edge(w, cut)))
        T = T + rng.normal(0, 0.03, w.size)
        if name == "600LP1":
            T[(w > 510) & (w < 514)] = -0.12
        if name == "550LP2":
            T[w < 500] = 100.14
        cols.append((name, "%T", w, T))
    n = max(c[2].size for c in cols)
    lines = [",".join(f"{c[0]}," for c in cols),
             ",".join(f"Wavelength (nm),{c[1]}" for c in cols) + ","]
    for i in range(n):
        cells = []
        for _, _, w, v in cols:
            cells += [f"{w[i]:.7f}", f"{v[i]:.10g}"] if i < w.size else ["", ""]
        lines.append(",".join(cells) + ",")
    lines += ["", "600LP,", "600LP", "Collection Time: 5/10/2018 5:14:12 PM", "Y Mode   Abs"]
    path.write_text("\n".join(lines) + "\n")
    return wl, np.power(10.0, -A)


def test_the_picked_sample_of_a_multi_sample_cary_file_is_used(qtbot, tmp_path):
    """600LP picked for C's T is used (it was dropped, and 600LP1 and 550LP2 blamed, because a
    problem of any sample in the file discarded the picked one); a sample with a problem is
    refused naming that sample only."""
    path = tmp_path / "filters.csv"
    wl_600, t_600 = _write_cary_filters(path)
    wiz = CalibrationWizard(None, base_profile=default_profile())
    qtbot.addWidget(wiz)
    wiz.show()
    page = wiz.measurements_page
    row = page.rows["C"]
    row.thickness.setValue(0.5)
    row.load("T", str(path))
    combo = row.combos["T"]
    assert [combo.itemText(i) for i in range(combo.count())] == FILTERS
    combo.setCurrentIndex(FILTERS.index("GSBS"))   # the operator looks around, then picks 600LP
    combo.setCurrentIndex(FILTERS.index("600LP"))
    ch = row.channels["T"]
    assert ch.sample == "600LP" and not row.error.isVisibleTo(page), row.error.text()
    grid = page.wavelengths()
    # the picked curve, T = 10^-A on the profile grid, against linear interpolation of the file
    order = np.argsort(wl_600)
    expected = np.interp(grid, wl_600[order], t_600[order])
    np.testing.assert_allclose(ch.values, expected, atol=0.03)
    assert ch.values.min() >= 0 and ch.values.max() <= 1
    assert len(page.figure.axes[1].lines) == 1 and page.isComplete()

    combo.setCurrentIndex(FILTERS.index("550LP2"))
    text = row.error.text()
    assert row.channels["T"].values is None and "550LP2" in text and "above 100 %" in text
    assert "600LP1" not in text and not page.isComplete()
    combo.setCurrentIndex(FILTERS.index("600LP1"))
    text = row.error.text()
    assert "600LP1" in text and "negative transmittance" in text and "550LP2" not in text
    combo.setCurrentIndex(FILTERS.index("530SP"))     # clean, but covers 450-750 nm only
    text = row.error.text()
    assert "530SP" in text and "450" in text and "550LP2" not in text

    # the fit uses the picked sample: provenance names it, and the fitted T reproduces it
    combo.setCurrentIndex(FILTERS.index("600LP"))
    wl = page.wavelengths()
    R = 0.05 + 0.02 * np.sin(wl / 40)
    r_path = tmp_path / "c_R.csv"
    write_spectra(r_path, [Sample("C", wl, R)], quantity="reflectance")
    row.load("R", str(r_path))
    wiz.next()
    wiz.next()
    with qtbot.waitSignal(wiz.fit_page.fitted, timeout=60000):
        pass
    profile, fits, _ = wiz.fit_page.result
    assert "[600LP]" in profile.provenance["measurements"]["C"][0]
    _, T_fit = reflectance_transmittance(profile.K[0], profile.S[0], 0.5)
    np.testing.assert_allclose(T_fit, row.channels["T"].values, atol=1e-6)


def test_file_quantity_override_reads_a_resin_absorbance_file(qtbot, shared_data):
    """The resin file does not say it holds absorbance: read as T it is refused (above 100 %);
    stated as absorbance it is read as T = 10^-A, like the CLI's --file-quantity absorbance."""
    resin = shared_data / "spectra" / "formats" / "resin_PR48_absorbance_2015-07-27.csv"
    wiz = CalibrationWizard(None, base_profile=default_profile())
    qtbot.addWidget(wiz)
    page = wiz.measurements_page
    row = page.rows["Cl"]
    row.thickness.setValue(1.0)
    row.load("T", str(resin))
    assert row.channels["T"].values is None and "above 100 %" in row.error.text()
    row.set_file_quantity("T", "absorbance")
    assert not row.error.isVisibleTo(page), row.error.text()
    data = np.loadtxt(resin, delimiter=",", comments="#")
    grid = page.wavelengths()
    expected = np.interp(grid, data[:, 0], np.power(10.0, -data[:, 1]))
    np.testing.assert_allclose(row.channels["T"].values, expected, atol=0.01)
    assert page.isComplete()
    # absorbance is no reflectance: said on the row, naming what the file was said to hold
    row.set_file_quantity("R", "absorbance")
    row.load("R", str(resin))
    assert row.channels["R"].values is None and "absorbance" in row.error.text()
    # the statement is per file: the T file keeps it when the sample list is reloaded
    assert row.holds["T"].currentText() == "absorbance"


def test_thickness_is_required_and_the_page_names_the_ink(qtbot, measurement_files):
    r_path, t_path = measurement_files
    wiz = CalibrationWizard(None, base_profile=default_profile())
    qtbot.addWidget(wiz)
    wiz.show()
    page = wiz.measurements_page
    assert page.rows["M"].thickness.text() == "thickness?"   # no silent 1.000 mm
    for ink in ("C", "M"):
        page.rows[ink].load("R", str(r_path))
        page.rows[ink].load("T", str(t_path))
    assert not page.isComplete()
    assert not wiz.button(QWizard.WizardButton.NextButton).isEnabled()
    assert page.missing.isVisibleTo(wiz) and "C, M" in page.missing.text()
    assert page.measurements() == []
    assert len(page.figure.axes[0].lines) == 2   # still plotted, labelled as lacking it
    page.rows["C"].thickness.setValue(0.4)
    assert "of M:" in page.missing.text() and not page.isComplete()
    page.rows["M"].thickness.setValue(0.4)
    assert page.isComplete() and not page.missing.isVisibleTo(wiz)
    assert [m.thickness_mm for m in page.measurements()] == [0.4, 0.4]


def _has_colour(widget, hex_colour: str, tol: int = 40) -> int:
    """How many pixels of the widget's rendering are near ``hex_colour``."""
    img = widget.grab().toImage()
    from PySide6.QtGui import QColor

    want = QColor(hex_colour)
    w, h = img.width(), img.height()
    buf = np.frombuffer(img.constBits(), np.uint8, img.bytesPerLine() * h)
    px = buf.reshape(h, img.bytesPerLine())[:, :4 * w].reshape(h, w, 4).astype(int)
    b, g, r = px[..., 0], px[..., 1], px[..., 2]
    return int(((abs(r - want.red()) < tol) & (abs(g - want.green()) < tol)
                & (abs(b - want.blue()) < tol)).sum())


def test_fit_page_one_layer_says_exact_by_construction(qtbot, measurement_files):
    r_path, t_path = measurement_files
    wiz = CalibrationWizard(None, base_profile=default_profile())
    qtbot.addWidget(wiz)
    wiz.show()
    _load_rows(wiz, r_path, t_path, inks=("C", "Y"))
    wiz.next()
    wiz.next()
    with qtbot.waitSignal(wiz.fit_page.fitted, timeout=60000):
        pass
    page = wiz.fit_page
    text = page.status.text()
    assert text.count("exact by construction") == 2 and "0.0000" not in text
    assert page.held_out == {}
    # K and S per fitted ink, plotted (two curves each), and drawn in the ink's colour
    assert [ax.get_title() for ax in page.ks_fig.axes] == ["C", "Y"]
    assert all(len(ax.lines) == 2 for ax in page.ks_fig.axes)
    page.tabs.setCurrentIndex(1)
    page.ks_canvas.resize(800, 400)
    page.ks_canvas.draw()
    from dreamprint_gui.gui.wizard.common import INK_COLOURS

    assert _has_colour(page.ks_canvas, INK_COLOURS["C"]) > 200
    assert _has_colour(page.ks_canvas, INK_COLOURS["Y"]) > 200


def test_fit_page_several_thicknesses_shows_held_out_error(qtbot):
    """The example set has C and M at 0.1 and 0.3 mm (noise-free, from the default profile):
    each thickness is predicted from the other to within rounding, and shown as held out."""
    from pathlib import Path

    set_path = Path(__file__).resolve().parents[1] / "data" / "calibration_set" / "set.toml"
    wiz = CalibrationWizard(None, base_profile=default_profile(), calibration_set=str(set_path))
    qtbot.addWidget(wiz)
    wiz.show()
    wiz.next()
    wiz.next()
    with qtbot.waitSignal(wiz.fit_page.fitted, timeout=120000):
        pass
    page = wiz.fit_page
    text = page.status.text()
    assert set(page.held_out) >= {"C", "M"}
    for ink in ("C", "M"):
        held, _ = page.held_out[ink]
        assert [h.thickness_mm for h in held] == [0.1, 0.3]
        assert all(h.overall_R < 2e-3 and h.overall_T < 2e-3 for h in held)
    assert "held-out rms R" in text and "0.1 mm: R &lt; 0.0001" in text
    # held-out curves (solid) in the error tab
    labels = [ln.get_label() for ax in page.res_fig.axes for ln in ax.lines]
    assert "C held out" in labels and "M held out" in labels


def test_a_second_thickness_row_gives_a_held_out_error(qtbot, tmp_path, truth, measurement_files):
    """C at 0.4 mm (exact) and, on a row added with +, at 0.8 mm with R offset by +0.01:
    fitted from 0.4 mm alone (the closed form gives the true K and S), 0.8 mm is predicted
    with an R error of exactly that offset and no T error."""
    r_path, t_path = measurement_files
    wl = truth.wavelengths_nm
    R8, T8 = reflectance_transmittance(truth.K, truth.S, 0.8)
    r8, t8 = tmp_path / "c_R_08.csv", tmp_path / "c_T_08.csv"
    write_spectra(r8, [Sample("C", wl, R8[0] + 0.01)], quantity="reflectance")
    write_spectra(t8, [Sample("C", wl, T8[0])], quantity="transmittance")
    wiz = CalibrationWizard(None, base_profile=default_profile())
    qtbot.addWidget(wiz)
    wiz.show()
    page = wiz.measurements_page
    _load_rows(wiz, r_path, t_path, inks=("C",))
    page.rows["C"].more.click()                       # + : another thickness of C
    assert [r.ink for r in page.layer_rows] == ["C", "C", "M", "Y", "K", "W", "Cl"]
    second = page.layer_rows[1]
    assert second.extra and second.more.text() == "-"
    second.load("R", str(r8))
    second.load("T", str(t8))
    assert not page.isComplete() and "of C:" in page.missing.text()  # its thickness first
    second.thickness.setValue(0.8)
    assert page.isComplete()
    assert [m.thickness_mm for m in page.measurements()] == [0.4, 0.8]
    wiz.next()
    wiz.next()
    with qtbot.waitSignal(wiz.fit_page.fitted, timeout=60000):
        pass
    held, _ = wiz.fit_page.held_out["C"]
    h08 = next(h for h in held if h.thickness_mm == 0.8)
    np.testing.assert_allclose(h08.rms_R, 0.01, rtol=1e-4)
    assert h08.overall_T < 1e-6
    assert "0.8 mm: R 0.0100, T &lt; 0.0001" in wiz.fit_page.status.text()
    # removing the row takes its measurement away
    wiz.back()
    wiz.back()
    second.more.click()
    assert len(page.layer_rows) == len(INKS) and len(page.measurements()) == 1
