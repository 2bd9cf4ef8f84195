"""`dreamprint calibrate --slabs` (issue 43): a thickness series of slabs, one instrument file
per slab and quantity, fitted with both faces; the profile marks the fitted inks measured."""

import json

import numpy as np
import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.core.profile import INKS, default_profile, ink_origins, load_profile
from dreamprint_gui.physics.slab_fit import simulate_slabs

P = default_profile()
WL = P.wavelengths_nm
BAND = (WL >= 450) & (WL <= 700)
SERIES = [0.5, 1.0, 2.0, 4.0, 8.0]
# a Clear of the kind the target measures: flat 0.02 /mm absorption with a violet edge
K_CL = 0.02 + 0.25 * np.exp(-(WL - 380.0) / 25.0)
S_CL = np.full(WL.size, 0.05)


def write_set(folder, ink, K, S, noise=0.002, seed=0, thickness=SERIES):
    """One CGATS reflectance file and one two-column transmittance CSV per slab, and a
    calibration set naming them with each slab's thickness."""
    slabs = simulate_slabs(ink, K, S, thickness, 0.04, 0.6, noise, np.random.default_rng(seed))
    fields = "\t".join(f"SPECTRAL_NM{w:.0f}" for w in WL)
    entries = []
    for s in slabs:
        r = folder / f"{ink}_{s.thickness_mm:g}mm_R.txt"
        r.write_text("CGATS.17\nNUMBER_OF_FIELDS\t37\nBEGIN_DATA_FORMAT\nSAMPLE_NAME\t"
                     f"{fields}\nEND_DATA_FORMAT\nNUMBER_OF_SETS\t1\nBEGIN_DATA\n\"slab\"\t"
                     + "\t".join(f"{100 * x:.5f}" for x in s.R) + "\nEND_DATA\n")
        t = folder / f"{ink}_{s.thickness_mm:g}mm_T.csv"
        t.write_text("nm,T\n" + "".join(f"{w:g},{x:.6f}\n" for w, x in zip(WL, s.T, strict=True)))
        entries.append(f'[[layer]]\nink = "{ink}"\nthickness_mm = {s.thickness_mm}\n'
                       f'R = "{r.name}"\nT = {{ file = "{t.name}", file_quantity = '
                       '"transmittance" }\n')
    toml = folder / "slabs.toml"
    toml.write_text("\n".join(entries))
    return toml


def run(capsys, *args):
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def test_calibrate_slabs_measures_the_clear(tmp_path, capsys):
    toml = write_set(tmp_path, "Cl", K_CL, S_CL)
    out = tmp_path / "p.json"
    code, stdout, err = run(capsys, "calibrate", str(toml), "--slabs", "-o", str(out))
    assert code == 0, err
    assert "Cl: 5 slab(s), faces k1 0.040 k2 0.596 (from n)" in stdout
    assert "measured: Cl; modelled: C, M, Y, K, W" in stdout
    assert "  0.5 mm: rms R" in stdout and "DOES NOT FIT" not in stdout
    p = load_profile(out)
    assert ink_origins(p) == {**{i: "modelled" for i in INKS}, "Cl": "measured"}
    # with k2 fitted, every slab fits and K, S come back
    code, stdout, err = run(capsys, "calibrate", str(toml), "--slabs", "--fit-k2", "-o",
                            str(out), "--json")
    assert code == 0, err
    rep = json.loads(stdout)["inks"][0]
    assert rep["k2"] == pytest.approx(0.6, abs=0.01) and rep["k2_fitted"]
    assert all(s["fits"] for s in rep["slabs"]) and not rep["warnings"]
    p = load_profile(out)
    i = INKS.index("Cl")
    assert np.max(np.abs(p.K[i] / K_CL - 1)[BAND]) < 0.10
    assert np.max(np.abs(p.S[i] / S_CL - 1)[BAND]) < 0.10
    res = p.residuals["Cl"]
    assert len(res["sigma_K"]) == WL.size and res["faces"]["k2_fitted"]
    np.testing.assert_array_equal(p.K[:i], P.K[:i])  # the other inks: the base's


def test_one_thickness_warns(tmp_path, capsys):
    toml = write_set(tmp_path, "W", P.K[4], P.S[4], thickness=[1.0])
    code, stdout, err = run(capsys, "calibrate", str(toml), "--slabs", "-o",
                            str(tmp_path / "w.json"))
    assert code == 0, err
    assert "warning: ink W: one thickness (1 mm) cannot separate the slab's faces" in err


def test_slab_options_need_slabs(tmp_path, capsys):
    toml = write_set(tmp_path, "W", P.K[4], P.S[4], thickness=[1.0])
    code, _, err = run(capsys, "calibrate", str(toml), "--fit-k2", "-o", str(tmp_path / "w.json"))
    assert code == 2 and "--fit-k2 apply to --slabs" in err


def test_slab_options_do_not_apply_to_a_chart(tmp_path, capsys):
    recipes, refl = tmp_path / "r.csv", tmp_path / "refl.csv"
    recipes.write_text("C,M,Y,K,W,Cl\n0.2,0,0,0,0.8,0\n")
    refl.write_text("400,500\n0.5,0.5\n")
    for extra in (["--slabs"], ["--refractive-index", "1.5"]):
        code, _, err = run(capsys, "calibrate", "--chart", str(recipes), "--reflectance",
                           str(refl), "-o", str(tmp_path / "c.json"), *extra)
        assert code == 2 and "apply to MEASUREMENTS of slabs, not to a chart" in err
    toml = write_set(tmp_path, "W", P.K[4], P.S[4], thickness=[1.0])
    code, _, err = run(capsys, "calibrate", str(toml), "--refractive-index", "1.5", "-o",
                       str(tmp_path / "w.json"))
    assert code == 2 and "--refractive-index and --fit-k2 apply to --slabs" in err
    assert not list(tmp_path.glob("*.json"))
