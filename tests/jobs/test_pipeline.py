"""The conversion pipeline end to end on the built-in demo source (small grids, small tables)."""

import hashlib
import json
import math
import os
import subprocess
import sys
import threading

import numpy as np
import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.job.check import check_job
from dreamprint_gui.job.encode.png_slices import read_png_labels
from dreamprint_gui.job.plan import ConvertSettings, JobCancelled, prepare_job
from dreamprint_gui.job.run import run_conversion
from dreamprint_gui.job.slab import halftone_layer

TABLE = 17  # small colour tables keep the suite fast; the pipeline is the same at 100


def _settings(out, **kw):
    base = dict(source="demo", output=out, height_mm=0.6, table_size=TABLE, seed=3)
    base.update(kw)
    return ConvertSettings(**base)


def _run(settings, cancel=None):
    gen = run_conversion(settings, cancel)
    progress = []
    while True:
        try:
            progress.append(next(gen))
        except StopIteration as stop:
            return stop.value, progress


def _digests(job):
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted((job / "slices").iterdir())}


@pytest.fixture(scope="module")
def reference_job(tmp_path_factory):
    out = tmp_path_factory.mktemp("ref") / "JOB"
    manifest, progress = _run(_settings(out, workers=1, slab_layers=3))
    return out, manifest, progress


def test_job_layout_and_manifest(reference_job):
    job, manifest, progress = reference_job
    nx, ny, nz = manifest["grid_dimensions"]
    assert nz == math.ceil(0.6 / 0.027)  # the default printer, voxelprint-27um
    assert sorted(os.listdir(job)) == ["manifest.json", "slices"]
    names = sorted(os.listdir(job / "slices"))
    assert names == [f"{z:05d}.png" for z in range(nz)]
    on_disk = json.loads((job / "manifest.json").read_text())
    assert on_disk == json.loads(json.dumps(manifest))
    for key in ("software", "source", "profile", "printer", "placement", "physical_size_mm",
                "voxel_mm",
                "grid_dimensions", "seed", "halftoning", "voxel_counts", "clamped_density",
                "timings_s"):
        assert key in manifest
    assert sum(manifest["voxel_counts"].values()) == nx * ny * nz
    assert manifest["physical_size_mm"][2] == pytest.approx(nz * 0.027)
    assert progress[-1].stage == "done" and progress[-1].layers_done == nz
    done = [p.layers_done for p in progress if p.stage == "converting"]
    assert done == sorted(done) and done[-1] == nz


