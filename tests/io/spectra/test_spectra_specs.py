"""Files written here to the published layouts (CGATS.17 field names and their meaning, Cary CSV
per-sample Y modes, CSV headers with CGATS field names), read back against the closed forms
they were written from."""

import json

import numpy as np
import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.profile import default_profile
from dreamprint_gui.io.spectra import read_spectra
from dreamprint_gui.io.spectra.calibration_set import load_calibration_set
from dreamprint_gui.physics.kubelka_munk import reflectance_transmittance

WL = np.arange(380.0, 731.0, 10.0)


def refl(k: int) -> np.ndarray:
    """A smooth reflectance in (0.05, 0.95): the closed form every file below is written from."""
    return 0.5 + 0.4 * np.sin(WL / (40.0 + 7 * k) + k)


def _cgats(path, field, *, scale=1.0, keywords=(), names=("cyan 1", "magenta 2", "white 3"),
           extra_fields=True):
    fields = ["SAMPLE_ID", "SAMPLE_NAME"] + [f"{field}{w:g}" for w in WL]
    if extra_fields:
        fields += ["LAB_L", "LAB_A", "LAB_B"]
    lines = ["CGATS.17", 'ORIGINATOR "test"', *keywords,
             f"NUMBER_OF_FIELDS {len(fields)}", "BEGIN_DATA_FORMAT", " ".join(fields),
             "END_DATA_FORMAT", f"NUMBER_OF_SETS {len(names)}", "BEGIN_DATA"]
    for k, name in enumerate(names):
        vals = " ".join(f"{v * scale:.6f}" for v in refl(k))
        lab = " 50.0 1.0 -2.0" if extra_fields else ""
        lines.append(f'{k + 1} "{name}" {vals}{lab}')
    lines.append("END_DATA")
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("field, scale", [
    ("SPECTRAL_NM", 1.0),        # i1Profiler: fractions
    ("SPECTRAL_NM", 100.0),      # i1Profiler versions that write 0-100
    ("SPECTRAL_NM_", 1.0),
    ("nm", 100.0),               # X-Rite ColorPort / Spectrolino
    ("R", 1.0),
    ("SPECTRAL_PCT", 100.0),     # CGATS.17: percent reflectance
    ("SPECTRAL_DEC", 1.0),       # CGATS.17: decimal reflectance
])
def test_cgats_spectral_fields_are_reflectance_by_default(tmp_path, field, scale):
    p = _cgats(tmp_path / "chart.txt", field, scale=scale)
    sf = read_spectra(p)
    assert sf.quantity == "reflectance"
    assert sf.metadata["quantity_basis"] == "CGATS default"
    assert "CGATS default" in sf.conversion
    assert sf.names == ["cyan 1", "magenta 2", "white 3"]
    for k, s in enumerate(sf.samples):
        np.testing.assert_array_equal(s.wavelengths_nm, WL)
        np.testing.assert_allclose(s.values, refl(k), rtol=0, atol=0.51e-6 / scale)
    assert sf.problems == ()


@pytest.mark.parametrize("keyword, quantity", [
    ('MEAS_TYPE "TRANSMISSIVE"', "transmittance"),
    ('MEASUREMENT_TYPE "Transmission"', "transmittance"),
    ('MEASUREMENT_GEOMETRY "diffuse transmittance"', "transmittance"),
    ('MEAS_TYPE "REFLECTIVE"', "reflectance"),
    ('MEAS_TYPE "EMISSIVE"', "spd"),
])
def test_cgats_stated_quantity_wins(tmp_path, keyword, quantity):
    p = _cgats(tmp_path / "t.txt", "SPECTRAL_NM", keywords=[keyword])
    sf = read_spectra(p)
    assert sf.quantity == quantity and "quantity_basis" not in sf.metadata
    assert "CGATS default" not in sf.conversion


def test_cgats_default_overruled_by_the_caller(tmp_path):
    p = _cgats(tmp_path / "t.txt", "SPECTRAL_NM")
    sf = read_spectra(p, quantity="transmittance")
    assert sf.quantity == "transmittance" and "read as transmittance" in sf.conversion
    # A stated transmittance is not overruled.
    p = _cgats(tmp_path / "s.txt", "SPECTRAL_NM", keywords=['MEAS_TYPE "TRANSMISSIVE"'])
    with pytest.raises(DreamPrintError, match="holds transmittance, not reflectance"):
        read_spectra(p, quantity="reflectance")


