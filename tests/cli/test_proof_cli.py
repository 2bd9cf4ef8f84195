"""``dreamprint proof`` and ``evaluate methods``: output, determinism, one-line errors, cancel."""

import json
import threading

import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.job.plan import JobCancelled
from dreamprint_gui.proof.runner import ProofSettings, run_proof

TINY = ["--height-mm", "3", "--views", "1", "--resolution", "16", "--spp", "2", "--cells", "12",
        "--table-size", "17"]


def run(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def test_proof_demo_writes_everything_and_is_deterministic(tmp_path, capsys):
    code, out, _ = run(capsys, "proof", "demo", "-o", tmp_path / "a", *TINY, "--json")
    assert code == 0
    rep = json.loads(out)
    names = {p.name for p in (tmp_path / "a").iterdir()}
    assert names == {"view_00_source.png", "view_00_print.png", "view_00_de2000.png",
                     "contact_sheet.png", "proof.json"}
    assert rep["renderer"]["renderer"] == "mitsuba" and rep["renderer"]["version"]
    o = rep["overall"]
    assert o["object_pixels"] > 0 and 0 <= o["mean_de2000"] <= o["p95_de2000"] + 1e-9
    assert set(o) >= {"psnr_db", "ssim", "coverage_error", "coverage_abs_error",
                      "mean_scielab_de2000", "p95_scielab_de2000", "empty_source_fraction",
                      "empty_source_de2000", "empty_source_coverage_error"}
    # the default Clear block: the object pixels where the source is empty are part of the
    # figures (their shares are at most the figures themselves)
    assert 0 <= o["empty_source_de2000"] <= o["mean_de2000"]
    # the headline, inside the source, beside them (issue 44); judged in the job's intent
    assert o["inside_source_pixels"] > 0 and rep["reference"]["intent"] == "colorimetric"
    assert o["inside_source_mean_de2000"] == pytest.approx(
        (o["mean_de2000"] - o["empty_source_de2000"]) / (1 - o["empty_source_fraction"]))
    # the noise floor: from the two halves (seeds 0, 1); S-CIELAB blurs what the eye does not see
    f = rep["noise_floor"]
    assert f["seeds"] == [0, 1] and f["object_pixels"] > 0
    assert 0 < f["mean_scielab_de2000"] < f["mean_de2000"] <= f["p95_de2000"] + 1e-9
    assert rep["viewing"]["distance_mm"] == 500.0 and rep["viewing"]["pixels_per_degree"] > 0
    assert json.loads((tmp_path / "a" / "proof.json").read_text())["noise_floor"] == f
    assert rep["optics"] == {"surface": "none", "phase": "isotropic", "from": "defaults"}
    code, out2, _ = run(capsys, "proof", "demo", "-o", tmp_path / "b", *TINY, "--json")
    rep2 = json.loads(out2)
    assert rep2["overall"] == rep["overall"]
    assert ((tmp_path / "a" / "view_00_print.png").read_bytes()
            == (tmp_path / "b" / "view_00_print.png").read_bytes())


def test_proof_of_an_exported_job(tmp_path, capsys):
    job = tmp_path / "job"
    assert main(["convert", "demo", "-o", str(job), "--height-mm", "2", "--table-size",
                 "17"]) == 0
    capsys.readouterr()
    code, out, err = run(capsys, "proof", job, "-o", tmp_path / "p", "--views", "1",
                         "--resolution", "16", "--spp", "2", "--cells", "12", "--json")
    assert code == 0, err
    assert json.loads(out)["source"] == str(job)
    # a missing slice, then a manifest that does not match: one line, exit 2, nothing written
    slices = sorted((job / "slices").iterdir())
    slices[3].rename(tmp_path / "moved.png")
    code, _, err = run(capsys, "proof", job, "-o", tmp_path / "q", "--views", "1")
    assert code == 2 and err.startswith("dreamprint: error:") and "missing" in err
    assert err.count("\n") == 1 and not (tmp_path / "q").exists()
    (tmp_path / "moved.png").rename(slices[3])
    # a truncated slice (perhaps one the block averaging would not read): refused up front
    good = slices[5].read_bytes()
    slices[5].write_bytes(good[:100])
    code, _, err = run(capsys, "proof", job, "-o", tmp_path / "q", "--views", "1")
    assert code == 2 and err.startswith("dreamprint: error:") and "truncated" in err
    assert err.count("\n") == 1 and not (tmp_path / "q").exists()
    slices[5].write_bytes(good)
    m = json.loads((job / "manifest.json").read_text())
    m["grid_dimensions"][0] += 1
    (job / "manifest.json").write_text(json.dumps(m))
    code, _, err = run(capsys, "proof", job, "-o", tmp_path / "q", "--views", "1")
    assert code == 2 and err.startswith("dreamprint: error:") and err.count("\n") == 1


@pytest.mark.parametrize("extra, words", [
    (["--resolution", "0"], "--resolution"),
    (["--resolution", "100000"], "--resolution"),
    (["--spp", "0"], "--spp"),
    (["--spp", "10000000"], "--spp"),
    (["--views", "0"], "--views"),
    (["--method", "magic"], "'magic' is not one of"),
    (["--sampler", "sobol"], "unknown sampler"),
    (["--surface", "satin"], "unknown surface"),
    (["--phase", "hg:1.5"], "hg:G"),
    (["--phase", "mie"], "unknown phase"),
    (["--surface", "glossy", "--background", "empty"], "--background clear"),
    (["--viewing-distance-mm", "0"], "--viewing-distance-mm"),
])
def test_absurd_settings_are_one_line_errors(tmp_path, capsys, extra, words):
    code, _, err = run(capsys, "proof", "demo", "-o", tmp_path / "x", "--height-mm", "3",
                       *extra)
    assert code == 2 and err.startswith("dreamprint: error:") and words in err
    assert err.count("\n") == 1 and not (tmp_path / "x").exists()


def test_unreadable_source_and_existing_output(tmp_path, capsys):
    bad = tmp_path / "cloud.vdb"
    bad.write_bytes(b"not a vdb at all")
    code, _, err = run(capsys, "proof", bad, "-o", tmp_path / "x", "--height-mm", "3")
    assert code == 2 and err.startswith("dreamprint: error:") and err.count("\n") == 1
    code, _, err = run(capsys, "proof", tmp_path / "nothing.vdb", "-o", tmp_path / "x",
                       "--height-mm", "3")
    assert code == 2 and "no such file" in err
    (tmp_path / "exists").mkdir()
    code, _, err = run(capsys, "proof", "demo", "-o", tmp_path / "exists", *TINY)
    assert code == 2 and "already exists" in err


def test_output_over_the_source_is_refused(tmp_path, capsys):
    """``-o`` equal to (or a parent of) the source, even with --overwrite: the job or volume
    judged must not be replaced by its proof."""
    job = tmp_path / "job"
    job.mkdir()
    (job / "manifest.json").write_text("{}")
    for src, out in ((job, job), (job, tmp_path), (job / "manifest.json", tmp_path)):
        code, _, err = run(capsys, "proof", src, "-o", out, "--overwrite", "--views", "1",
                           "--resolution", "16", "--spp", "2")
        assert code == 2 and err.startswith("dreamprint: error:"), err
        assert "or contains, the source" in err and err.count("\n") == 1
    assert (job / "manifest.json").read_text() == "{}"


def test_cancel_leaves_nothing(tmp_path):
    cancel = threading.Event()
    s = ProofSettings(source="demo", output=str(tmp_path / "c"), height_mm=3, views=1,
                      resolution=16, spp=2, max_cells=12, table_size=17)
    gen = run_proof(s, cancel)
    with pytest.raises(JobCancelled):
        for p in gen:
            if p.stage == "source":  # always reported (labels may finish between polls)
                cancel.set()
    assert list(tmp_path.iterdir()) == []


def test_evaluate_methods_table(capsys):
    code, out, err = run(capsys, "evaluate", "methods", "demo", *TINY, "--method", "paper",
                         "--halftone", "blue-noise", "--halftone", "random", "--json")
    assert code == 0, err
    t = json.loads(out)
    assert [(r["method"], r["halftone"]) for r in t["methods"]] == [
        ("paper", "blue-noise"), ("paper", "random")]
    assert all(r["object_pixels"] > 0 for r in t["methods"])
    code, _, err = run(capsys, "evaluate", "methods", "demo", *TINY, "--method", "nope")
    assert code == 2 and "'nope' is not one of" in err and err.count("\n") == 1
    for r in t["methods"]:   # each row has its floor, and is judged against the best row's
        assert r["noise_floor"]["mean_scielab_de2000"] > 0
        # the headline is inside the source; all object pixels beside it, keys unchanged
        assert r["inside_source_pixels"] > 0 and r["noise_floor"]["inside_source_pixels"] > 0
        assert r["inside_source_mean_de2000"] <= r["inside_source_p95_de2000"] + 1e-9
        for key in ("inside_source_mean_de2000", "inside_source_mean_scielab_de2000",
                    "mean_de2000", "mean_scielab_de2000"):
            v = r["vs_best"][key]
            assert v["difference"] >= 0 and v["significant"] == (v["difference"] > v["threshold"])


def test_evaluate_methods_text_marks_noise(capsys):
    code, out, err = run(capsys, "evaluate", "methods", "demo", *TINY, "--method", "paper",
                         "--halftone", "blue-noise", "--halftone", "random")
    assert code == 0, err
    rows = [ln for ln in out.splitlines() if ln.startswith("paper")]
    assert len(rows) == 2
    # the legend says what a "~" means (a difference within the noise floor is no ranking)
    assert "within 3 x the noise floor" in out


def test_evaluate_methods_honours_halftone(capsys):
    """``--halftone random`` alone gives one row, random (it was once silently replaced)."""
    code, out, err = run(capsys, "evaluate", "methods", "demo", *TINY, "--method", "paper",
                         "--halftone", "random", "--json")
    assert code == 0, err
    assert [r["halftone"] for r in json.loads(out)["methods"]] == ["random"]
    code, _, err = run(capsys, "evaluate", "methods", "demo", *TINY, "--halftones", "random")
    assert code == 2 and "--halftones" in err  # the former second option is gone


@pytest.mark.parametrize(("cmd", "option", "bad"), [
    (("proof", "demo", "-o", "X"), "--method", "fast"),
    (("proof", "demo", "-o", "X"), "--halftone", "bluenoise"),
    (("proof", "demo", "-o", "X"), "--background", "white"),
    (("evaluate", "methods", "demo"), "--halftone", "ordered"),
    (("convert", "demo", "-o", "X"), "--halftone", "ordered"),
    (("convert", "demo", "-o", "X"), "--background", "none"),
])
def test_fixed_choices_are_refused_before_any_work(capsys, cmd, option, bad):
    code, _, err = run(capsys, *cmd, "--height-mm", "1", option, bad)
    assert code == 2 and f"'{bad}' is not one of" in err and err.count("\n") == 1, err


def test_cli_choices_are_the_engines():
    from dreamprint_gui.cli.proof import HALFTONE_CHOICES, METHOD_CHOICES
    from dreamprint_gui.job.halftone import HALFTONE_METHODS
    from dreamprint_gui.proof.methods import METHODS

    assert METHOD_CHOICES == METHODS and HALFTONE_CHOICES == HALFTONE_METHODS


def test_proof_with_a_surface_and_hg_phase(tmp_path, capsys):
    code, out, err = run(capsys, "proof", "demo", "-o", tmp_path / "s", *TINY, "--surface",
                         "matte", "--phase", "hg:0.4", "--no-noise-floor", "--json")
    assert code == 0, err
    rep = json.loads(out)
    assert rep["optics"]["surface"] == "matte" and rep["optics"]["from"] == "command line"
    assert rep["optics"]["refractive_index"] == 1.5 and rep["km_to_rte"]["g"] == 0.4
    assert rep["renderer"]["surface"] == "matte" and rep["noise_floor"] is None
    assert rep["overall"]["object_pixels"] > 0


def test_a_solid_jobs_folder_is_proofed_against_its_source_as_the_job_read_it(
        tmp_path, capsys, shared_data):
    import numpy as np

    from dreamprint_gui.job.plan import ConvertSettings
    from dreamprint_gui.proof.labels import EngineLabels, JobFolderLabels
    from dreamprint_gui.proof.source_render import sample_source

    knight = str(shared_data / "voxels" / "magicavoxel_chr_knight.vox")
    job = tmp_path / "job"
    assert main(["convert", knight, "-o", str(job), "--height-mm", "2", "--table-size",
                 "17", "-q"]) == 0
    capsys.readouterr()
    folder = JobFolderLabels(job)
    engine = EngineLabels(ConvertSettings(source=knight, height_mm=2.0, table_size=17))
    assert folder.grid == engine.grid
    lo = np.zeros(3)
    a, b = (sample_source(x.source, x.grid, (8, 8, 8), 1.0,
                          tuple(-(-n // 8) for n in x.grid.shape_xyz), lo)
            for x in (folder, engine))
    assert a.nearest and b.nearest  # solid: the occupied cells at the solid density
    np.testing.assert_array_equal(a.sigma, b.sigma)


def test_a_figure_within_the_noise_says_how_to_tell_the_rows_apart():
    """A "~" comes with the way out: more samples per pixel (issue 46)."""
    from dreamprint_gui.cli.proof import noise_legend
    from dreamprint_gui.proof.compare import mark_significance

    def row(de, floor):
        return {"mean_de2000": de, "mean_scielab_de2000": de,
                "noise_floor": {"mean_de2000": floor, "mean_scielab_de2000": floor}}

    close = [row(5.0, 0.2), row(5.3, 0.2)]          # 0.3 apart, 3 x floor = 0.6: noise
    mark_significance(close)
    lines = noise_legend(close, 16)
    assert len(lines) == 2 and "raise --spp (now 16)" in lines[1] and "--spp 64" in lines[1]
    apart = [row(5.0, 0.05), row(6.0, 0.05)]        # 1.0 apart, threshold 0.15: a ranking
    mark_significance(apart)
    assert len(noise_legend(apart, 16)) == 1
