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
