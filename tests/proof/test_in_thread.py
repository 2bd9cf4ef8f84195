"""The proof's stages run in a thread (runner.in_thread): while one Mitsuba render of the print
runs (about 20 s each on the default proof) the generator still says how the stage goes every
core.progress.HEARTBEAT_S seconds, and the command line prints it to a log (issue 46)."""

import time

from dreamprint_gui.cli.proof import _drive
from dreamprint_gui.core import progress as core_progress
from dreamprint_gui.proof.runner import ProofProgress, in_thread


def _slow_stage(prog, seconds=0.4):
    def work() -> None:
        time.sleep(seconds)                 # one render: no progress of its own meanwhile
        prog["p"] = (1, 1)
    return work


def test_a_stage_without_news_still_yields_every_heartbeat(monkeypatch):
    monkeypatch.setattr(core_progress, "HEARTBEAT_S", 0.05)
    prog = {"p": (0, 1)}
    t0 = time.monotonic()
    seen = list(in_thread(_slow_stage(prog, 0.9), "print", prog,
                          lambda: time.monotonic() - t0, {}, None))
    waiting = [p for p in seen if (p.done, p.total) == (0, 1)]
    # the thread is polled every 0.2 s: about 0.9 / 0.2 yields while it sleeps, not one
    assert len(waiting) >= 3
    assert all(b.elapsed_s > a.elapsed_s for a, b in zip(waiting, waiting[1:], strict=False))
    assert (seen[-1].done, seen[-1].total) == (1, 1)


def test_without_the_heartbeat_a_stage_says_nothing_until_it_moves(monkeypatch):
    """The reference for the test above: with a heartbeat longer than the stage, one line."""
    monkeypatch.setattr(core_progress, "HEARTBEAT_S", 60.0)
    prog = {"p": (0, 1)}
    t0 = time.monotonic()
    seen = list(in_thread(_slow_stage(prog), "print", prog, lambda: time.monotonic() - t0,
                          {}, None))
    assert [(p.done, p.total) for p in seen] == [(0, 1), (1, 1)]


def test_a_log_gets_the_bar_every_heartbeat(monkeypatch, capsys):
    """No terminal (a log, a pipe): a line whenever HEARTBEAT_S passed (was every 10 s)."""
    monkeypatch.setattr(core_progress, "HEARTBEAT_S", 0.05)

    def gen():
        for k in range(4):
            time.sleep(0.06)
            yield ProofProgress("print", 0, 2, 0.06 * (k + 1))
        yield ProofProgress("print", 2, 2, 0.3)
        return "report"

    assert _drive(gen()) == "report"
    lines = [ln for ln in capsys.readouterr().err.splitlines() if "print render" in ln]
    assert len(lines) == 5 and lines[-1].split()[-3] == "2/2"


# --- the proof's stages that had no thread: preparing, the source render, writing (issue 46's
# walk: 9 s, 12-16 s and 14 s silent). Each is slowed here by a sleep standing in for its work.

class _Stop(Exception):
    """Ends a patched proof where the test has seen what it needs."""


def _waiting(seen, stage):
    return [p for p in seen if p.stage == stage and p.done == 0]


def _run_until_stop(gen):
    seen = []
    try:
        for p in gen:
            seen.append(p)
    except _Stop:
        pass
    return seen


def test_preparing_says_how_it_goes_while_the_source_opens(monkeypatch):
    from dreamprint_gui.proof import runner

    monkeypatch.setattr(core_progress, "HEARTBEAT_S", 0.05)

    def slow_labels(s):
        time.sleep(0.9)                     # opening the source, tables and renderer
        raise _Stop

    monkeypatch.setattr(runner, "_labels", slow_labels)
    seen = _run_until_stop(runner.render_proof(runner.ProofSettings(source="demo",
                                                                    height_mm=20.0)))
    # polled every 0.2 s: several heartbeats, not the one line before the work
    assert len(_waiting(seen, "preparing")) >= 3


