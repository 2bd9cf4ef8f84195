"""When a long step says how it goes: :data:`HEARTBEAT_S` and :func:`percent_reporter`, the
one rule for a build's percentage (the command line's bar, the job's notices, the GUI's), and
:func:`every_heartbeat` for the messages inside a step."""

from __future__ import annotations

import time
from collections.abc import Callable

__all__ = ["HEARTBEAT_S", "percent_reporter", "every_heartbeat"]

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
