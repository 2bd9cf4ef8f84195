"""``dreamprint spectra FILE [--json]``: the contract's keys, and errors as one line, exit 2."""

import json

from dreamprint_gui.cli import main


def test_json_summary(spectra_data, capsys):
    assert main(["spectra", str(spectra_data / "cary_multi_percentT.csv"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["format"] == "Agilent Cary CSV" and out["quantity"] == "transmittance"
    assert "percent to fraction" in out["conversion"]
    s = out["samples"][2]
    assert s["name"] == "yellow 0.5mm" and s["wavelengths_nm"] == [350.0, 750.0]
    assert s["step_nm"] == 5.0 and s["points"] == 81
    assert 0 < s["min"] < s["max"] <= 1
    assert {"name", "wavelengths_nm", "step_nm", "points", "min", "max"} <= set(s)


def test_text_summary_and_quantity_conversion(spectra_data, capsys):
    path = str(spectra_data / "jcamp_difdup_absorbance.jdx")
    assert main(["spectra", path, "--quantity", "transmittance"]) == 0
    out = capsys.readouterr().out
    assert "format: JCAMP-DX 4.24" in out and "quantity: transmittance" in out
    assert "T = 10^-A" in out and "360-780 nm  step 2 nm  211 points" in out


def test_problems_listed(tmp_path, capsys):
    p = tmp_path / "r.csv"
    p.write_text("# quantity: reflectance\nwavelength,a\n400,0.5\n500,-0.2\n")
    assert main(["spectra", str(p)]) == 0
    assert "sample 'a': negative reflectance -0.2 at 500 nm" in capsys.readouterr().out


def test_errors_one_line_exit_2(spectra_data, tmp_path, capsys):
    assert main(["spectra", str(spectra_data / "spdx_led_relative.spdx"),
                 "--quantity", "reflectance"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("dreamprint: error: ")
    assert "spectral power distribution" in err
    p = tmp_path / "bad.csv"
    p.write_text("wavelength,a\n400,0.5\n500,zz\n")
    assert main(["spectra", str(p)]) == 2
    assert capsys.readouterr().err == f"dreamprint: error: {p}:3: 'zz' is not a number (a text " \
        "row inside the data, or a garbled line)\n"
    assert main(["spectra", str(tmp_path / "none.csv")]) == 2
    assert "no such file" in capsys.readouterr().err
