"""One reader of a chart's files (issue 46): the layouts published PolyJet charts come in."""

import numpy as np
import pytest

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.profile import INKS, default_profile
from dreamprint_gui.io.chart_files import read_chart
from dreamprint_gui.io.measurements_csv import read_measurements_csv
from dreamprint_gui.io.recipes import read_recipes
from dreamprint_gui.physics.colorimetry import observer_for
from dreamprint_gui.physics.kubelka_munk import mix, reflectance_infinite

FILE_ORDER = ["K", "C", "M", "Y", "W"]  # the published chart's column order


def _percent_recipes(n, seed=1):
    """n mixtures of five inks in steps of 25 %, summing to 100."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < n:
        parts = rng.multinomial(4, np.ones(5) / 5) * 25
        out.append(dict(zip(FILE_ORDER, parts.tolist(), strict=True)))
    return out


def _expected(recipes):
    c = np.zeros((len(recipes), len(INKS)))
    for r, rec in enumerate(recipes):
        for ink, v in rec.items():
            c[r, INKS.index(ink)] = v / 100.0
    return c


def _write_layouts(tmp_path, recipes):
    """The same recipes in four layouts; returns their paths."""
    named = tmp_path / "ratios.csv"                 # as the published chart: K,C,... / k50,c0,...
    named.write_text(",".join(FILE_ORDER) + "\n" + "".join(
        ",".join(f"{i.lower()}{r[i]}" for i in FILE_ORDER) + "\n" for r in recipes))
    headerless = tmp_path / "headerless.csv"         # K=50,C=0,... with no header
    headerless.write_text("".join(",".join(f"{i}={r[i]}" for i in FILE_ORDER) + "\n"
                                  for r in recipes))
    plain = tmp_path / "plain.csv"                  # fractions under a header of inks
    plain.write_text("id,C,M,Y,K,W\n" + "".join(
        f"p{n}," + ",".join(repr(r[i] / 100) for i in "CMYKW") + "\n"
        for n, r in enumerate(recipes)))
    per_cell = tmp_path / "ratio_2_x.csv"           # one mixture per cell, two rows
    half = (len(recipes) + 1) // 2
    rows = [recipes[:half], recipes[half:]]
    lines = ['"C, M, Y, K, W"' + "," * (half - 1)]
    for row in rows:
        lines.append(",".join('"' + ", ".join(str(r[i]) for i in "CMYKW") + '"' for r in row)
                     + "," * (half - len(row)))
    per_cell.write_text("\r\n".join(lines) + "\r\n")
    return named, headerless, plain, per_cell


def test_every_recipe_layout_reads_the_same_mixtures(tmp_path):
    recipes = _percent_recipes(13)
    want = _expected(recipes)
    for path in _write_layouts(tmp_path, recipes):
        got = read_recipes(path)
        assert np.allclose(got, want, atol=1e-12), path.name


@pytest.mark.parametrize("text, words", [
    ("K,C,M,Y,W\nk50,m0,c50,y0,w0\n", "cell 'm0' names ink M in the column of ink C"),
    ("K,C,M,Y,W\nk50,c0,m40,y0,w0\n", "sum to 90, not 1 (or 100 %)"),
    ("K,C,M,Y,W\nk50,c0,mx,y0,w50\n", "ink M: 'mx' is not a number"),
    ('"C, M, Y, K, W",\n"0, 50, 0, 50","0, 0, 0, 50, 50"\n', "has 4 values, the first cell"),
    ("k50,c50\nk50,k50\n", "cell 'k50' names ink K in the column of ink C"),
])
def test_recipe_errors_name_the_line_and_the_cell(tmp_path, text, words):
    f = tmp_path / "r.csv"
    f.write_text(text)
    with pytest.raises(DreamPrintError) as e:
        read_recipes(f)
    assert words in str(e.value) and str(f) in str(e.value)
    assert f"{f}:2:" in str(e.value)


def _cgats_csv(path, wl, R, lab, percent=False):
    """A chart's measurements as spreadsheets export them: LAB_L,LAB_A,LAB_B, then spectra."""
    field = "SPECTRAL_PCT" if percent else "SPECTRAL_NM"
    scale = 100.0 if percent else 1.0
    head = "LAB_L,LAB_A,LAB_B," + ",".join(f"{field}{w:g}" for w in wl)
    body = "".join(",".join(f"{x:.2f}" for x in lab[r]) + ","
                   + ",".join(f"{x * scale:.6f}" for x in R[r]) + "\n" for r in range(len(R)))
    path.write_text(head + "\n" + body)