def test_cgats_long_layout_percent(tmp_path):
    lines = ["CGATS.17", "NUMBER_OF_FIELDS 3", "BEGIN_DATA_FORMAT",
             "SAMPLE_NAME SPECTRAL_NM SPECTRAL_PCT", "END_DATA_FORMAT",
             f"NUMBER_OF_SETS {2 * WL.size}", "BEGIN_DATA"]
    for k, name in enumerate(("a", "b")):
        lines += [f"{name} {w:g} {100 * v:.5f}" for w, v in zip(WL, refl(k), strict=True)]
    p = tmp_path / "long.cgats"
    p.write_text("\n".join(lines + ["END_DATA"]) + "\n")
    sf = read_spectra(p)
    assert sf.quantity == "reflectance" and sf.names == ["a", "b"]
    np.testing.assert_allclose(sf.sample("b").values, refl(1), atol=1e-7)


def test_cgats_truncated_sets(tmp_path):
    p = _cgats(tmp_path / "t.txt", "SPECTRAL_NM")
    lines = p.read_text().splitlines()
    del lines[-2]                                    # one data line lost
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(DreamPrintError, match="NUMBER_OF_SETS is 3 but 2 data line"):
        read_spectra(p)


# --- CSV whose header uses CGATS field names ------------------------------------------------

def _cgats_csv(path, *, field="SPECTRAL_NM", scale=1.0, delim=",", decimal=".", comment=""):
    header = ["SAMPLE_ID", "SAMPLE_NAME"] + [f"{field}{w:g}" for w in WL] + ["LAB_L", "LAB_A",
                                                                               "LAB_B"]
    rows = [delim.join(header)]
    for k, name in enumerate(("paper", "ink C", "ink M")):
        vals = [f"{v * scale:.6f}".replace(".", decimal) for v in refl(k)]
        rows.append(delim.join([str(k + 1), name, *vals, "95.1", "0.2", "-1.3"]))
    path.write_text(comment + "\n".join(rows) + "\n")
    return path


@pytest.mark.parametrize("kw", [
    {}, {"delim": ";", "decimal": ","}, {"delim": "\t"}, {"field": "SPECTRAL_PCT", "scale": 100},
    {"field": "SPECTRAL_NM_", "scale": 100}, {"field": "nm"},
])
def test_csv_with_cgats_field_names(tmp_path, kw):
    p = _cgats_csv(tmp_path / "chart.csv", **kw)
    sf = read_spectra(p)
    assert sf.format == "CSV with CGATS field names"
    assert sf.quantity == "reflectance" and sf.metadata["quantity_basis"] == "CGATS default"
    assert sf.names == ["paper", "ink C", "ink M"]
    for k, s in enumerate(sf.samples):
        np.testing.assert_array_equal(s.wavelengths_nm, WL)
        np.testing.assert_allclose(s.values, refl(k), atol=1e-6)


def test_csv_with_cgats_field_names_stated_quantity_and_bad_rows(tmp_path):
    p = _cgats_csv(tmp_path / "t.csv", comment="# quantity: transmittance\n")
    sf = read_spectra(p)
    assert sf.quantity == "transmittance" and "quantity_basis" not in sf.metadata
    lines = p.read_text().splitlines()
    lines[3] = lines[3].rsplit(",", 5)[0]
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(DreamPrintError, match="values on this line but the data format has") \
            as exc:
        read_spectra(p)
    assert exc.value.line == 4


