"""Each reader on the shared real files and on generated files, against closed forms or an
independent reader."""

import os
import sys
from pathlib import Path

import numpy as np
import pytest

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.spectra import detect_format, read_spectra
from dreamprint_gui.io.spectra.detect import read_text

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "data" / "spectra"))
from make_test_files import PATCHES, band, edge  # noqa: E402

WL10 = np.arange(380.0, 731.0, 10.0)
R_PATCHES = np.array([edge(WL10, c, lo, hi) for c, lo, hi in PATCHES.values()])


# --- shared real files -------------------------------------------------------------------

def test_xrite_spectrolino_matches_colour_science_reader(shared_data):
    import colour

    path = shared_data / "spectra/formats/X-Rite_Digital_Colour_Checker.txt"
    sf = read_spectra(path)
    ref = colour.read_sds_from_xrite_file(str(path))
    assert sf.names == list(ref)
    assert sf.format.startswith("CGATS.17") and sf.quantity == "reflectance"
    for s in sf.samples:
        np.testing.assert_array_equal(s.wavelengths_nm, ref[s.name].wavelengths)
        np.testing.assert_array_equal(s.values, ref[s.name].values)
    assert sf.problems == ()


def test_babelcolor_csv_matches_colour_science_reader(shared_data):
    import colour

    path = shared_data / "spectra/formats/babelcolor_average.csv"
    sf = read_spectra(path, quantity="reflectance")
    ref = colour.io.read_spectral_data_from_csv_file(str(path))
    assert sf.format == "CSV, a wavelength per row"
    assert sf.names == [k for k in ref if k != "wavelength"]
    for s in sf.samples:
        np.testing.assert_array_equal(s.wavelengths_nm, ref["wavelength"])
        np.testing.assert_array_equal(s.values, ref[s.name])


def test_cary_sample_absorbance_and_transmittance(shared_data):
    path = shared_data / "spectra/formats/cary_CuPCtS_H2O_vis_absorbance.csv"
    expect = np.loadtxt(path, delimiter=",", skiprows=2, max_rows=141, usecols=(0, 1))
    a = read_spectra(path)
    assert (a.format, a.quantity, a.names) == ("Agilent Cary CSV", "absorbance", ["sample1"])
    s = a.sample("sample1")
    np.testing.assert_array_equal(s.wavelengths_nm, expect[::-1, 0])
    np.testing.assert_array_equal(s.values, expect[::-1, 1])
    t = read_spectra(path, quantity="transmittance").sample(0)
    np.testing.assert_allclose(t.values, 10.0 ** -expect[::-1, 1], rtol=1e-15)
    assert "descending" in a.conversion


def test_nist_jcamp_matches_jcamp_package(shared_data):
    import jcamp

    path = shared_data / "spectra/formats/nist_toluene_uvvis.jdx"
    sf = read_spectra(path)
    assert sf.quantity == "log_epsilon" and sf.names == ["Toluene"]
    with open(path) as f:
        ref = jcamp.read(f)
    x, y = ref["x"], ref["y"]
    ux = np.unique(x)
    np.testing.assert_array_equal(sf.samples[0].wavelengths_nm, ux)
    # Repeated points in this file carry equal values, so merging keeps them exactly.
    np.testing.assert_allclose(sf.samples[0].values, [y[x == u].mean() for u in ux], rtol=1e-15)
    with pytest.raises(DreamPrintError, match="molar absorptivity"):
        read_spectra(path, quantity="transmittance")


def test_resin_headerless_csv(shared_data):
    path = shared_data / "spectra/formats/resin_PR48_absorbance_2015-07-27.csv"
    expect = np.loadtxt(path, delimiter=",", comments="#")
    sf = read_spectra(path)
    assert sf.quantity == "unstated" and len(sf) == 1
    np.testing.assert_array_equal(sf.samples[0].wavelengths_nm, expect[:, 0])
    np.testing.assert_array_equal(sf.samples[0].values, expect[:, 1])
    t = read_spectra(path, quantity="transmittance", file_quantity="absorbance")
    np.testing.assert_allclose(t.samples[0].values, 10.0 ** -expect[:, 1], rtol=1e-15)
    r = read_spectra(path, quantity="reflectance")
    assert r.quantity == "reflectance" and "does not state its quantity" in r.conversion
    with pytest.raises(DreamPrintError, match="holds absorbance, not reflectance"):
        read_spectra(path, quantity="reflectance", file_quantity="absorbance")


