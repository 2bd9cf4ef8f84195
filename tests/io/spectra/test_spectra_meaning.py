"""Writers round-trip to 1e-9; unit detection; impossible values; resampling onto a grid."""

import numpy as np
import pytest

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.spectra import Sample, read_spectra, write_spectra

WL = np.arange(380.0, 781.0, 5.0)


def _samples(n=3, seed=1):
    rng = np.random.default_rng(seed)
    names = ["plain", 'with "quotes", commas', "spaces and tabs\tinside"][:n]
    return [Sample(nm, WL.copy(), rng.uniform(1e-4, 0.999, WL.size)) for nm in names]


@pytest.mark.parametrize("fmt", ["csv-columns", "csv-rows", "cgats", "jcamp-dx"])
@pytest.mark.parametrize("quantity", ["reflectance", "transmittance"])
def test_round_trip(tmp_path, fmt, quantity):
    samples = _samples()
    p = tmp_path / f"out.{fmt}"
    write_spectra(p, samples, quantity=quantity, format=fmt)
    sf = read_spectra(p)
    assert sf.quantity == quantity and sf.problems == ()
    assert len(sf) == len(samples)
    for got, want in zip(sf.samples, samples, strict=True):
        if fmt != "jcamp-dx":  # JCAMP-DX titles are one line: tabs become blanks there
            assert got.name == want.name
        np.testing.assert_allclose(got.wavelengths_nm, want.wavelengths_nm, rtol=0, atol=1e-9)
        np.testing.assert_allclose(got.values, want.values, rtol=0, atol=1e-9)


def test_round_trip_absorbance_csv(tmp_path):
    s = [Sample("a", WL, np.linspace(0.0, 3.5, WL.size))]
    write_spectra(tmp_path / "a.csv", s, quantity="absorbance")
    t = read_spectra(tmp_path / "a.csv", quantity="transmittance")
    np.testing.assert_allclose(t.samples[0].values, 10.0 ** -np.linspace(0, 3.5, WL.size),
                               rtol=1e-14)
    with pytest.raises(DreamPrintError, match="CGATS cannot state absorbance"):
        write_spectra(tmp_path / "a.txt", s, quantity="absorbance", format="cgats")


def test_percent_fraction_detection(tmp_path):
    p = tmp_path / "r.csv"
    p.write_text("wavelength,a\n400,12.5\n500,55\n600,80\n")
    sf = read_spectra(p, quantity="reflectance")
    np.testing.assert_allclose(sf.samples[0].values, [0.125, 0.55, 0.80])
    assert "percent to fraction" in sf.conversion
    p.write_text("wavelength,a\n400,0.125\n500,0.55\n600,0.80\n")
    sf = read_spectra(p, quantity="reflectance")
    np.testing.assert_allclose(sf.samples[0].values, [0.125, 0.55, 0.80])
    assert sf.conversion.endswith("read as reflectance")
    # A very dark patch in percent cannot be told from fractions; the caller may say so.
    p.write_text("wavelength,a\n400,0.9\n500,1.2\n600,1.1\n")
    sf = read_spectra(p, quantity="reflectance", value_scale="percent")
    np.testing.assert_allclose(sf.samples[0].values, [0.009, 0.012, 0.011])
    p.write_text("wavelength,%T sample\n400,12.5\n500,55\n600,80\n")
    sf = read_spectra(p)
    assert sf.quantity == "transmittance"
    np.testing.assert_allclose(sf.samples[0].values, [0.125, 0.55, 0.80])


def test_wavelength_units(tmp_path):
    p = tmp_path / "um.csv"
    p.write_text("0.40,0.5\n0.45,0.6\n0.50,0.7\n")  # no header: micrometres by magnitude
    sf = read_spectra(p, quantity="transmittance")
    np.testing.assert_allclose(sf.samples[0].wavelengths_nm, [400, 450, 500])
    p.write_text("wavenumber (cm-1),a\n25000,0.5\n20000,0.6\n")
    sf = read_spectra(p, quantity="transmittance")
    np.testing.assert_allclose(sf.samples[0].wavelengths_nm, [400, 500])
    np.testing.assert_allclose(sf.samples[0].values, [0.5, 0.6])
    p.write_text("sample,nm400,nm450,nm500\nx,0.1,0.2,0.3\n")
    sf = read_spectra(p, quantity="reflectance")
    assert sf.format == "CSV, a sample per row" and sf.names == ["x"]
    np.testing.assert_allclose(sf.samples[0].wavelengths_nm, [400, 450, 500])


def test_descending_and_repeated_wavelengths(tmp_path):
    p = tmp_path / "d.csv"
    p.write_text("wavelength,a\n600,0.3\n500,0.2\n500,0.4\n400,0.1\n")
    sf = read_spectra(p, quantity="reflectance")
    np.testing.assert_allclose(sf.samples[0].wavelengths_nm, [400, 500, 600])
    np.testing.assert_allclose(sf.samples[0].values, [0.1, 0.3, 0.3])
    assert "differing values averaged" in sf.conversion


def test_impossible_values_flagged_with_name_and_wavelength(tmp_path):
    p = tmp_path / "bad.csv"
    p.write_text("# quantity: transmittance\nwavelength,ok,neg,over,nan\n"
                 "400,0.5,-0.02,0.5,0.5\n500,0.5,0.1,1.2,nan\n600,0.5,-0.1,0.5,0.5\n")
    sf = read_spectra(p)
    assert sf.problems == (
        "sample 'neg': negative transmittance -0.02 at 400 nm (and 1 more wavelength(s))",
        "sample 'over': transmittance above 100 % 1.2 at 500 nm",
        "sample 'nan': non-finite value nan at 500 nm",
    )
    # Instrument noise within 0.1 % is not reported.
    p.write_text("wavelength,a\n400,-0.0005\n500,1.0008\n")
    assert read_spectra(p, quantity="reflectance").problems == ()


def test_resample_onto_profile_grid(tmp_path):
    wl = np.arange(360.0, 801.0, 5.0)
    line = 0.2 + 0.001 * (wl - 360)  # interpolation reproduces a straight line exactly
    write_spectra(tmp_path / "s.csv", [Sample("s", wl, line)], quantity="reflectance")
    sf = read_spectra(tmp_path / "s.csv")
    grid = np.arange(380.0, 751.0, 10.0)
    np.testing.assert_allclose(sf.resample("s", grid), 0.2 + 0.001 * (grid - 360), atol=1e-12)
    wide = np.arange(340.0, 831.0, 10.0)
    with pytest.raises(DreamPrintError, match="covers 360-800 nm") as exc:
        sf.resample(0, wide)
    assert "sample 's'" in str(exc.value) and exc.value.path == sf.path
    held = sf.sample("s").resample(wide, extrapolate_nm=30)
    np.testing.assert_allclose(held[[0, 1, -2, -1]], line[[0, 0, -1, -1]], atol=1e-12)


def test_sample_lookup_errors(spectra_data):
    sf = read_spectra(spectra_data / "cgats_i1profiler_percent.txt")
    assert sf.sample("patch 2 red").name == "Patch 2 red"  # case-insensitive fallback
    with pytest.raises(DreamPrintError, match="no sample named 'x'.*'Patch 1 yellow'"):
        sf.sample("x")
    with pytest.raises(DreamPrintError, match="no sample at index 7"):
        sf.sample(7)