def test_cli_json_names_the_quantity(tmp_path, capsys):
    p = _cgats_csv(tmp_path / "chart.csv")
    assert main(["spectra", str(p), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["quantity"] == "reflectance" and out["quantity_basis"] == "CGATS default"
    q = _cgats(tmp_path / "i1.txt", "SPECTRAL_NM")
    assert main(["spectra", str(q)]) == 0
    assert "quantity: reflectance (CGATS default)" in capsys.readouterr().out


# --- Agilent Cary CSV, one Y mode per sample --------------------------------------------------

def _cary(path, samples):
    """samples: [(name, mode, values on WL)], written long-to-short as Cary scans."""
    names = ",".join(f"{n}," for n, _, _ in samples)
    head = ",".join(f"Wavelength (nm),{m}" for _, m, _ in samples)
    rows = [names, head]
    for i in range(WL.size - 1, -1, -1):
        rows.append(",".join(f"{WL[i]:.1f},{v[i]:.8f}" for _, _, v in samples))
    rows += ["", "sample 1", "Collection Time: 1/2/2024 10:00:00 AM"]
    path.write_text("\n".join(rows) + "\n")
    return path


def _mixed_cary(tmp_path):
    t1, t2, t3 = refl(0), refl(1), refl(2)
    return _cary(tmp_path / "mixed.csv", [
        ("C 0.1mm", "%T", 100 * t1), ("C 0.3mm", "Abs", -np.log10(t2)),
        ("M 0.1mm", "%T", 100 * t3), ("white", "%R", 100 * refl(3))]), (t1, t2, t3)


def test_cary_mixed_y_modes_each_sample_its_own(tmp_path):
    p, (t1, t2, t3) = _mixed_cary(tmp_path)
    sf = read_spectra(p)
    assert sf.quantity == "mixed"
    assert [s.quantity for s in sf.samples] == ["transmittance", "absorbance", "transmittance",
                                                "reflectance"]
    np.testing.assert_allclose(sf.sample("C 0.1mm").values, t1, atol=1e-10)
    np.testing.assert_allclose(sf.sample("C 0.3mm").values, -np.log10(t2), atol=1e-8)
    assert sf.sample("C 0.1mm").wavelengths_nm[0] == 380.0

    t = read_spectra(p, quantity="transmittance")
    assert t.quantity == "transmittance"
    np.testing.assert_allclose(t.sample("C 0.1mm").values, t1, atol=1e-10)
    np.testing.assert_allclose(t.sample("C 0.3mm").values, t2, rtol=1e-7)   # T = 10^-A
    np.testing.assert_allclose(t.sample(2).values, t3, atol=1e-10)
    with pytest.raises(DreamPrintError, match="sample 'white' holds reflectance, not "
                                              "transmittance"):
        t.sample("white")
    r = read_spectra(p, quantity="reflectance")
    np.testing.assert_allclose(r.sample("white").values, refl(3), atol=1e-10)
    with pytest.raises(DreamPrintError, match="'C 0.3mm' holds absorbance, not reflectance"):
        r.resample("C 0.3mm", WL)


def test_cli_mixed_cary(tmp_path, capsys):
    p, _ = _mixed_cary(tmp_path)
    assert main(["spectra", str(p), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["quantity"] == "mixed"
    assert [s["quantity"] for s in out["samples"]] == ["transmittance", "absorbance",
                                                       "transmittance", "reflectance"]
    assert main(["spectra", str(p)]) == 0
    assert "[absorbance]" in capsys.readouterr().out


def test_calibration_set_picks_samples_from_a_mixed_file(tmp_path):
    prof = default_profile()
    grid = prof.wavelengths_nm
    i = 0                                                    # the profile's first ink
    ink = "C"
    R1, T1 = reflectance_transmittance(prof.K[i], prof.S[i], 0.1)
    R3, T3 = reflectance_transmittance(prof.K[i], prof.S[i], 0.3)
    assert np.array_equal(grid, WL)
    _cary(tmp_path / "t.csv", [("thin", "%T", 100 * T1), ("thick", "Abs", -np.log10(T3)),
                               ("thin R", "%R", 100 * R1)])
    _cary(tmp_path / "r.csv", [("thick R", "%R", 100 * R3)])
    (tmp_path / "set.toml").write_text(
        f'[[layer]]\nink = "{ink}"\nthickness_mm = 0.1\n'
        'R = { file = "t.csv", sample = 3 }\nT = { file = "t.csv", sample = "thin" }\n'
        f'[[layer]]\nink = "{ink}"\nthickness_mm = 0.3\n'
        'R = { file = "r.csv", sample = "thick R" }\nT = { file = "t.csv", sample = "thick" }\n')
    layers = load_calibration_set(tmp_path / "set.toml", grid)
    np.testing.assert_allclose(layers[0].T, T1, atol=1e-9)
    np.testing.assert_allclose(layers[0].R, R1, atol=1e-9)
    np.testing.assert_allclose(layers[1].T, T3, rtol=1e-7, atol=1e-12)
    np.testing.assert_allclose(layers[1].R, R3, atol=1e-9)
    (tmp_path / "bad.toml").write_text(
        f'[[layer]]\nink = "{ink}"\nthickness_mm = 0.1\n'
        'T = { file = "t.csv", sample = "thin R" }\n')
    with pytest.raises(DreamPrintError, match="'thin R' holds reflectance, not transmittance"):
        load_calibration_set(tmp_path / "bad.toml", grid)
