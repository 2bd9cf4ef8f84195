"""Truncated, garbled and wrong files: one clear DreamPrintError (file, line, problem), never
another exception."""

import numpy as np
import pytest

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.spectra import read_spectra

GENERATED = ["cary_multi_percentT.csv", "cgats_argyll.ti3", "cgats_i1profiler_percent.txt",
             "cgats_spectral_pct_long.txt", "csv_columns_micrometres_T.csv",
             "csv_rows_semicolon_percent.csv", "jcamp_difdup_absorbance.jdx",
             "spdx_led_relative.spdx"]


def _read_or_refuse(path):
    try:
        return read_spectra(path)
    except DreamPrintError as exc:
        assert "\n" not in str(exc) and exc.path == str(path)
        return exc


@pytest.mark.parametrize("name", GENERATED)
def test_truncations_never_crash(spectra_data, tmp_path, name):
    data = (spectra_data / name).read_bytes()
    for frac in (0.1, 0.35, 0.6, 0.85, 0.97):
        p = tmp_path / f"cut{frac}_{name}"
        p.write_bytes(data[:int(len(data) * frac)])
        _read_or_refuse(p)


@pytest.mark.parametrize("name", GENERATED)
def test_random_byte_damage_never_crashes(spectra_data, tmp_path, name):
    rng = np.random.default_rng(7)
    data = bytearray((spectra_data / name).read_bytes())
    for k in range(25):
        d = bytearray(data)
        for i in rng.integers(0, len(d), 4):
            d[i] = int(rng.choice(list(b"x;,\t\"#-.0%S@?\n ")))
        p = tmp_path / f"dmg{k}_{name}"
        p.write_bytes(bytes(d))
        _read_or_refuse(p)


@pytest.mark.parametrize("name, cut_line, match", [
    ("cgats_i1profiler_percent.txt", 16, "no END_DATA"),
    ("cgats_argyll.ti3", 24, "no END_DATA"),
    ("jcamp_difdup_absorbance.jdx", 20, "without ##END="),
])
def test_truncated_at_a_line_is_an_error(spectra_data, tmp_path, name, cut_line, match):
    lines = (spectra_data / name).read_bytes().splitlines(keepends=True)
    p = tmp_path / name
    p.write_bytes(b"".join(lines[:cut_line]))
    with pytest.raises(DreamPrintError, match=match):
        read_spectra(p)


def test_cgats_short_row_names_its_line(spectra_data, tmp_path):
    text = (spectra_data / "cgats_i1profiler_percent.txt").read_text()
    lines = text.splitlines()
    i = lines.index("BEGIN_DATA") + 2
    lines[i] = lines[i].rsplit("\t", 3)[0]
    p = tmp_path / "short.txt"
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(DreamPrintError, match="values on this line") as exc:
        read_spectra(p)
    assert exc.value.line == i + 1


def test_cgats_number_of_sets_mismatch(spectra_data, tmp_path):
    text = (spectra_data / "cgats_argyll.ti3").read_text().replace("NUMBER_OF_SETS 3",
                                                                      "NUMBER_OF_SETS 4")
    p = tmp_path / "sets.ti3"
    p.write_text(text)
    with pytest.raises(DreamPrintError, match="NUMBER_OF_SETS is 4 but 3"):
        read_spectra(p)


def test_cgats_garbled_number(spectra_data, tmp_path):
    lines = (spectra_data / "cgats_argyll.ti3").read_text().splitlines()
    i = next(k for k, ln in enumerate(lines) if ln.startswith("2 "))
    lines[i] = lines[i].replace("0.0 0.0 0.0 0.0 ", "0.0 0.0 0.0 0.0 4x.5 ", 1)
    lines[i] = lines[i].rsplit(" ", 1)[0]
    p = tmp_path / "garbled.ti3"
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(DreamPrintError, match="SPEC_380: '4x.5' is not a number") as exc:
        read_spectra(p)
    assert exc.value.line == i + 1


def test_cgats_without_spectra(tmp_path):
    p = tmp_path / "lab.txt"
    p.write_text("CGATS.17\nNUMBER_OF_FIELDS 4\nBEGIN_DATA_FORMAT\nSAMPLE_ID LAB_L LAB_A LAB_B\n"
                 "END_DATA_FORMAT\nNUMBER_OF_SETS 1\nBEGIN_DATA\n1 50 0 0\nEND_DATA\n")
    with pytest.raises(DreamPrintError, match="no spectral fields"):
        read_spectra(p)


def test_cgats_bands_keyword_checked(spectra_data, tmp_path):
    text = (spectra_data / "cgats_argyll.ti3").read_text().replace('SPECTRAL_BANDS "36"',
                                                                      'SPECTRAL_BANDS "31"')
    p = tmp_path / "bands.ti3"
    p.write_text(text)
    with pytest.raises(DreamPrintError, match="SPECTRAL_BANDS is 31 but 36"):
        read_spectra(p)


def test_cary_cut_inside_a_row(spectra_data, tmp_path):
    lines = (spectra_data / "cary_multi_percentT.csv").read_text().splitlines()
    lines = lines[:20] + [lines[20].rsplit(",", 2)[0]]
    p = tmp_path / "cut.csv"
    p.write_text("\n".join(lines))
    with pytest.raises(DreamPrintError, match="wavelength without a value") as exc:
        read_spectra(p)
    assert exc.value.line == 21


def test_cary_unknown_y_mode(tmp_path):
    p = tmp_path / "fr.csv"
    p.write_text("s1,\nWavelength (nm),F(R),\n500,0.1,\n400,0.2,\n")
    with pytest.raises(DreamPrintError, match="Y mode 'F\\(R\\)'"):
        read_spectra(p)


def test_csv_text_inside_data_and_short_rows(tmp_path):
    p = tmp_path / "t.csv"
    p.write_text("wavelength,a,b\n400,0.1,0.2\n410,0.1,oops\n420,0.1,0.2\n")
    with pytest.raises(DreamPrintError, match="'oops' is not a number") as exc:
        read_spectra(p)
    assert exc.value.line == 3
    p.write_text("wavelength,a,b\n400,0.1,0.2\n410,0.1,0.2\n420,0.1\n")
    with pytest.raises(DreamPrintError, match="2 cells but 3 columns") as exc:
        read_spectra(p)
    assert exc.value.line == 4


def test_csv_without_a_wavelength_axis(tmp_path):
    p = tmp_path / "t.csv"
    p.write_text("0.1,0.2,0.3\n0.4,0.2,0.1\n0.3,0.3,0.3\n")
    with pytest.raises(DreamPrintError, match="cannot tell where the wavelengths are"):
        read_spectra(p)


@pytest.mark.parametrize("content, match", [
    (b"", "empty"), (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR", "binary"),
    (b"# only a comment\n", "no data lines"),
])
def test_not_spectra(tmp_path, content, match):
    p = tmp_path / "x.csv"
    p.write_bytes(content)
    with pytest.raises(DreamPrintError, match=match):
        read_spectra(p)


def test_missing_file_and_folder(tmp_path):
    with pytest.raises(DreamPrintError, match="no such file"):
        read_spectra(tmp_path / "absent.csv")
    with pytest.raises(DreamPrintError, match="folder"):
        read_spectra(tmp_path)


def test_spdx_malformed_xml(spectra_data, tmp_path):
    text = (spectra_data / "spdx_led_relative.spdx").read_text()
    p = tmp_path / "bad.spdx"
    p.write_text(text[: len(text) // 2])
    with pytest.raises(DreamPrintError, match="XML") as exc:
        read_spectra(p)
    assert exc.value.line is not None