def test_evaluate_job_is_consistent(reference_job, capsys):
    job, manifest, _ = reference_job
    report = check_job(job)
    assert report["consistent"], report["problems"]
    n = report["total_voxels"]
    for m, r in report["materials"].items():
        # Halftoning is unbiased: fraction within 5 binomial standard errors of the intent.
        p = r["intended"]
        assert abs(r["fraction"] - p) <= 5 * np.sqrt(p * (1 - p) / n) + 1e-12, m
    assert main(["evaluate", "job", str(job), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["consistent"] and set(out["materials"]) == {"C", "M", "Y", "K", "W", "Cl",
                                                           "empty"}


def test_evaluate_job_detects_a_tampered_slice(reference_job, tmp_path):
    import shutil

    job, manifest, _ = reference_job
    copy = tmp_path / "J"
    shutil.copytree(job, copy)
    (copy / "slices" / "00001.png").unlink()
    report = check_job(copy)
    assert not report["consistent"] and any("missing" in p for p in report["problems"])


def _results(manifest):
    """What a job reports about its voxels (not how it ran: timings, workers, scheduler)."""
    keep = ("mean_concentration", "voxel_counts", "clamped_density", "grid_dimensions")
    return {k: manifest.get(k) for k in keep}


def test_byte_identical_across_workers_and_slab_sizes(reference_job, tmp_path):
    job, ref_manifest, _ = reference_job
    ref = _digests(job)
    out = tmp_path / "J2"
    manifest, _ = _run(_settings(out, workers=2, slab_layers=7))
    assert _digests(out) == ref
    assert _results(manifest) == _results(ref_manifest)  # float sums too, to the last bit
    out = tmp_path / "J3"
    manifest, _ = _run(_settings(out, workers=2, scheduler="processes", slab_layers=11))
    assert _digests(out) == ref
    assert _results(manifest) == _results(ref_manifest)


@pytest.mark.parametrize("threshold", [None, 0.0])
def test_stale_slab_buffers_never_reach_the_slices(tmp_path, monkeypatch, threshold):
    """Worker buffers that held mid-grey colour and a high density everywhere give the same
    slices: the sampler rewrites every density, and the colour it may leave stale (empty rows,
    positive threshold) is never read. With threshold 0 the job asks for every colour; a
    zero-density voxel is pure Clear whatever its colour (eq. 12, rho = 0) in any case."""
    from dreamprint_gui.io.volumes.base import SlabBuffers

    ref = tmp_path / "ref"
    _run(_settings(ref, workers=2, slab_layers=4, density_threshold=threshold))
    take = SlabBuffers.take

    def grey_take(self, shape):
        rgb, sigma = take(self, shape)
        rgb[...] = 0.5
        sigma[...] = 7.0
        return rgb, sigma

    monkeypatch.setattr(SlabBuffers, "take", grey_take)
    out = tmp_path / "stale"
    _run(_settings(out, workers=2, slab_layers=4, density_threshold=threshold))
    assert _digests(out) == _digests(ref)


def test_same_slices_when_compiled_for_another_cpu(reference_job, tmp_path):
    """The kernels compiled for a baseline x86-64 (SSE2: no AVX, no FMA, no gathers) write the
    same bytes as for this machine's CPU: no fast-math, explicit vectors lowered exactly."""
    job, _, _ = reference_job
    out = tmp_path / "J"
    code = ("import sys; from dreamprint_gui.job.plan import ConvertSettings\n"
            "from dreamprint_gui.job.run import run_conversion\n"
            f"s = ConvertSettings(source='demo', output=sys.argv[1], height_mm=0.6, "
            f"table_size={TABLE}, seed=3, workers=1, slab_layers=3)\n"
            "for _ in run_conversion(s):\n    pass\n")
    env = dict(os.environ, NUMBA_CPU_NAME="x86-64", NUMBA_CPU_FEATURES="",
               NUMBA_CACHE_DIR=str(tmp_path / "numba-cache"))
    res = subprocess.run([sys.executable, "-c", code, str(out)], env=env, capture_output=True,
                         text=True, timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    assert _digests(out) == _digests(job)


def test_local_cluster_gives_the_same_slices(reference_job, tmp_path):
    from distributed import LocalCluster

    job, _, _ = reference_job
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster:
        out = tmp_path / "JD"
        manifest, _ = _run(_settings(out, scheduler=cluster.scheduler_address, slab_layers=5))
    assert _digests(out) == _digests(job)
    assert manifest["execution"]["scheduler"].startswith("tcp://")


def test_halftone_layer_matches_the_exported_slice(reference_job):
    job, manifest, _ = reference_job
    settings = _settings(None)
    ctx = prepare_job(settings)
    palette = np.array([v["rgb"] for v in manifest["labels"].values()], np.uint8)
    for z in (0, 17):
        np.testing.assert_array_equal(halftone_layer(settings, z, ctx),
                                      read_png_labels(job / "slices" / f"{z:05d}.png", palette))


def test_cancel_leaves_nothing(tmp_path):
    out = tmp_path / "JOB"
    cancel = threading.Event()
    gen = run_conversion(_settings(out, workers=2, slab_layers=1), cancel)
    with pytest.raises(JobCancelled):
        for p in gen:
            if p.stage == "converting" and p.layers_done >= 2:
                cancel.set()
    assert os.listdir(tmp_path) == []


def test_closing_the_generator_leaves_nothing(tmp_path):
    out = tmp_path / "JOB"
    gen = run_conversion(_settings(out, workers=2, slab_layers=1))
    for p in gen:
        if p.stage == "converting" and p.layers_done >= 1:
            break
    gen.close()
    assert os.listdir(tmp_path) == []


def test_refusals_happen_before_any_work(tmp_path):
    with pytest.raises(DreamPrintError, match="tray"):
        _run(_settings(tmp_path / "J", height_mm=None, size_mm=(600.0, 600.0, 600.0)))
    (tmp_path / "EXISTS").mkdir()
    with pytest.raises(DreamPrintError, match="--overwrite"):
        _run(_settings(tmp_path / "EXISTS"))
    assert sorted(os.listdir(tmp_path)) == ["EXISTS"]


def test_cli_convert_demo(tmp_path, capsys):
    out = tmp_path / "JOB"
    rc = main(["convert", "demo", "-o", str(out), "--height-mm", "0.3", "--table-size", "17",
               "--background", "empty", "--halftone", "random", "--seed", "5"])
    assert rc == 0
    assert "wrote" in capsys.readouterr().out
    m = json.loads((out / "manifest.json").read_text())
    assert m["background"]["mode"] == "empty" and m["halftoning"]["method"] == "random"
    assert main(["convert", "demo", "-o", str(out), "--height-mm", "0.3"]) == 2
    assert "--overwrite" in capsys.readouterr().err


def test_cli_convert_objective_and_intent_reach_the_job(tmp_path, capsys):
    out = tmp_path / "JOB"
    rc = main(["convert", "demo", "-o", str(out), "--height-mm", "0.3", "--table-size", "9",
               "--objective", "srgb", "--intent", "perceptual"])
    assert rc == 0, capsys.readouterr().err
    m = json.loads((out / "manifest.json").read_text())
    assert m["profile"]["objective"] == "srgb" and m["profile"]["intent"] == "perceptual"
    with pytest.raises(DreamPrintError, match="rendering intent"):
        _run(_settings(tmp_path / "J2", intent="saturation"))
    assert not (tmp_path / "J2").exists()


def test_slices_carry_the_legend_codes_and_the_printer_dpi(reference_job):
    """The default printer is Voxel Print's grid (600 x 300 dpi, 27 um) and its slices carry
    the Voxel Print legend's codes, VeroClear 227, 233, 253 (not the display colour)."""
    from PIL import Image

    from dreamprint_gui.job.encode.png_slices import read_png_phys

    job, manifest, _ = reference_job
    assert manifest["printer"]["name"] == "voxelprint-27um"
    legend = {(0, 90, 158), (166, 33, 98), (200, 189, 3), (26, 26, 29), (240, 240, 240),
              (227, 233, 253), (255, 255, 255)}
    seen = set()
    for f in sorted((job / "slices").iterdir()):
        rgb = np.asarray(Image.open(f).convert("RGB")).reshape(-1, 3)
        seen |= {tuple(int(v) for v in c) for c in np.unique(rgb, axis=0)}
        ppx, ppy, unit = read_png_phys(f)
        # 600 dpi = 600 / 0.0254 px/m; 300 dpi likewise
        assert unit == 1 and abs(ppx - 600 / 0.0254) < 1 and abs(ppy - 300 / 0.0254) < 1
    assert seen <= legend and (227, 233, 253) in seen and (150, 190, 225) not in seen
    assert manifest["labels"]["Cl"]["rgb"] == [227, 233, 253]


def test_evaluate_job_reports_volumes_and_checks_the_printer(reference_job, capsys):
    job, manifest, _ = reference_job
    report = check_job(job)
    assert all(c["ok"] for c in report["checks"]), report["checks"]
    assert {c["check"] for c in report["checks"]} >= {"voxel", "image size", "codes in slices",
                                                     "dpi", "layers", "tray"}
    vox_mm3 = (25.4 / 600) * (25.4 / 300) * 0.027
    for m, r in report["materials"].items():
        assert r["volume_ml"] == pytest.approx(r["voxels"] * vox_mm3 / 1000, rel=1e-9)
        if m != "empty":
            assert 1.17 <= r["mass_g"] / max(r["volume_ml"], 1e-300) <= 1.19 or r["voxels"] == 0
    assert main(["evaluate", "job", str(job)]) == 0
    text = capsys.readouterr().out
    assert "volume ml" in text and "mass g" in text and "columns:" in text
    assert "dpi: pHYs 600.0 x 300.0 dpi" in text


def test_evaluate_job_against_another_printer_and_a_foreign_code(reference_job, tmp_path,
                                                                  capsys):
    import shutil

    from PIL import Image

    job, manifest, _ = reference_job
    report = check_job(job, "j850-paper")  # another grid: voxel, layers and dpi disagree
    bad = {c["check"] for c in report["checks"] if not c["ok"]}
    assert {"voxel", "layers", "dpi"} <= bad and not report["consistent"]
    # the resin is the job's, at its own voxel, whatever printer it is checked against
    # (issue 46: a 27 um job checked against a 14 um printer was counted at 14 um)
    own = check_job(job)
    assert report["voxel_mm"] == own["voxel_mm"] != report["printer_voxel_mm"]
    assert report["total_volume_ml"] == pytest.approx(own["total_volume_ml"], rel=1e-12)
    copy = tmp_path / "J"
    shutil.copytree(job, copy)
    first = copy / "slices" / "00000.png"
    im = np.asarray(Image.open(first).convert("RGB")).copy()
    im[0, 0] = (150, 190, 225)  # the display colour of Clear written into a slice
    Image.fromarray(im).save(first)
    report = check_job(copy)
    bad = {c["check"]: c["text"] for c in report["checks"] if not c["ok"]}
    assert "codes in slices" in bad and "(150, 190, 225)" in bad["codes in slices"]
    assert "dpi" in bad  # Pillow wrote no pHYs into that slice: some slices lack it
    assert main(["evaluate", "job", str(copy)]) == 2
    assert "not consistent" in capsys.readouterr().err
