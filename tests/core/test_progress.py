"""core.progress: the heartbeat of a call that reports nothing while it runs, and the time left
it states (issue 46: every step over 2 s shows progress)."""

import threading
import time

import pytest

from dreamprint_gui.core import progress
from dreamprint_gui.core.progress import eta_text, heartbeat


def test_heartbeat_speaks_while_a_gil_free_call_runs_and_stops_after(monkeypatch):
    """A 0.5 s wait (time.sleep releases the GIL as a Mitsuba render does) with a 0.05 s
    heartbeat: about 10 beats, each giving the time since the block started, increasing; none
    after the block."""
    monkeypatch.setattr(progress, "HEARTBEAT_S", 0.05)
    said: list[float] = []
    t0 = time.monotonic()
    with heartbeat(said.append):
        time.sleep(0.5)
    block = time.monotonic() - t0
    n = len(said)
    assert 4 <= n <= 11
    assert all(b > a for a, b in zip(said, said[1:], strict=False))
    assert said[0] >= 0.05 and said[-1] <= block
    time.sleep(0.15)
    assert len(said) == n                      # the thread ended with the block
    assert not any(t.name == "dreamprint-heartbeat" for t in threading.enumerate())


def test_a_short_block_says_nothing_and_errors_pass_through():
    said: list[float] = []
    with heartbeat(said.append):
        pass
    assert said == []
    with pytest.raises(ValueError), heartbeat(said.append):
        raise ValueError("the block's own error")


def test_a_failing_message_does_not_fail_the_work(monkeypatch):
    monkeypatch.setattr(progress, "HEARTBEAT_S", 0.02)

    def say(_el: float) -> None:
        raise OSError("stderr closed")

    with heartbeat(say):
        time.sleep(0.1)


def test_eta_text():
    assert eta_text(12.2, None) == "12 s"
    assert eta_text(12.2, 20.0) == "12 s, about 8 s left"
    assert eta_text(21.0, 20.0) == "21 s, any moment now"
