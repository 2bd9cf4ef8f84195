"""Compensation inside other work (proof/compensated.py): the phases' clock, the compensated
export (as ``convert --compensate``) and the open-loop vs compensated proofs."""

import json
import time

import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.job.plan import ConvertSettings
from dreamprint_gui.proof.compensated import (
    PhaseClock,
    compare_compensation,
    compensate_settings_for,
    correction_path_for,
    run_compensated_conversion,
)
from dreamprint_gui.proof.runner import ProofSettings

TINY = {"views": 1, "iterations": 1, "resolution": 24, "spp": 2, "max_cells": 12,
        "field_cells": 6}


def drive(gen):
    items = []
    try:
        while True:
            items.append(next(gen))
    except StopIteration as stop:
        return items, stop.value


def test_phase_clock_fractions_and_time_left(monkeypatch):
    clock = PhaseClock({"a": 3.0, "b": 1.0})
    assert clock.fraction("a", 0.0) == 0.0
    assert clock.fraction("a", 0.5) == pytest.approx(0.375)
    assert clock.fraction("b", 0.0) == pytest.approx(0.75)
    assert clock.fraction("b", 2.0) == pytest.approx(1.0)   # clipped
    monkeypatch.setattr(time, "perf_counter", lambda: clock.t0 + 30.0)
    p = clock.progress("a", 0.5)
    # 30 s for 0.375 of the work: 50 s for the other 0.625
    assert p.elapsed_s == pytest.approx(30.0) and p.eta_s == pytest.approx(50.0)
    assert clock.progress("a", 0.0).eta_s is None


def test_compensate_settings_follow_the_job():
    s = ConvertSettings(source="demo", output="/tmp/x/job", height_mm=7.0, seed=5,
                        background="empty", density_scale=2.0, halftone="random",
                        table_size=17, rotate=90, fit="box", source_options={"k": 1})
    cs = compensate_settings_for(s, "/tmp/x/job.correction.npz", iterations=2)
    assert (cs.source, cs.height_mm, cs.seed, cs.background, cs.density_scale, cs.halftone,
            cs.table_size, cs.rotate, cs.fit, cs.iterations) == (
        "demo", 7.0, 5, "empty", 2.0, "random", 17, 90, "box", 2)
    assert cs.source_options == (("k", 1),)
    assert correction_path_for("/tmp/x/job/") == correction_path_for("/tmp/x/job")
    assert str(correction_path_for("/tmp/x/job")) == "/tmp/x/job.correction.npz"


def test_compensation_trains_under_the_jobs_intent_objective_and_content():
    """The correction of a job is trained on the job's own rendering choices: the labels the
    optimiser proofs are made with the job's intent, objective, content and sampling."""
    from dreamprint_gui.proof.methods import method_labels

    s = ConvertSettings(source="demo", output="/tmp/x/job", height_mm=2.0, table_size=17,
                        intent="relative", objective="srgb", content="solid",
                        sampling="linear")
    ps = compensate_settings_for(s, "/tmp/x/job.correction.npz").proof_settings()
    labels = method_labels(ps)
    cs = labels.ctx.settings
    assert (cs.intent, cs.objective, cs.content, cs.sampling) == (
        "relative", "srgb", "solid", "linear")
    assert (labels.ctx.tables.intent, labels.ctx.tables.objective) == ("relative", "srgb")
    assert labels.ctx.content.mode == "solid"


def test_compensation_trains_under_the_jobs_density_threshold(monkeypatch):
    """``convert --compensate --density-threshold T``: the optimiser's labels are made with
    the job's threshold T (what becomes background), not the default half of pure Clear's."""
    import dreamprint_gui.proof.compensate as compensate

    seen = []

    class Stop(Exception):
        pass

    def labels(settings):
        seen.append(settings)
        raise Stop

    monkeypatch.setattr(compensate, "EngineLabels", labels)
    for thr in (7.5, None):
        s = ConvertSettings(source="demo", output="/tmp/x/job", height_mm=2.0, table_size=17,
                            density_threshold=thr, intent="relative", rotate=90)
        with pytest.raises(Stop):
            compensate._Loop(compensate_settings_for(s, "/tmp/x/c.npz"), [], lambda: False)
        job = seen[-1]
        assert job.density_threshold == thr
        assert job.spec == s.spec   # and the rest of the print as the job states it


