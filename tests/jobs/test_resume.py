"""Resumable jobs: a run killed (kill -9) or interrupted (Ctrl-C) keeps its finished slabs, and
``--resume`` finishes only what is missing, with the slices of an uninterrupted run."""

import hashlib
import json
import os
import signal
import subprocess
import sys
import time
from dataclasses import replace

import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.job.plan import ConvertSettings
from dreamprint_gui.job.resume import find_interrupted, missing_slabs, read_slab_records
from dreamprint_gui.job.run import run_conversion
from dreamprint_gui.job.write import IDENTITY, SLABS, JobWriter

TABLE = 17
HEIGHT = "6"  # 223 layers of 145 x 73 voxels: a few seconds with one layer per slab
ARGS = ["--height-mm", HEIGHT, "--table-size", str(TABLE), "--seed", "3", "--slab-layers", "1",
        "--workers", "1", "-q"]


def _digests(job):
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted((job / "slices").iterdir())}


def _results(job):
    m = json.loads((job / "manifest.json").read_text())
    return {k: m[k] for k in ("voxel_counts", "mean_concentration", "clamped_density",
                              "grid_dimensions")}, m


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    out = tmp_path_factory.mktemp("ref") / "JOB"
    assert main(["convert", "demo", "-o", str(out), *ARGS[:-3], "--slab-layers", "7",
                 "--workers", "2", "-q"]) == 0
    return out


def _resume_then_compare(settings, out, ref):
    """Resume ``settings``' job, convert it again uninterrupted into ``ref``: same slices."""
    for _ in run_conversion(replace(settings, resume=True), preflight=False):
        pass
    for _ in run_conversion(replace(settings, output=ref), preflight=False):
        pass
    assert _digests(out) == _digests(ref)


def _partials(folder):
    return [p for p in folder.iterdir() if p.name.startswith(".JOB.partial-")]


