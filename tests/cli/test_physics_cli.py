"""The command-line contract of issue 3 (predict, calibrate, evaluate density-fit, errors)."""

import json
import subprocess
import sys

import numpy as np
import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.core.profile import INKS, default_profile, load_profile
from dreamprint_gui.physics.kubelka_munk import mix, reflectance_infinite, reflectance_transmittance


def run(capsys, *args):
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def test_predict_json_white_and_fields(capsys):
    code, out, _ = run(capsys, "predict", "--mix", "W=1", "--json")
    assert code == 0
    rec = json.loads(out)
    assert set(rec) >= {"wavelengths_nm", "R", "T", "XYZ", "Lab", "sRGB", "sigma_per_mm"}
    p = default_profile()
    i = INKS.index("W")
    np.testing.assert_allclose(rec["R"], reflectance_infinite(p.K[i], p.S[i]), rtol=1e-12)
    assert rec["T"] == [0.0] * 36 and rec["sigma_per_mm"] > 0


def test_predict_finite_thickness_and_mix_file(tmp_path, capsys):
    f = tmp_path / "recipes.csv"
    f.write_text("C,M,W\n20,30,50\n0.1,0,0.9\n")
    code, out, _ = run(capsys, "predict", "--mix-file", str(f), "--thickness-mm", "0.5",
                       "--json")
    assert code == 0
    recs = json.loads(out)
    assert len(recs) == 2
    _, single, _ = run(capsys, "predict", "--mix", "C=0.2,M=0.3,W=0.5", "--thickness-mm",
                       "0.5", "--json")
    for key, value in json.loads(single).items():
        np.testing.assert_allclose(recs[0][key], value, rtol=1e-12, atol=1e-15)
    p = default_profile()
    K, S = mix([0.2, 0.3, 0, 0, 0.5, 0], p.K, p.S)
    R, T = reflectance_transmittance(K, S, 0.5)
    np.testing.assert_allclose(recs[0]["T"], T, rtol=1e-12)


def test_errors_are_one_line_exit_2(tmp_path, capsys):
    code, out, err = run(capsys, "predict", "--mix", "C=0.5", "--json")
    assert code == 2 and err.startswith("dreamprint: error:") and err.count("\n") == 1
    bad = tmp_path / "p.json"
    bad.write_text("{}")
    code, _, err = run(capsys, "predict", "--mix", "C=1", "--profile", str(bad))
    assert code == 2 and str(bad) in err and "Traceback" not in err


def test_console_script_exit_status():
    r = subprocess.run([sys.executable, "-m", "dreamprint_gui.cli", "predict", "--mix", "Z=1"],
                       capture_output=True, text=True)
    assert r.returncode == 2 and r.stderr.startswith("dreamprint: error:")


def test_evaluate_density_fit(capsys):
    code, out, _ = run(capsys, "evaluate", "density-fit", "--json")
    d = json.loads(out)
    assert code == 0 and d["t_max_mm"] == 5.0 and d["samples"] == 100
    assert d["inks"]["K"]["mean_percent"] < 5e-4  # black hardly scatters: the paper's 0.000 %
    assert all(v["max_percent"] >= v["mean_percent"] for v in d["inks"].values())


def test_calibrate_from_project_csv(tmp_path, capsys):
    base = default_profile()
    i = INKS.index("M")
    K, S = base.K[i] * 2, base.S[i] * 3
    wl = base.wavelengths_nm
    rows = ["ink,quantity,thickness_mm," + ",".join(f"{w:g}" for w in wl)]
    for t in (0.1, 0.4):
        R, T = reflectance_transmittance(K, S, t)
        rows.append(f"M,R,{t}," + ",".join(repr(x) for x in R))
        rows.append(f"M,T,{t}," + ",".join(repr(x) for x in T))
    csv = tmp_path / "m.csv"
    csv.write_text("\n".join(rows) + "\n")
    out = tmp_path / "prof.json"
    code, stdout, err = run(capsys, "calibrate", str(csv), "-o", str(out), "--json")
    assert code == 0, err
    report = json.loads(stdout)
    assert report["inks"][0]["ink"] == "M"
    prof = load_profile(out)
    np.testing.assert_allclose(prof.K[i], K, rtol=1e-6)
    np.testing.assert_allclose(prof.S[i], S, rtol=1e-6)


@pytest.mark.parametrize("content, message", [
    ("ink,quantity,thickness_mm,380,390,400\nQ,R,0.1,0.1,0.1,0.1\n", "unknown ink 'Q'"),
    ("ink,quantity,thickness_mm,380,390,400\nC,R,0.1,0.1,abc,0.1\n", ":2: a cell is not"),
])
def test_calibrate_bad_csv(tmp_path, capsys, content, message):
    f = tmp_path / "bad.csv"
    f.write_text(content)
    code, _, err = run(capsys, "calibrate", str(f), "-o", str(tmp_path / "x.json"))
    assert code == 2 and message in err and not (tmp_path / "x.json").exists()