def test_compensated_export_refuses_an_existing_job_before_optimising(tmp_path):
    (tmp_path / "job").mkdir()
    s = ConvertSettings(source="demo", output=str(tmp_path / "job"), height_mm=2.0,
                        table_size=17)
    gen = run_compensated_conversion(s, **TINY)
    t0 = time.process_time()
    with pytest.raises(DreamPrintError, match="already exists"):
        next(gen)
    assert time.process_time() - t0 < 5.0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["job"]


@pytest.mark.parametrize("fail_in", ["optimising", "converting"])
def test_a_failed_overwrite_leaves_the_old_job_with_its_own_correction(tmp_path, monkeypatch,
                                                                       fail_in):
    """``--compensate --overwrite`` over a finished job: cancelled (or failing) before the new
    job is in place, the old job and the correction it was made with are as they were; done,
    the new correction replaces it and nothing else is left beside the job."""
    import dreamprint_gui.proof.compensated as compensated
    from dreamprint_gui.job.plan import JobCancelled

    out = tmp_path / "job"
    out.mkdir()
    (out / "manifest.json").write_text("{}")
    corr = correction_path_for(out)
    corr.write_bytes(b"the old job's correction")
    s = ConvertSettings(source="demo", output=str(out), height_mm=1.0, table_size=17,
                        overwrite=True)

    def cancelled(*a, **k):
        raise JobCancelled("the export was cancelled")
        yield  # a generator, as run_conversion / run_compensate

    monkeypatch.setattr(compensated, "run_conversion" if fail_in == "converting"
                        else "run_compensate", cancelled)
    with pytest.raises(JobCancelled):
        drive(run_compensated_conversion(s, preflight=False, **TINY))
    assert corr.read_bytes() == b"the old job's correction"
    assert (out / "manifest.json").read_text() == "{}"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["job", "job.correction.npz"]
    if fail_in == "optimising":
        return
    monkeypatch.undo()
    drive(run_compensated_conversion(s, preflight=False, **TINY))
    assert corr.read_bytes() != b"the old job's correction"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["job", "job.correction.npz"]


def test_convert_compensate_writes_job_and_correction(tmp_path, capsys, monkeypatch):
    """The command line's route, end to end, with a tiny optimiser (its defaults take about
    two minutes here; the settings it trains under are test_print_spec's)."""
    import functools

    import dreamprint_gui.proof.compensated as compensated

    monkeypatch.setattr(compensated, "run_compensated_conversion",
                        functools.partial(compensated.run_compensated_conversion, **TINY))
    out = tmp_path / "job"
    code = main(["convert", "demo", "-o", str(out), "--height-mm", "2", "--table-size", "17",
                 "--compensate", "--json"])
    cap = capsys.readouterr()
    assert code == 0, cap.err
    manifest = json.loads(cap.out)
    corr = tmp_path / "job.correction.npz"
    assert corr.is_file() and manifest["compensation"]["path"] == str(corr.absolute())
    from dreamprint_gui.job.correction import load_correction

    assert load_correction(corr).density_threshold == pytest.approx(
        manifest["background"]["density_threshold_per_mm"], rel=1e-12)
    figures = manifest["compensation"]["proof_figures"]
    assert "[compensate] iteration 1/1" in cap.err and f"[compensate] wrote {corr}" in cap.err
    assert (f"compensation: {corr.absolute()}; training dE2000 mean "
            f"{figures['before']['mean_de2000']:.2f} -> {figures['after']['mean_de2000']:.2f}"
            in cap.err)