def test_kubelka_munk_table_refused(shared_data):
    path = shared_data / "spectra/formats/acrylic_paints_KS_380-750nm.csv"
    with pytest.raises(DreamPrintError, match="Kubelka-Munk") as exc:
        read_spectra(path)
    assert exc.value.line == 1 and exc.value.path == str(path)


SHARED_DATA = Path(os.environ.get("DREAMPRINT_SAMPLE_DATA")  # as tests/conftest.py
                   or Path(__file__).resolve().parents[3].parent / "shared/data")
SHARED_FORMATS = sorted(p.name for p in (SHARED_DATA / "spectra/formats").glob("*"))


def test_shared_samples_present():
    assert len(SHARED_FORMATS) >= 6, (SHARED_DATA, SHARED_FORMATS)


@pytest.mark.parametrize("name", SHARED_FORMATS)
def test_every_shared_sample_reads_or_is_refused_clearly(shared_data, name):
    path = shared_data / "spectra/formats" / name
    try:
        sf = read_spectra(path)
    except DreamPrintError as exc:
        assert exc.path == str(path) and "\n" not in str(exc)
        return
    assert len(sf) >= 1
    for s in sf.samples:
        assert np.all(np.diff(s.wavelengths_nm) > 0)


# --- generated files ------------------------------------------------------------------------

def test_i1profiler_percent_without_norm(spectra_data):
    sf = read_spectra(spectra_data / "cgats_i1profiler_percent.txt")
    assert sf.format == "CGATS.17 (X-Rite i1Profiler)" and sf.quantity == "reflectance"
    assert sf.names == list(PATCHES)
    assert "percent to fraction" in sf.conversion and "does not say" in sf.conversion
    got = np.array([s.values for s in sf.samples])
    np.testing.assert_allclose(got, R_PATCHES, rtol=1e-5)
    # Stated otherwise by the caller: kept as written.
    raw = read_spectra(spectra_data / "cgats_i1profiler_percent.txt", value_scale="fraction")
    np.testing.assert_allclose(raw.samples[0].values, 100 * R_PATCHES[0], rtol=1e-5)
    assert raw.problems and "above 100 %" in raw.problems[0]


def test_argyll_ti3_spectral_norm_and_second_table(spectra_data):
    sf = read_spectra(spectra_data / "cgats_argyll.ti3")
    assert sf.format == "CGATS.17 (ArgyllCMS CTI3)" and sf.names == ["1", "2", "3"]
    assert "1 other table" in sf.conversion
    np.testing.assert_allclose([s.values for s in sf.samples], R_PATCHES, atol=1e-8)
    t = read_spectra(spectra_data / "cgats_argyll.ti3", quantity="transmittance")
    assert t.quantity == "transmittance"  # implied reflectance overruled by the caller


def test_cgats_long_layout_spectral_pct(spectra_data):
    sf = read_spectra(spectra_data / "cgats_spectral_pct_long.txt", quantity="reflectance")
    assert sf.names == list(PATCHES)
    np.testing.assert_allclose([s.values for s in sf.samples], R_PATCHES, atol=1e-8)
    for s in sf.samples:
        np.testing.assert_array_equal(s.wavelengths_nm, WL10)


def test_cary_multi_sample_percent_t(spectra_data):
    sf = read_spectra(spectra_data / "cary_multi_percentT.csv")
    assert sf.names == ["cyan 0.5mm", "magenta 0.5mm", "yellow 0.5mm"]
    assert sf.quantity == "transmittance"
    for s, (c, p, w) in zip(sf.samples, [(620, 1.2, 40), (530, 0.9, 35), (430, 1.5, 30)],
                            strict=True):
        np.testing.assert_allclose(s.values, 10.0 ** -(band(s.wavelengths_nm, c, p, w) + 0.02),
                                   rtol=1e-9)
    assert sf.samples[2].range_nm == (350.0, 750.0) and sf.samples[0].range_nm == (350, 800)
    a = read_spectra(spectra_data / "cary_multi_percentT.csv", quantity="absorbance")
    np.testing.assert_allclose(a.samples[1].values,
                               band(a.samples[1].wavelengths_nm, 530, 0.9, 35) + 0.02,
                               atol=1e-9)