def _fake_proof(monkeypatch, slow: str):
    """The proof's pipeline with every computation replaced by a quick stand-in, and the one
    named ``slow`` by a 0.9 s sleep; the gamut floor (the last stage before the report) ends
    the run."""
    from types import SimpleNamespace as NS

    import numpy as np

    from dreamprint_gui.proof import runner

    monkeypatch.setattr(core_progress, "HEARTBEAT_S", 0.05)
    lab = NS(profile=NS(proof_optics=None), shape_xyz=(2, 2, 2), voxel_mm=(1.0, 1.0, 1.0),
             layer=None, source=None, grid=None, density_scale=1.0)
    medium = NS(box_mm=(0.0, 2.0), print_size_mm=(2.0, 2.0, 2.0), fractions=None,
                block_xyz=None, cells_xyz=None, cell_mm=1.0)
    bands = NS(K=None, S=None, xyz_weights=np.ones((2, 3)),
               observer=NS(xyz_to_linear_srgb=np.eye(3), XYZ_to_linear_sRGB=lambda x: x))

    def stand_in(value=None):
        def f(*a, **k):
            if f.__name__ == slow:
                time.sleep(0.9)
            return value
        return f

    def stop(*a, **k):
        if slow == "gamut_floor":
            time.sleep(0.9)
        raise _Stop

    fakes = {"_labels": lab, "spectral_bands": bands, "block_for_cell": 1,
             "block_fractions": medium, "resolve_optics": NS(surface="none"),
             "job_intent": "colorimetric", "medium_coefficients": (None, None),
             "sample_source": None, "intent_reference": None,
             "cached_render_source": (np.zeros((2, 2, 3)), np.zeros((2, 2)), 0),
             "optical_depth": np.ones((2, 2, 2)), "edge_refine": 0, "thick_tiles": [],
             "render_print_halves": ([np.zeros((2, 2, 2))], [[np.zeros((2, 2, 2))]] * 2,
                                     {"halves": {"seeds": [0, 1]}}),
             "samples_per_degree": 1.0, "print_xyz": np.zeros((2, 2, 3)),
             "compare_view": ({}, None), "noise_floor_from_halves": {}, "summarise": {},
             "noise_corrected_figures": {},
             "clear_report": {}}
    for name, value in fakes.items():
        f = stand_in(value)
        f.__name__ = name
        monkeypatch.setattr(runner, name, f)
    monkeypatch.setattr(runner, "orbit_views",
                        lambda size, n: [NS(half_mm=1.0, describe=lambda: {})])
    monkeypatch.setattr(runner, "gamut_floor", stop)
    gen = runner.render_proof(runner.ProofSettings(source="demo", height_mm=20.0, views=1))
    return _run_until_stop(gen)


def test_the_source_stage_says_how_it_goes_from_the_labels_on(monkeypatch):
    """The print's coefficients (12-16 s after the labels on a cold cache) and the source's
    sampling run in the source stage's thread."""
    for slow in ("medium_coefficients", "sample_source"):
        seen = _fake_proof(monkeypatch, slow)
        assert len(_waiting(seen, "source")) >= 3, slow


def test_the_print_stage_says_how_it_goes_before_its_first_pass(monkeypatch):
    seen = _fake_proof(monkeypatch, "optical_depth")
    assert len(_waiting(seen, "print")) >= 3


def test_the_gamut_floor_says_how_it_goes(monkeypatch):
    """After the comparison, the tables' prediction rendered (49.8 s silent, cold, load 7)."""
    seen = _fake_proof(monkeypatch, "gamut_floor")
    assert [p.stage for p in seen][-1] == "gamut floor"
    assert len(_waiting(seen, "gamut floor")) >= 3
    quick = _fake_proof(monkeypatch, "none")
    assert len(_waiting(quick, "gamut floor")) <= 2


def test_writing_says_how_it_goes(monkeypatch, tmp_path):
    from dreamprint_gui.proof import runner

    monkeypatch.setattr(core_progress, "HEARTBEAT_S", 0.05)

    def quick_render(s, cancel=None):
        yield runner.ProofProgress("compare", 1, 1, 0.1)
        return {"report": {"timings_s": {"total": 0.1}}, "images": []}

    def slow_write(result, folder):
        time.sleep(0.9)                     # the images and the contact sheet
        (folder / "proof.json").write_text("{}\n", encoding="utf-8")

    monkeypatch.setattr(runner, "render_proof", quick_render)
    monkeypatch.setattr(runner, "write_proof", slow_write)
    out = tmp_path / "proof"
    seen = list(runner.run_proof(runner.ProofSettings(source="demo", height_mm=20.0,
                                                      output=str(out))))
    writing = _waiting(seen, "writing")
    assert len(writing) >= 3
    assert all(b.elapsed_s > a.elapsed_s for a, b in zip(writing[1:], writing[2:],
                                                          strict=False))
    assert seen[-1].stage == "done" and (out / "proof.json").is_file()


def _preparing(seconds):
    def gen():
        yield ProofProgress("preparing", 0, 1, 0.0, "opening the source, tables and renderer")
        t0 = time.monotonic()
        while time.monotonic() - t0 < seconds:
            time.sleep(0.02)
            yield ProofProgress("preparing", 0, 1, time.monotonic() - t0)
        yield ProofProgress("done", 1, 1, seconds, "out")
        return "report"
    return gen()


def test_a_quick_preparation_prints_nothing_a_long_one_its_heartbeat(monkeypatch, capsys):
    """A bad input refused while preparing stays one line (nothing before it within
    HEARTBEAT_S); a preparation longer than that says so every HEARTBEAT_S."""
    monkeypatch.setattr(core_progress, "HEARTBEAT_S", 0.2)
    assert _drive(_preparing(0.1)) == "report"
    assert capsys.readouterr().err == ""
    assert _drive(_preparing(0.9)) == "report"
    lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("preparing")]
    assert 2 <= len(lines) <= 5