@pytest.mark.parametrize("percent", [False, True])
def test_read_chart_takes_cgats_headers_with_lab_columns(tmp_path, percent):
    base = default_profile()
    recipes = _percent_recipes(9, seed=3)
    c = _expected(recipes)
    R = reflectance_infinite(*mix(c, base.K, base.S))
    lab = observer_for(base.wavelengths_nm).spectra_to_Lab(R)
    named, *_ = _write_layouts(tmp_path, recipes)
    meas = tmp_path / "color_measurements.csv"
    _cgats_csv(meas, base.wavelengths_nm, R, lab, percent)
    chart = read_chart(named, meas, base.wavelengths_nm)
    assert np.allclose(chart.recipes, c)
    assert np.allclose(chart.reflectance, R, atol=1e-6)  # Lab columns are not read as spectra


def test_read_chart_counts_must_agree(tmp_path):
    base = default_profile()
    recipes = _percent_recipes(5)
    c = _expected(recipes)
    R = reflectance_infinite(*mix(c, base.K, base.S))
    named, *_ = _write_layouts(tmp_path, recipes)
    meas = tmp_path / "m.csv"
    _cgats_csv(meas, base.wavelengths_nm, R[:4], np.zeros((4, 3)))
    with pytest.raises(DreamPrintError, match="4 measured spectra but 5 recipes"):
        read_chart(named, meas, base.wavelengths_nm)


def test_measurements_csv_takes_cgats_wavelength_headings(tmp_path):
    wl = np.arange(380.0, 740.0, 10.0)
    R = np.linspace(0.2, 0.6, wl.size)
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    a.write_text("ink,quantity,thickness_mm," + ",".join(f"{w:g}" for w in wl) + "\n"
                 + "C,R,0.1," + ",".join(repr(x) for x in R) + "\n")
    b.write_text("ink,quantity,thickness_mm," + ",".join(f"SPECTRAL_NM{w:g}" for w in wl)
                 + "\n" + "C,R,0.1," + ",".join(repr(x) for x in R) + "\n")
    la, lb = read_measurements_csv(a, wl), read_measurements_csv(b, wl)
    assert np.allclose(la[0].R, R) and np.allclose(lb[0].R, R)
    b.write_text("ink,quantity,thickness_mm,LAB_L,380,390,400\nC,R,0.1,50,0.1,0.1,0.1\n")
    with pytest.raises(DreamPrintError, match="'LAB_L' after thickness_mm is not a wavelength"):
        read_measurements_csv(b, wl)


@pytest.mark.parametrize("text", [
    "id;C;M;Y;K;W\np1;50;0;0;50;0\np2;0;50;50;0;0\n",                 # a ';' spreadsheet
    "id;C;M;Y;K;W\np1;0,5;0;0;0,5;0\np2;0;0,5;0,5;0;0\n",             # and its decimal comma
    "name\tC\tM\tY\tK\tW\np1\t50%\t0\t0\t50%\t0\np2\t0\t50\t50\t0\t0\n",  # tab, percent signs
    '"C; M; Y; K; W",\n"50; 0; 0; 50; 0","0; 50; 50; 0; 0"\n',        # ';' lists in cells
])
def test_recipes_in_a_semicolon_or_tab_file_read_as_the_spectra_do(tmp_path, text):
    """The chart's recipes take the delimiters and decimal commas its measurement file may
    use (the one delimiter rule of the spectra readers); before, an id column in a ';' file
    was refused as "column 'id;C;M;Y;K;W' is not an ink" and 0,5 split into two cells."""
    p = tmp_path / "recipes.csv"
    p.write_text(text, encoding="utf-8")
    want = np.zeros((2, len(INKS)))
    want[0, [INKS.index("C"), INKS.index("K")]] = 0.5
    want[1, [INKS.index("M"), INKS.index("Y")]] = 0.5
    np.testing.assert_allclose(read_recipes(p), want)


def test_an_unreadable_recipe_file_is_one_line(tmp_path, monkeypatch):
    """A file the operator may not read (permissions; tests run as root, so it is simulated)."""
    p = tmp_path / "recipes.csv"
    p.write_text("C,M,Y,K,W\n1,0,0,0,0\n")

    def denied(self, *a, **kw):
        raise PermissionError(13, "Permission denied", str(self))

    monkeypatch.setattr(type(p), "read_text", denied)
    with pytest.raises(DreamPrintError, match="cannot read it") as e:
        read_recipes(p)
    assert str(p) in str(e.value)
