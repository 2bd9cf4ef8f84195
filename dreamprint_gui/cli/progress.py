"""Progress on the command line's stderr (durations in words by :mod:`..core.durations`):
:func:`progress_bar` (a colour table build's progress, every 10 % or 2 s) and
:func:`step_progress` (the steps of the slow commands) and :func:`notice` (a first-use build's
announcement and heartbeat, e.g. ``gamut.get_tables(notify=notice)``)."""

from __future__ import annotations

import click

from dreamprint_gui.core import progress as _core
from dreamprint_gui.core.durations import seconds_text
from dreamprint_gui.core.progress import percent_reporter

__all__ = ["progress_bar", "step_progress", "notice"]


def progress_bar(what: str = ""):
    """A table build's progress on stderr (also with --json: stdout carries the JSON), every
    10 % and every :data:`~dreamprint_gui.core.progress.HEARTBEAT_S` s in between
    (:func:`~dreamprint_gui.core.progress.percent_reporter`). Called only while building: a
    table loaded from the cache prints nothing."""
    label = f"building colour tables{f' ({what})' if what else ''}"
    return percent_reporter(lambda pct: click.echo(f"{label}: {pct:3d} %", err=True))


def step_progress(label: str, quiet: bool = False):
    """``progress(done, total)`` printing ``label: done/total steps, elapsed, about T left``
    on stderr after each step (a step of the slow commands, seconds each: fits, render
    passes); ``progress(0, total)``, called once the inputs are checked, says what started.
    ``progress(done, total, detail)`` says how the step under way goes (``detail``, e.g. a
    fit's iteration, the slices read), at most every ``core.progress.HEARTBEAT_S`` seconds:
    ``label: done/total, detail (elapsed)`` (no ``done/total`` for a single step). None when
    ``quiet``."""
    import time

    if quiet:
        return None
    t0 = [time.monotonic()]
    last = [t0[0]]

    def report(done: int, total: int, detail: str | None = None) -> None:
        now = time.monotonic()
        if detail is not None:
            if now - last[0] >= _core.HEARTBEAT_S:
                last[0] = now
                steps = f"{done}/{total}, " if total > 1 else ""
                click.echo(f"{label}: {steps}{detail} ({seconds_text(now - t0[0])})", err=True)
            return
        last[0] = now
        if done == 0:
            t0[0] = now
            click.echo(f"{label}: 0/{total}, started", err=True)
            return
        el = now - t0[0]
        left = el / done * (total - done) if done else float("nan")
        tail = f", about {seconds_text(left)} left" if done < total else ", done"
        click.echo(f"{label}: {done}/{total} ({seconds_text(el)}{tail})", err=True)

    return report


def notice(message: str) -> None:
    """One line on stderr (stdout stays a command's result, e.g. its JSON)."""
    click.echo(message, err=True)
