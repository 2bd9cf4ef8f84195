"""The calibration-set TOML: the example set gives back the profile it was generated from."""

import shutil

import numpy as np
import pytest

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.profile import INKS, default_profile
from dreamprint_gui.io.spectra.calibration_set import load_calibration_set
from dreamprint_gui.physics.kubelka_munk import reflectance_transmittance


def test_example_set_matches_forward_model(calibration_set_dir):
    prof = default_profile()
    layers = load_calibration_set(calibration_set_dir / "set.toml", prof.wavelengths_nm)
    assert [(m.ink, m.thickness_mm) for m in layers] == [
        (ink, t) for ink in INKS for t in (0.1, 0.3)]
    for m in layers:
        i = INKS.index(m.ink)
        R, T = reflectance_transmittance(prof.K[i], prof.S[i], m.thickness_mm)
        # Files hold 6 significant digits (CGATS) and 10 (Cary); cyan's T is absorbance to 1e-6.
        np.testing.assert_allclose(m.R, R, rtol=1e-5, atol=1e-9)
        np.testing.assert_allclose(m.T, T, rtol=3e-6, atol=1e-12)
        assert m.R.shape == m.T.shape == prof.wavelengths_nm.shape
        assert "R: reflectance_i1profiler.txt" in m.source


def _set(tmp_path, calibration_set_dir, body):
    for f in calibration_set_dir.iterdir():
        shutil.copy(f, tmp_path / f.name)
    p = tmp_path / "s.toml"
    p.write_text(body)
    return p


GRID = np.arange(380.0, 731.0, 10.0)
R_OK = 'R = { file = "reflectance_i1profiler.txt", sample = "M 0.1 mm" }'


@pytest.mark.parametrize("body, match", [
    (f'[[layer]]\nink = "Q"\nthickness_mm = 1\n{R_OK}\n', "ink 'Q' is not one of"),
    (f'[[layer]]\nink = "M"\nthickness_mm = -1\n{R_OK}\n', "thickness_mm must be"),
    ('[[layer]]\nink = "M"\nthickness_mm = 1\n', "give R, T or both"),
    (f'[[layer]]\nink = "M"\nthickness_mm = inf\n{R_OK}\nT = "transmittance_cary.csv"\n',
     "transmits nothing"),
    (f'[[layer]]\nink = "M"\nthickness = 1\n{R_OK}\n', "unknown key"),
    ('version = 2\n', "version 2"),
    ('name = "x"\n', "no \\[\\[layer\\]\\]"),
    (f'[[layer]]\nink = "M"\nthickness_mm = 1\n{R_OK[:-2]}, extrapolate_nm = -3 }}\n',
     "extrapolate_nm must be"),
    ('[[layer]]\nink = "M"\nthickness_mm = 1\nR = { file = "reflectance_i1profiler.txt" }\n',
     "holds 12 samples; say which"),
    ('[[layer]]\nink = "M"\nthickness_mm = 1\nR = { file = "reflectance_i1profiler.txt", '
     'sample = 13 }\n', "position 13 is outside 1-12"),
])
def test_set_errors_name_the_set_and_layer(tmp_path, calibration_set_dir, body, match):
    p = _set(tmp_path, calibration_set_dir, body)
    with pytest.raises(DreamPrintError, match=match) as exc:
        load_calibration_set(p, GRID)
    assert exc.value.path == str(p)


def test_toml_syntax_error_has_line(tmp_path, calibration_set_dir):
    p = _set(tmp_path, calibration_set_dir, '[[layer]]\nink = "M"\nthickness_mm = = 1\n')
    with pytest.raises(DreamPrintError, match="not valid TOML") as exc:
        load_calibration_set(p, GRID)
    assert exc.value.line == 3


def test_measurement_errors_name_the_data_file_and_the_layer(tmp_path, calibration_set_dir):
    p = _set(tmp_path, calibration_set_dir,
             '[[layer]]\nink = "M"\nthickness_mm = 0.1\n'
             'R = { file = "reflectance_i1profiler.txt", sample = "nope" }\n')
    with pytest.raises(DreamPrintError, match=r"no sample named 'nope'.*layer 1 \(ink M, 0.1 mm\) R"
                       ) as exc:
        load_calibration_set(p, GRID)
    assert exc.value.path.endswith("reflectance_i1profiler.txt")
    p.write_text('[[layer]]\nink = "M"\nthickness_mm = 0.1\nR = "absent.csv"\n')
    with pytest.raises(DreamPrintError, match="no such file") as exc:
        load_calibration_set(p, GRID)
    assert exc.value.path == str(tmp_path / "absent.csv")


def test_uncovered_grid_refused_unless_extrapolation_allowed(tmp_path, calibration_set_dir):
    body = ('[[layer]]\nink = "M"\nthickness_mm = 0.1\n'
            'T = { file = "transmittance_cary.csv", sample = "M 0.1 mm"%s }\n')
    p = _set(tmp_path, calibration_set_dir, body % "")
    wide = np.arange(360.0, 781.0, 10.0)
    with pytest.raises(DreamPrintError, match="covers 370-750 nm but 360-780 nm"):
        load_calibration_set(p, wide)
    p.write_text(body % ", extrapolate_nm = 30")
    (m,) = load_calibration_set(p, wide)
    assert m.T.shape == wide.shape and m.R is None


def test_impossible_values_refused(tmp_path, calibration_set_dir):
    p = _set(tmp_path, calibration_set_dir,
             '[[layer]]\nink = "W"\nthickness_mm = inf\nR = "white.csv"\n')
    (tmp_path / "white.csv").write_text("# quantity: reflectance\nwavelength,w\n"
                                        "380,0.9\n550,1.08\n730,0.9\n")
    with pytest.raises(DreamPrintError, match="reflectance above 100 % 1.08 at 550 nm"):
        load_calibration_set(p, GRID)


def test_documented_example_is_valid_toml():
    import re
    import tomllib
    from pathlib import Path

    doc = (Path(__file__).resolve().parents[3] / "docs/calibration-set.md").read_text()
    example = re.search(r"```toml\n(.*?)```", doc, re.S).group(1)
    d = tomllib.loads(example)
    assert [layer["ink"] for layer in d["layer"]] == ["C", "C", "W"]
    assert d["layer"][2]["thickness_mm"] == float("inf")