def test_an_interrupted_compensated_job_keeps_its_correction_and_resumes_with_it(
        tmp_path, monkeypatch):
    """Ctrl-C while converting keeps the finished layers for --resume and the correction they
    were made with; the resumed run converts with that file instead of optimising another.
    A cancel (the export dialog's) removes both (tests/gui/test_gamut_and_export.py)."""
    from dataclasses import replace

    import dreamprint_gui.proof.compensated as compensated
    from dreamprint_gui.job.resume import find_interrupted

    real = compensated.run_conversion

    def interrupted(settings, cancel=None, preflight=True):  # Ctrl-C inside the conversion
        gen = real(settings, cancel, preflight=preflight)
        for p in gen:
            yield p
            if p.stage == "converting" and p.layers_done >= 4:
                gen.throw(KeyboardInterrupt())

    out = tmp_path / "job"
    s = ConvertSettings(source="demo", output=str(out), height_mm=1.0, table_size=17, seed=3,
                        workers=1, slab_layers=2, scheduler="sync")
    monkeypatch.setattr(compensated, "run_conversion", interrupted)
    with pytest.raises(KeyboardInterrupt):
        drive(run_compensated_conversion(s, preflight=False, **TINY))
    corr = correction_path_for(out)
    assert corr.is_file() and find_interrupted(out) is not None and not out.exists()
    made = corr.read_bytes()

    monkeypatch.setattr(compensated, "run_conversion", real)
    items, manifest = drive(run_compensated_conversion(replace(s, resume=True),
                                                       preflight=False, **TINY))
    assert {p.stage for p in items} == {"converting"}   # no second optimisation
    assert corr.read_bytes() == made
    assert manifest["compensation"]["path"] == str(corr.absolute())
    assert manifest["execution"]["resumed_layers"] >= 4


def test_compare_compensation_trains_apart_and_leaves_no_file(tmp_path, monkeypatch):
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    ps = ProofSettings(source="demo", height_mm=3.0, views=1, resolution=24, spp=2,
                       max_cells=12, table_size=17, seed=3, noise_floor=False)
    items, res = drive(compare_compensation(ps, iterations=1, training_views=1,
                                            train_resolution=24, field_cells=6))
    assert list(tmp_path.iterdir()) == []
    assert res["optimiser"]["settings"]["seed"] == 4
    assert res["open_loop"]["report"]["compensation"] is None
    comp = res["compensated"]["report"]["compensation"]
    assert comp is not None and comp["optimiser_figures"] == res["optimiser"]["figures"]
    # the proofs' cameras are the proof's (elevation 20), not the training ones (35)
    assert res["compensated"]["report"]["views"][0]["elevation_deg"] == 20.0
    assert res["optimiser"]["training_views"][0]["elevation_deg"] == 35.0
    fr = [p.fraction for p in items]
    assert fr == sorted(fr) and fr[-1] <= 1.0


def test_optimiser_progress_only_grows_for_any_iteration_count():
    """The fraction of the optimiser's phase from its item stream (preparing, then per
    iteration labels, print 0..4 of 4, iteration k of n + 1) never goes back."""
    from dreamprint_gui.proof.compensated import _optimise_within
    from dreamprint_gui.proof.runner import ProofProgress

    for n in (1, 4, 10):
        state = {"total": n + 1}
        items = [ProofProgress("preparing", 0, 1, 0.0)]
        for k in range(n + 1):
            items.append(ProofProgress(f"labels (iteration {k}/{n})", 1, 2, 0.0))
            items += [ProofProgress(f"print (iteration {k}/{n})", d, 4, 0.0) for d in range(5)]
            items.append(ProofProgress("iteration", k + 1, n + 1, 0.0, "iteration"))
        fr = [_optimise_within(p, state) for p in items]
        assert fr == sorted(fr) and fr[0] == 0.0 and fr[-1] == 1.0, n