def test_csv_rows_semicolon_decimal_comma_percent(spectra_data):
    sf = read_spectra(spectra_data / "csv_rows_semicolon_percent.csv")
    assert sf.format == "CSV, a sample per row" and sf.quantity == "reflectance"
    assert sf.names == list(PATCHES)
    np.testing.assert_allclose([s.values for s in sf.samples], R_PATCHES, atol=1e-6)


def test_csv_columns_micrometres_uneven(spectra_data):
    sf = read_spectra(spectra_data / "csv_columns_micrometres_T.csv")
    s = sf.sample("resin 2mm")
    assert sf.quantity == "transmittance" and "micrometres" in sf.conversion
    wl = np.array([360, 380, 390, 410, 450, 500, 550, 600, 650, 700, 750, 800.0])
    np.testing.assert_allclose(s.wavelengths_nm, wl, rtol=1e-12)
    np.testing.assert_allclose(s.values, 10.0 ** -(band(wl, 600, 0.8, 50) + 0.01), atol=1e-8)
    assert not s.uniform


def test_jcamp_difdup_against_closed_form_and_jcamp_package(spectra_data, tmp_path):
    import jcamp
    from make_test_files import jcamp_text

    path = spectra_data / "jcamp_difdup_absorbance.jdx"
    body = path.read_text().split("##XYDATA=(X++(Y..Y))")[1]
    assert any(c in body for c in "STUVWXYZs") and "%" in body  # DUP and DIF forms present
    sf = read_spectra(path)
    s = sf.samples[0]
    wl = np.arange(360.0, 781.0, 2.0)
    a = band(wl, 620, 1.2, 40) + 0.02
    a[wl > 740] = a[wl > 740][0]
    np.testing.assert_array_equal(s.wavelengths_nm, wl)
    np.testing.assert_allclose(s.values, a, atol=0.51e-5)
    # The jcamp package misreads multi-digit DUP counts (S1 = 11) and fails on DUP after SQZ,
    # so the cross-check uses lines short enough to need neither.
    short = tmp_path / "short_lines.jdx"
    short.write_text(jcamp_text("t", "ABSORBANCE", wl, np.rint(a / 1e-5).astype(int), 1e-5,
                                per_line=8))
    assert "S1" not in short.read_text()
    with open(short) as f:
        ref = jcamp.read(f)
    np.testing.assert_allclose(read_spectra(short).samples[0].values, ref["y"], rtol=1e-12)
    np.testing.assert_allclose(s.values, ref["y"], rtol=1e-12)
    t = read_spectra(path, quantity="transmittance")
    np.testing.assert_allclose(t.samples[0].values, 10.0 ** -s.values, rtol=1e-15)


def test_spdx_spd_refused_as_reflectance(spectra_data):
    led = spectra_data / "spdx_led_relative.spdx"
    sf = read_spectra(led)
    assert sf.quantity == "spd" and sf.format.startswith("IES TM-27-14")
    np.testing.assert_allclose(sf.samples[0].values,
                               band(WL10, 450, 1.0, 12) + band(WL10, 580, 0.6, 60), rtol=1e-10)
    for q in ("reflectance", "transmittance"):
        with pytest.raises(DreamPrintError, match="spectral power distribution"):
            read_spectra(led, quantity=q)
    r = read_spectra(spectra_data / "spdx_reflectance.spdx", quantity="reflectance")
    np.testing.assert_allclose(r.samples[0].values, R_PATCHES[0], rtol=1e-10)


def test_detection_is_by_content_not_name(spectra_data, tmp_path):
    expected = {"cgats_argyll.ti3": "cgats", "cary_multi_percentT.csv": "cary",
                "jcamp_difdup_absorbance.jdx": "jcamp-dx", "spdx_led_relative.spdx": "spdx",
                "csv_rows_semicolon_percent.csv": "csv"}
    for name, fmt in expected.items():
        copy = tmp_path / "measurement.dat"
        copy.write_bytes((spectra_data / name).read_bytes())
        assert detect_format(read_text(copy)) == fmt


def test_utf16_and_latin1_text(tmp_path):
    text = "# R\nwavelength,Échantillon\n400,0.5\n500,0.6\n600,0.7\n"
    for enc in ("utf-16", "latin-1", "utf-8-sig"):
        p = tmp_path / f"{enc}.csv"
        p.write_bytes(text.encode(enc))
        sf = read_spectra(p, quantity="reflectance")
        assert sf.names == ["Échantillon"]
        np.testing.assert_array_equal(sf.samples[0].values, [0.5, 0.6, 0.7])
