"""Progress and time on the command line's stderr: :func:`fmt_time` (``m:ss`` / ``h:mm:ss``),
:func:`progress_bar` (a colour table build's progress, every 10 %) and :func:`step_progress`
(the steps of the slow commands)."""

from __future__ import annotations

import math

import click

__all__ = ["fmt_time", "progress_bar", "step_progress"]


def fmt_time(s: float | None) -> str:
    if s is None or not math.isfinite(s):
        return "--:--"
    s = int(round(s))
    if s >= 3600:
        return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}"
    return f"{s // 60}:{s % 60:02d}"


def progress_bar(what: str = ""):
    """A table build's progress on stderr (also with --json: stdout carries the JSON), every
    10 %. Called only while building: a table loaded from the cache prints nothing."""
    state = {"last": -1}
    label = f"building colour tables{f' ({what})' if what else ''}"

    def report(fraction: float) -> None:
        pct = int(100 * fraction)
        if pct // 10 != state["last"]:
            state["last"] = pct // 10
            click.echo(f"{label}: {pct:3d} %", err=True)

    return report


def step_progress(label: str, quiet: bool = False):
    """``progress(done, total)`` printing ``label: done/total steps, elapsed, about T left``
    on stderr after each step (a step of the slow commands, seconds each: fits, render
    passes); ``progress(0, total)``, called once the inputs are checked, says what started.
    None when ``quiet``."""
    import time

    if quiet:
        return None
    t0 = [time.monotonic()]

    def report(done: int, total: int) -> None:
        if done == 0:
            t0[0] = time.monotonic()
            click.echo(f"{label}: 0/{total}, started", err=True)
            return
        el = time.monotonic() - t0[0]
        left = el / done * (total - done) if done else float("nan")
        tail = f", about {left:.0f} s left" if done < total else ", done"
        click.echo(f"{label}: {done}/{total} ({el:.0f} s{tail})", err=True)

    return report