def test_calibrate_from_instrument_calibration_set(tmp_path, capsys):
    """The shipped example set (CGATS R, Cary T, JCAMP-DX absorbance) gives back the profile
    its files were generated from (tests/data/spectra/make_test_files.py)."""
    from pathlib import Path

    toml = Path(__file__).resolve().parents[1] / "data" / "calibration_set" / "set.toml"
    out = tmp_path / "set.json"
    code, stdout, err = run(capsys, "calibrate", str(toml), "-o", str(out), "--json")
    assert code == 0, err
    assert {i["ink"] for i in json.loads(stdout)["inks"]} == set(INKS)
    got, ref = load_profile(out), default_profile()
    np.testing.assert_allclose(got.K, ref.K, rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(got.S, ref.S, rtol=1e-4, atol=1e-6)


def test_optically_thick_reflectance_joins_the_fit():
    from dreamprint_gui.core.calibration_types import LayerMeasurement
    from dreamprint_gui.physics.calibration import fit_ink

    K, S = np.full(36, 2.0), np.full(36, 5.0)
    layers = [LayerMeasurement("W", 0.2, None, reflectance_transmittance(K, S, 0.2)[1], "t"),
              LayerMeasurement("W", np.inf, reflectance_infinite(K, S), None, "r")]
    fit = fit_ink(layers, 36)
    np.testing.assert_allclose(fit.K, K, rtol=1e-6)
    np.testing.assert_allclose(fit.S, S, rtol=1e-6)


def test_calibrate_chart_as_published_reports_cross_validated_de(tmp_path, capsys,
                                                                 monkeypatch):
    """The layouts of a published PolyJet chart (issue 46): recipes as ``k50,c0,...`` under a
    ``K,C,M,Y,W`` header, measurements as ``LAB_L,LAB_A,LAB_B,SPECTRAL_NM380,...``."""
    from dreamprint_gui.physics.colorimetry import observer_for

    base = default_profile()
    rng = np.random.default_rng(7)
    parts = np.array([rng.multinomial(4, np.ones(5) / 5) * 25 for _ in range(24)])  # K,C,M,Y,W
    c = np.zeros((24, 6))
    for j, ink in enumerate("KCMYW"):
        c[:, INKS.index(ink)] = parts[:, j] / 100
    K = base.K * np.exp(0.1 * rng.standard_normal((6, 1)))
    R = reflectance_infinite(*mix(c, K, base.S))
    lab = observer_for(base.wavelengths_nm).spectra_to_Lab(R)
    (tmp_path / "ratios.csv").write_text("K,C,M,Y,W\n" + "".join(
        ",".join(f"{ink.lower()}{v}" for ink, v in zip("kcmyw", row, strict=True)) + "\n"
        for row in parts))
    (tmp_path / "color_measurements.csv").write_text(
        "LAB_L,LAB_A,LAB_B," + ",".join(f"SPECTRAL_NM{w:g}" for w in base.wavelengths_nm)
        + "\n" + "".join(",".join(f"{x:.2f}" for x in lab[r]) + ","
                         + ",".join(f"{x:.4f}" for x in R[r]) + "\n" for r in range(24)))
    out = tmp_path / "chart.json"
    from dreamprint_gui.core import progress

    monkeypatch.setattr(progress, "HEARTBEAT_S", 0.0)  # every iteration says itself
    code, stdout, err = run(capsys, "calibrate", "--chart", str(tmp_path / "ratios.csv"),
                            "--reflectance", str(tmp_path / "color_measurements.csv"),
                            "-o", str(out), "--folds", "2", "--json")
    assert code == 0, err
    rep = json.loads(stdout)
    assert rep["patches"] == 24
    assert rep["cross_validated_dE2000"]["mean"] < rep["base_dE2000"]["mean"]
    # the wait is visible: a line when it starts and after each of the 1 + 2 fits
    steps = [ln for ln in err.splitlines() if ln.startswith("calibrate --chart, 24 patches")
             and ": iteration " not in ln]
    assert len(steps) == 4 and steps[-1].endswith("3/3 (" + steps[-1].split("(")[-1])
    # and each fit (seconds on a real chart) says its iterations as they go (issue 46)
    for f in range(3):
        during = [ln for ln in err.splitlines() if f": {f}/3, fit {f + 1}: iteration " in ln]
        assert len(during) >= 2 and "of at most 100 (" in during[-1]
    assert err.index(": 0/3, fit 1: iteration 1 ") < err.index(": 1/3 (")
    assert load_profile(out).residuals["chart"]["folds"] == 2
