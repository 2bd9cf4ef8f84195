"""The Clear's low bound (issue 43): where it comes from, and the proof's figures at both."""

import json

import numpy as np
import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.core.profile import INKS, default_profile, save_profile
from dreamprint_gui.physics.clear_bounds import (
    clear_is_modelled,
    clear_low_bound,
    clear_low_bound_K,
)

TINY = ["--height-mm", "3", "--views", "1", "--resolution", "16", "--spp", "2", "--cells", "12",
        "--table-size", "17", "--no-noise-floor"]
CL = INKS.index("Cl")


def test_low_bound_is_measured_md_s_floor_with_the_violet_edge():
    p = default_profile()
    wl = p.wavelengths_nm
    low = clear_low_bound(p)
    k = low.K[CL]
    assert k[wl == 700][0] == pytest.approx(0.002, abs=1e-6)   # MEASURED.md: 0.002 /mm
    assert k[wl == 380][0] == pytest.approx(0.252)               # the modelled 380 nm value
    band = (wl >= 450) & (wl <= 730)
    assert np.all((k[band] >= 0.002) & (k[band] <= 0.0023))     # MEASURED.md's 0.002 there
    assert k[wl == 400][0] == pytest.approx(0.002 + 0.25 * np.exp(-2.0))  # the steep edge
    # the built-in's flat part is 0.03: the bound is 15 x lower there
    assert p.K[CL][wl == 700][0] / k[wl == 700][0] == pytest.approx(15.0, rel=1e-3)
    np.testing.assert_array_equal(low.S, p.S)
    np.testing.assert_array_equal(np.delete(low.K, CL, 0), np.delete(p.K, CL, 0))
    assert np.all(clear_low_bound_K(wl) <= p.K[CL] + 1e-15)
    assert clear_is_modelled(p)
    measured = p.with_settings(provenance={"ink_origin": {"Cl": "measured"}})
    assert not clear_is_modelled(measured)


def run(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def test_proof_reports_both_bounds_of_a_modelled_clear(tmp_path, capsys):
    code, out, err = run(capsys, "proof", "demo", "-o", tmp_path / "a", *TINY,
                         "--clear-low-bound", "--json")
    assert code == 0, err
    clear = json.loads(out)["clear"]
    assert clear["origin"] == "modelled" and "0.002" in clear["low_bound"]
    a, b = clear["figures"]["modelled"], clear["figures"]["low_bound"]
    # the same pixels at both bounds; the block body (source empty) absorbs less at the low
    # bound, so the print covers less where the source shows nothing
    assert a["clear_block_fraction"] == b["clear_block_fraction"] > 0
    assert 0 <= b["clear_block_coverage_error"] < a["clear_block_coverage_error"]
    proof = json.loads((tmp_path / "a" / "proof.json").read_text())
    assert proof["clear"] == clear


def test_a_measured_clear_has_no_bound_to_render(tmp_path, capsys):
    p = default_profile()
    prof = tmp_path / "measured.json"
    save_profile(p.with_settings(provenance={"ink_origin": {i: "measured" for i in INKS}}), prof)
    code, out, err = run(capsys, "proof", "demo", "-o", tmp_path / "b", *TINY, "--profile",
                         prof, "--clear-low-bound")
    assert code == 0, err
    assert "Clear: measured (the Clear is measured: its K and S are no guess)" in out


def test_evaluate_methods_carries_the_bounds_per_row(capsys):
    code, out, err = run(capsys, "evaluate", "methods", "demo", *TINY, "--method", "paper",
                         "--clear-low-bound", "--json")
    assert code == 0, err
    row = json.loads(out)["methods"][0]
    assert set(row["clear"]["figures"]) == {"modelled", "low_bound"}
    code, out, err = run(capsys, "evaluate", "methods", "demo", *TINY, "--method", "paper")
    assert code == 0, err
    assert "Clear: modelled (the Clear is modelled; --clear-low-bound renders" in out


def test_a_chart_proof_refuses_the_option(tmp_path, capsys):
    recipes = tmp_path / "r.csv"
    recipes.write_text("C,M,Y,K,W,Cl\n0.2,0,0,0,0.8,0\n")
    code, _, err = run(capsys, "proof", "--chart", recipes, "-o", tmp_path / "c",
                       "--clear-low-bound")
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "--clear-low-bound renders a volume's print again" in err
    assert not (tmp_path / "c").exists()
