"""The JCAMP-DX ASDF codec against values decoded by hand from the specification's rules
(McDonald & Wilks 1988, table of SQZ/DIF/DUP characters)."""

import numpy as np
import pytest

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.spectra import read_spectra
from dreamprint_gui.io.spectra.jcampdx import decode_asdf_line, encode_difdup


@pytest.mark.parametrize("line, ys", [
    ("400 A0J0%TN%T", [10, 20, 20, 20, 25, 25, 25]),        # DIF with DUP of a DIF token
    ("400 A0B0TB5C0T", [10, 20, 20, 25, 30, 30]),           # DUP after SQZ values
    ("400 a5j2", [-15, -27]),                               # negative SQZ, DIF -12
    ("400 @S0", [0] * 10),                                  # two-digit DUP count
    ("400 1.5E-01 2.5E-01", [0.15, 0.25]),                  # AFFN with exponents
    ("400+10+20-5", [10, 20, -5]),                          # PAC: signs as separators
    ("400 10,20;30", [10, 20, 30]),                         # AFFN with , and ; separators
    ("400 A0?B0", [10, np.nan, 20]),                        # ? marks a missing value
])
def test_decode_hand_worked_lines(line, ys):
    x, got, _ = decode_asdf_line(line)
    assert x == 400
    np.testing.assert_array_equal(got, ys)


def test_encode_decode_round_trip_with_y_checks():
    rng = np.random.default_rng(4)
    vals = np.cumsum(rng.integers(-30, 30, 200))
    vals[50:80] = vals[50]  # a flat run: DUP of a zero difference
    x = np.arange(200.0)
    lines = encode_difdup(vals.tolist(), x.tolist(), per_line=15)
    ys, prev_dif = [], False
    for ln in lines:
        _, v, prev = decode_asdf_line(ln)
        if prev_dif:
            assert v[0] == ys[-1]
            v = v[1:]
        ys += v
        prev_dif = prev
    np.testing.assert_array_equal(ys, vals)


HEADER = """##TITLE=t
##JCAMP-DX=4.24
##DATA TYPE=UV/VIS SPECTRUM
##XUNITS=NANOMETERS
##YUNITS=TRANSMITTANCE
##XFACTOR=1
##YFACTOR=0.01
##FIRSTX=400
##LASTX=460
##NPOINTS=7
##XYDATA=(X++(Y..Y))
"""


def _write(tmp_path, body, name="t.jdx"):
    p = tmp_path / name
    p.write_text(HEADER + body)
    return p


def test_two_line_difdup_file(tmp_path):
    p = _write(tmp_path, "400 A0J0%\n420 B0%N%J0\n##END=\n")
    s = read_spectra(p).samples[0]
    np.testing.assert_array_equal(s.wavelengths_nm, np.arange(400.0, 461.0, 10.0))
    np.testing.assert_allclose(s.values, [0.10, 0.20, 0.20, 0.20, 0.25, 0.25, 0.35])


@pytest.mark.parametrize("body, match, line", [
    ("400 A0J0%\n420 C0%N%J0\n##END=\n", "Y check failed", 13),
    ("400 A0J0%\n440 B0%N%J0\n##END=\n", "X check failed", 13),
    ("400 A0J0%\n420 B0%N\n##END=\n", "NPOINTS is 7", 13),
    ("400 A0J0%\n420 B0%N%J0\n", "without ##END=", 13),
    ("400 A0J0%\n420 B0%N%*0\n##END=\n", "unexpected character", 13),
    ("400 A0J0%\n420 B0%N%J0K0K0\n##END=\n", "more ordinates", 13),
    ("400 A0J0%\n420 B0%S99999999999\n##END=\n", "DUP count 199999999999", 13),
])
def test_damaged_compressed_files(tmp_path, body, match, line):
    p = _write(tmp_path, body)
    with pytest.raises(DreamPrintError, match=match) as exc:
        read_spectra(p)
    assert exc.value.line == line and exc.value.path == str(p)


def test_link_compound_file_is_several_samples(tmp_path):
    from dreamprint_gui.io.spectra import Sample, write_spectra

    wl = np.arange(400.0, 701.0, 5.0)
    samples = [Sample(f"s{i}", wl, 0.1 * i + 0.5 * np.exp(-((wl - 550) / 50) ** 2))
               for i in (1, 2)]
    p = tmp_path / "link.jdx"
    write_spectra(p, samples, quantity="transmittance", format="jcamp-dx")
    assert "##DATA TYPE=LINK" in p.read_text()
    sf = read_spectra(p)
    assert sf.names == ["s1", "s2"] and sf.quantity == "transmittance"
    for a, b in zip(sf.samples, samples, strict=True):
        np.testing.assert_allclose(a.values, b.values, atol=1e-11)


def test_peak_table_refused(tmp_path):
    p = tmp_path / "peaks.jdx"
    p.write_text("##TITLE=p\n##JCAMP-DX=4.24\n##XUNITS=NANOMETERS\n##YUNITS=ABSORBANCE\n"
                 "##PEAK TABLE=(XY..XY)\n400,1 500,2\n##END=\n")
    with pytest.raises(DreamPrintError, match="PEAK TABLE"):
        read_spectra(p)