def _start(out, *extra):
    env = dict(os.environ, PYTHONPATH=os.getcwd())
    # Ctrl-C as a terminal sends it: a suite run as a background job of a non-interactive shell
    # ignores SIGINT, and its children inherit that (the job then finished, exit 0)
    return subprocess.Popen([sys.executable, "-m", "dreamprint_gui.cli", "convert", "demo", "-o",
                             str(out), *ARGS, *extra], stderr=subprocess.PIPE, env=env,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def _wait_for_slabs(proc, folder, n, timeout=120):
    """Wait until the running job has recorded ``n`` finished slabs."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        parts = _partials(folder)
        if parts and len(list((parts[0] / SLABS).glob("*.json"))) >= n:
            return parts[0]
        assert proc.poll() is None, proc.stderr.read().decode()
        time.sleep(0.02)
    raise AssertionError("the job recorded no slabs in time")


def test_kill_9_then_resume_gives_the_uninterrupted_slices(uninterrupted, tmp_path, capsys):
    out = tmp_path / "JOB"
    proc = _start(out)
    _wait_for_slabs(proc, tmp_path, 40)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert not out.exists()
    left = find_interrupted(out)
    assert left is not None and 40 <= left[1] < left[2] == 223
    # without --resume the kept layers are not thrown away: one line, nothing touched
    assert main(["convert", "demo", "-o", str(out), *ARGS]) == 2
    err = capsys.readouterr().err
    assert "--resume" in err and f"{left[1]} of 223 layers" in err and len(err.splitlines()) == 1
    assert _partials(tmp_path) == [left[0]]
    assert main(["convert", "demo", "-o", str(out), *ARGS[:-1], "--resume"]) == 0
    captured = capsys.readouterr()
    assert f"resuming: {left[1]} of 223 layers" in captured.err
    assert f"{left[1]} layers kept from the interrupted run" in captured.out
    assert sorted(os.listdir(tmp_path)) == ["JOB"]  # the hidden folder became the job
    assert sorted(os.listdir(out)) == ["manifest.json", "slices"]
    assert _digests(out) == _digests(uninterrupted)
    got, manifest = _results(out)
    assert got == _results(uninterrupted)[0]  # the kept slabs' sums too, to the last bit
    assert manifest["execution"]["resumed_layers"] == left[1]


def test_ctrl_c_keeps_the_finished_layers_and_resume_finishes(uninterrupted, tmp_path):
    out = tmp_path / "JOB"
    proc = _start(out)
    _wait_for_slabs(proc, tmp_path, 20)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert b"--resume" in err and not out.exists()
    [kept] = _partials(tmp_path)
    assert not (kept / ".cancelled").exists()
    done = read_slab_records(kept, 223)
    assert done and all(r["z1"] > r["z0"] for r in done)
    assert main(["convert", "demo", "-o", str(out), *ARGS, "--resume"]) == 0
    assert _digests(out) == _digests(uninterrupted)


def _interrupted_job(tmp_path, n_slabs=5, **kw):
    """A job folder as a run interrupted after ``n_slabs`` slabs leaves it."""
    out = tmp_path / "JOB"
    settings = ConvertSettings(source="demo", output=out, height_mm=1.0, table_size=TABLE,
                               seed=3, workers=1, slab_layers=2, scheduler="sync", **kw)
    gen = run_conversion(settings, preflight=False)
    with pytest.raises(KeyboardInterrupt):
        for p in gen:
            if p.stage == "converting" and p.layers_done >= 2 * n_slabs:
                gen.throw(KeyboardInterrupt())
    [kept] = _partials(tmp_path)
    # as if its process were gone (a kill or a power cut): a pid above Linux's pid_max
    gone = kept.with_name(".JOB.partial-4194400-0")
    kept.rename(gone)
    return out, settings, gone


@pytest.mark.parametrize("change, says", [
    ({"seed": 4}, "another seed"), ({"height_mm": 1.2}, "another size"),
    ({"background": "empty"}, "another background"), ({"intent": "perceptual"}, "colour tables"),
])
def test_a_folder_of_another_job_is_refused(tmp_path, change, says):
    out, settings, kept = _interrupted_job(tmp_path)
    before = sorted(p.name for p in kept.rglob("*"))
    with pytest.raises(DreamPrintError, match=says) as e:
        for _ in run_conversion(replace(settings, resume=True, **change), preflight=False):
            pass
    assert str(kept) in str(e.value) and "\n" not in str(e.value)
    assert sorted(p.name for p in kept.rglob("*")) == before  # left as it was


def test_a_folder_of_another_version_or_source_file_is_refused(tmp_path):
    out, settings, kept = _interrupted_job(tmp_path)
    ident = json.loads((kept / IDENTITY).read_text())
    ident["software"]["version"] = "0.1"
    (kept / IDENTITY).write_text(json.dumps(ident))
    with pytest.raises(DreamPrintError, match=r"another DreamPrint version \(0.1, this is"):
        for _ in run_conversion(replace(settings, resume=True), preflight=False):
            pass
    ident["software"]["version"] = json.loads(json.dumps(
        __import__("dreamprint_gui").__version__))
    ident["source_file"] = [123, 456]
    (kept / IDENTITY).write_text(json.dumps(ident))
    with pytest.raises(DreamPrintError, match="has changed since"):
        for _ in run_conversion(replace(settings, resume=True), preflight=False):
            pass


def test_a_short_slice_makes_its_slab_run_again(tmp_path):
    """A power cut may leave a recorded slice empty: its slab is not counted as done."""
    out, settings, kept = _interrupted_job(tmp_path, n_slabs=4)
    recs = read_slab_records(kept, 38)
    assert len(recs) >= 4
    (kept / "slices" / "00002.png").write_bytes(b"")  # layer 2: the slab (2, 4)
    again = read_slab_records(kept, 38)
    assert [r["z0"] for r in again] == [r["z0"] for r in recs if r["z0"] != 2]
    ref = tmp_path / "REF"
    for _ in run_conversion(replace(settings, output=ref), preflight=False):
        pass
    for _ in run_conversion(replace(settings, resume=True, workers=2, slab_layers=5,
                                    scheduler="threads"), preflight=False):
        pass
    assert _digests(out) == _digests(ref)


def test_resume_with_nothing_to_resume_converts_from_the_start(tmp_path):
    out = tmp_path / "JOB"
    settings = ConvertSettings(source="demo", output=out, height_mm=0.3, table_size=TABLE,
                               resume=True)
    msgs = [p.message for p in run_conversion(settings, preflight=False)]
    assert any("no interrupted run" in m for m in msgs)
    assert sorted(os.listdir(out)) == ["manifest.json", "slices"]


def test_cancel_still_removes_everything(tmp_path):
    import threading

    cancel = threading.Event()
    settings = ConvertSettings(source="demo", output=tmp_path / "JOB", height_mm=1.0,
                               table_size=TABLE, slab_layers=1, workers=1)
    from dreamprint_gui.job.plan import JobCancelled

    with pytest.raises(JobCancelled):
        for p in run_conversion(settings, cancel, preflight=False):
            if p.stage == "converting" and p.layers_done >= 3:
                cancel.set()
    assert os.listdir(tmp_path) == []


def test_missing_slabs_are_the_uncovered_layers():
    recs = [{"z0": 2, "z1": 5}, {"z0": 8, "z1": 9}]
    assert missing_slabs([(0, 4), (4, 8), (8, 12)], recs) == [(0, 2), (5, 8), (9, 12)]
    assert missing_slabs([(0, 12)], []) == [(0, 12)]
    assert missing_slabs([(2, 5)], recs) == []


def test_plain_writer_interrupt_still_removes_its_folder(tmp_path):
    """Only a job stamped resumable is kept on Ctrl-C."""
    with pytest.raises(KeyboardInterrupt), JobWriter(tmp_path / "JOB") as w:
        (w.slices_dir / "00000.png").write_bytes(b"x")
        raise KeyboardInterrupt
    assert os.listdir(tmp_path) == []


def test_an_error_while_resuming_keeps_the_finished_layers(tmp_path, monkeypatch):
    """A resumed run that fails (here every slab task raises) loses none of the layers it took
    over: the folder stays, under the failed process's name, and a later --resume finishes."""
    import dreamprint_gui.job.run as run

    out, settings, kept = _interrupted_job(tmp_path, n_slabs=4)
    before = len(read_slab_records(kept, 38))

    def broken(*args, **kw):
        raise RuntimeError("worker exploded")

    with monkeypatch.context() as m:
        m.setattr(run, "run_slab", broken)
        with pytest.raises(RuntimeError, match="exploded"):
            for _ in run_conversion(replace(settings, resume=True), preflight=False):
                pass
    [left] = _partials(tmp_path)
    assert len(read_slab_records(left, 38)) == before and not out.exists()
    left.rename(left.with_name(".JOB.partial-4194401-0"))  # its process gone
    _resume_then_compare(settings, out, tmp_path / "REF")


def test_resume_and_overwrite_together_are_refused(tmp_path, capsys):
    assert main(["convert", "demo", "-o", str(tmp_path / "JOB"), "--height-mm", "0.3",
                 "--resume", "--overwrite"]) == 2
    assert "not both" in capsys.readouterr().err
    assert os.listdir(tmp_path) == []


def test_time_left_follows_the_recent_rate():
    """A cluster halving its speed (a worker lost): after a window the time left is that of
    the new rate, not of the whole run's mean; a resumed job's kept layers took no time."""
    from dreamprint_gui.job.run import RATE_WINDOW_S, TimeLeft

    eta = TimeLeft(1000, 0, 0.0)
    for t in range(1, 41):  # 10 layers/s for 40 s
        left = eta.update(10 * t, float(t))
    assert left == pytest.approx(600 / 10)
    for t in range(41, 81):  # then 5 layers/s
        left = eta.update(400 + 5 * (t - 40), float(t))
    assert RATE_WINDOW_S <= 40 and left == pytest.approx(400 / 5)  # the mean would say 53 s
    resumed = TimeLeft(100, 50, 0.0)
    assert resumed.update(60, 10.0) == pytest.approx(40 / 1.0)
    assert TimeLeft(10, 0, 0.0).update(0, 5.0) == float("inf")  # no progress: unknown


@pytest.mark.parametrize("damage", [
    lambda r: r.pop("counts"),                              # a traceback before
    lambda r: r.update(conc_sums=r["conc_sums"][:1]),       # wrong totals silently before
    lambda r: r.update(counts=[c * 2 for c in r["counts"]]),
    lambda r: r.update(clamped="none"),                     # a traceback before
    lambda r: r.update(conc_sums=[[float("nan")] * 7] * len(r["conc_sums"])),
])
def test_a_damaged_slab_record_makes_its_slab_run_again(tmp_path, damage):
    """A record whose totals are not a slab's (edited, damaged) is not taken as done: the
    resumed job runs that slab again and its manifest's totals are those of an uninterrupted
    run, instead of a traceback or silently wrong totals."""
    out, settings, kept = _interrupted_job(tmp_path, n_slabs=4)
    recs = read_slab_records(kept, 38, _layer_voxels(kept))
    assert len(recs) >= 4  # sound records pass the check
    victim = kept / SLABS / f"{recs[1]['z0']:06d}-{recs[1]['z1']:06d}.json"
    rec = json.loads(victim.read_text())
    damage(rec)
    victim.write_text(json.dumps(rec))
    assert [r["z0"] for r in read_slab_records(kept, 38, _layer_voxels(kept))] == [
        r["z0"] for r in recs if r["z0"] != recs[1]["z0"]]
    for _ in run_conversion(replace(settings, resume=True), preflight=False):
        pass
    ref = tmp_path / "REF"
    for _ in run_conversion(replace(settings, output=ref), preflight=False):
        pass
    got, m = _results(out)
    want, _ = _results(ref)
    assert got == want and _digests(out) == _digests(ref)
    assert m["execution"]["resumed_layers"] == sum(
        r["z1"] - r["z0"] for r in recs) - (recs[1]["z1"] - recs[1]["z0"])
    nx, ny, nz = m["grid_dimensions"]
    t = m["timings_s"]  # the rate of the layers this run converted, not of the kept ones
    assert t["voxels_per_second"] * t["total"] == pytest.approx(
        nx * ny * (nz - m["execution"]["resumed_layers"]))


def _layer_voxels(folder):
    nx, ny, _ = json.loads((folder / IDENTITY).read_text())["grid_dimensions"]
    return nx * ny


def test_a_run_interrupted_in_this_process_is_found_and_resumed(tmp_path):
    """The GUI's case: an export stopped by a lost cluster or a full disk leaves its folder
    under the still running application's pid; Export again must find it (the CLI's message
    says so) instead of converting from the first layer beside it or removing it."""
    out = tmp_path / "JOB"
    settings = ConvertSettings(source="demo", output=out, height_mm=1.0, table_size=TABLE,
                               seed=3, workers=1, slab_layers=2, scheduler="sync")
    gen = run_conversion(settings, preflight=False)
    with pytest.raises(KeyboardInterrupt):
        for p in gen:
            if p.stage == "converting" and p.layers_done >= 8:
                gen.throw(KeyboardInterrupt())
    [kept] = _partials(tmp_path)
    assert f"-{os.getpid()}-" in kept.name  # this process's name, not renamed
    left = find_interrupted(out)
    assert left is not None and left[0] == kept and left[1] >= 8
    with pytest.raises(DreamPrintError, match="add --resume"):
        for _ in run_conversion(settings, preflight=False):
            pass
    _resume_then_compare(settings, out, tmp_path / "REF")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["JOB", "REF"]


def test_a_folder_being_written_is_not_stale(tmp_path):
    """Another export of this process (the GUI may run two) never takes a folder still written."""
    from dreamprint_gui.job.write import stale_partials

    with JobWriter(tmp_path / "JOB") as w:
        assert w.tmp.is_dir() and stale_partials(tmp_path / "JOB") == []
