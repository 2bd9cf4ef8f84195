"""`dreamprint lookup` and `dreamprint gamut` (issue 5's command-line contract)."""

import json

import pytest

from dreamprint_gui.cli import main

pytestmark = pytest.mark.usefixtures("private_cache")


def _run(capsys, *args):
    code = main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


def test_lookup_json_matches_predict(capsys):
    code, out, _ = _run(capsys, "lookup", "--rgb", "0.2,0.5,0.7", "--density", "4",
                        "--size", "9", "--json")
    assert code == 0
    (rec,) = json.loads(out)
    assert set(rec) >= {"rgb", "concentrations", "aligned", "sRGB", "Lab", "dE2000",
                        "sigma_per_mm"}
    assert set(rec["concentrations"]) == {"C", "M", "Y", "K", "W"}
    assert set(rec["aligned"]) == {"C", "M", "Y", "K", "W", "Cl"}
    assert rec["sigma_per_mm"] == pytest.approx(4.0, rel=1e-6)
    mix = ",".join(f"{k}={v!r}" for k, v in rec["concentrations"].items())
    code, out, _ = _run(capsys, "predict", "--mix", mix, "--json")
    assert code == 0
    assert json.loads(out)["sRGB"] == rec["sRGB"]


def test_lookup_rgb_file_and_errors(capsys, tmp_path):
    f = tmp_path / "c.csv"
    f.write_text("R,G,B\n0.1,0.2,0.3\n1,1,1\n")
    code, out, _ = _run(capsys, "lookup", "--rgb-file", str(f), "--size", "9", "--json")
    assert code == 0 and len(json.loads(out)) == 2
    f.write_text("red,green\n0.1,0.2\n")
    code, _, err = _run(capsys, "lookup", "--rgb-file", str(f), "--size", "9")
    assert code == 2 and f"{f}:1:" in err and "R, G and B" in err
    f.write_text("R,G,B\n0.1,x,0.3\n")
    code, _, err = _run(capsys, "lookup", "--rgb-file", str(f), "--size", "9")
    assert code == 2 and f"{f}:2:" in err
    code, _, err = _run(capsys, "lookup", "--rgb", "0.1,2,0.3", "--size", "9")
    assert code == 2 and "[0, 1]" in err


def test_gamut_json_chart_and_plot(capsys, tmp_path):
    chart, plot = tmp_path / "chart.png", tmp_path / "plot.png"
    code, out, _ = _run(capsys, "gamut", "--size", "9", "--samples", "200", "--json",
                        "--chart", str(chart), "--plot", str(plot))
    assert code == 0
    rep = json.loads(out)
    for key in ("lut_size", "build_seconds", "cached", "colour_thickness_mm",
                "srgb_in_gamut_fraction", "lab_gamut_volume", "lut_vs_direct_dE2000",
                "out_of_gamut_dE2000"):
        assert key in rep
    assert rep["lut_size"] == 9 and 0 < rep["srgb_in_gamut_fraction"] < 1
    assert 0 < rep["lab_gamut_volume"] < rep["srgb_lab_volume"]
    assert chart.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    first = rep
    code, out, _ = _run(capsys, "gamut", "--size", "9", "--samples", "50", "--json")
    rep = json.loads(out)
    assert rep["cached"] is True
    # this run's time and the cached build's time are reported apart, never contradicting
    assert rep["build_seconds"] is None and rep["seconds"] == rep["load_seconds"] >= 0
    if not first["cached"]:
        assert rep["built_seconds_when_cached"] == first["build_seconds"] == first["seconds"]
    # every objective's figures (issue 17)
    assert set(rep["objectives"]) == {"srgb", "cielab", "de2000"}
    for fig in rep["objectives"].values():
        assert fig["intent"] == "colorimetric"
        assert set(fig["lut_vs_direct_dE2000"]) >= {"mean", "p95"}
        assert 0 < fig["srgb_in_gamut_fraction"] < 1
        assert fig["lookup_minus_lattice_best_dE2000"]["count"] == 300
        # a cached table's per-objective build time is not reported as this run's build
        assert fig["cached"] is True and fig["build_seconds"] is None
        assert fig["built_seconds_when_cached"] >= 0
        assert fig["adjacent_node_dE2000"]["max"] > 0


def test_gamut_intent_and_objective_choice(capsys):
    code, out, _ = _run(capsys, "gamut", "--size", "5", "--samples", "50", "--json",
                        "--objective", "cielab", "--intent", "perceptual", "--no-compare")
    assert code == 0
    rep = json.loads(out)
    assert (rep["objective"], rep["intent"]) == ("cielab", "perceptual")
    assert list(rep["objectives"]) == ["cielab"] and "SGCK" in rep["out_of_gamut_policy"]
    code, out, _ = _run(capsys, "lookup", "--rgb", "0,0,1", "--size", "5", "--json",
                        "--intent", "perceptual", "--objective", "cielab")
    assert code == 0 and json.loads(out)[0]["dE2000"] > 1.0
    code, _, err = _run(capsys, "gamut", "--intent", "saturation")
    assert code == 2 and "saturation" in err
    code, _, err = _run(capsys, "gamut", "--objective", "lab")  # no undocumented aliases
    assert code == 2 and "'lab' is not one of" in err


def test_gamut_progress_on_stderr_only_while_building(capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    args = ("gamut", "--size", "6", "--samples", "20", "--no-compare", "--json")
    code, out, err = _run(capsys, *args)
    assert code == 0 and json.loads(out)["cached"] is False
    assert "building colour tables (de2000, colorimetric): 100 %" in err  # --json too
    assert "evaluating" in err
    code, out, err = _run(capsys, *args)
    assert code == 0 and json.loads(out)["cached"] is True
    assert "building" not in err
    # the direct solves (seconds per objective) say each step as it ends (issue 46)
    code, out, err = _run(capsys, "gamut", "--size", "6", "--samples", "20", "--json")
    steps = [ln for ln in err.splitlines() if ln.startswith("evaluating: ")]
    assert code == 0 and len(steps) == 1 + 2 + 2      # started, the lattice, 3 objectives
    assert steps[0].endswith("0/4, started") and steps[-1].endswith(", done)")


def test_lookup_and_gamut_reuse_the_tables_a_job_built(capsys, tmp_path):
    """A job's tables (the profile at its printer's layer) serve lookup and gamut: no second
    build (issue 46: lookup rebuilt them at the profile's own 14 um layer). Size 5: no other
    test builds it in this session's cache."""
    code, _, err = _run(capsys, "convert", "demo", "-o", str(tmp_path / "J"), "--height-mm",
                        "0.5", "--table-size", "5")
    assert code == 0 and "building colour tables" in err
    code, _, err = _run(capsys, "lookup", "--rgb", "0.2,0.5,0.7", "--size", "5")
    assert code == 0 and "building" not in err
    code, _, err = _run(capsys, "gamut", "--size", "5", "--samples", "20", "--no-compare")
    assert code == 0 and "building" not in err
    # another printer's layer is another table
    code, _, err = _run(capsys, "lookup", "--rgb", "0.2,0.5,0.7", "--size", "5", "--printer",
                        "voxelprint-14um")
    assert code == 0 and "building colour tables" in err
