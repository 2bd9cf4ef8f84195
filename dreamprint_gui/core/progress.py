"""When a long step says how it goes: :data:`HEARTBEAT_S` and :func:`percent_reporter`, the
one rule for a build's percentage (the command line's bar, the job's notices, the GUI's),
:func:`every_heartbeat` for the messages inside a step, and :func:`heartbeat` for a call that
reports nothing while it runs (a Mitsuba render, numba compiling): a thread says how long it
has run every :data:`HEARTBEAT_S` seconds, with :func:`eta_text` for what is left."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from dreamprint_gui.core.durations import about_text, seconds_text

__all__ = ["HEARTBEAT_S", "percent_reporter", "every_heartbeat", "heartbeat", "eta_text"]

# a step under way says how it goes at most this often, and at least this often when its work
# allows (issue 46: every step over 2 s shows progress)
HEARTBEAT_S = 2.0


def percent_reporter(say: Callable[[int], None]) -> Callable[[float], None]:
    """``report(fraction)`` calling ``say(percent)`` at every 10 % and in between when
    :data:`HEARTBEAT_S` seconds passed since the last call (a 10 % step can take 10 s)."""
    state = {"decile": -1, "pct": -1, "t": time.monotonic()}

    def report(fraction: float) -> None:
        pct = int(100 * fraction)
        now = time.monotonic()
        if pct // 10 != state["decile"] or (pct != state["pct"]
                                            and now - state["t"] >= HEARTBEAT_S):
            state.update(decile=pct // 10, pct=pct, t=now)
            say(pct)

    return report


def every_heartbeat(say: Callable[[str], None]) -> Callable[[str], None]:
    """``say`` for the messages inside a step (e.g. each iteration): passed on only when
    :data:`HEARTBEAT_S` seconds passed since the last one passed (or since this was made,
    when the step was announced), so a quick step adds no line."""
    last = [time.monotonic()]

    def detail(message: str) -> None:
        now = time.monotonic()
        if now - last[0] >= HEARTBEAT_S:
            last[0] = now
            say(message)

    return detail


@contextmanager
def heartbeat(say: Callable[[float], None]) -> Iterator[None]:
    """While the ``with`` block runs, ``say(elapsed_s)`` every :data:`HEARTBEAT_S` seconds
    (``elapsed_s`` since the block started) from a daemon thread: for one call that gives no
    progress of its own and releases the GIL while it works (a Mitsuba render, a numba
    compile). A block shorter than :data:`HEARTBEAT_S` says nothing. ``say`` runs on that
    thread (the command line's ``click.echo`` and a Qt signal's ``emit`` may); an exception it
    raises ends the heartbeat, not the block. The block's own work and results are untouched."""
    stop = threading.Event()
    t0 = time.monotonic()
    period = HEARTBEAT_S

    def beat() -> None:
        while not stop.wait(period):
            try:
                say(time.monotonic() - t0)
            except Exception:  # noqa: BLE001 - a failing message must not fail the work
                return

    thread = threading.Thread(target=beat, name="dreamprint-heartbeat", daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join()


def eta_text(elapsed_s: float, expected_s: float | None) -> str:
    """``"12 s"``, or ``"12 s, about 8 s left"`` when the step is expected to take
    ``expected_s`` seconds in all (e.g. the mean of the passes before it, scaled by their
    samples); ``"12 s, any moment now"`` once that is passed."""
    el = seconds_text(elapsed_s)
    if expected_s is None or not expected_s > 0:
        return el
    left = expected_s - elapsed_s
    return f"{el}, {about_text(left)} left" if left >= 1 else f"{el}, any moment now"
