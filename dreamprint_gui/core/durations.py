"""How long something takes, in words: the one rule for every surface (the command line's
notices, pre-flight and progress lines, the job's notes, the GUI's dialogs).

- :func:`seconds_text`: an estimate or a duration in round words (``"under 1 s"``, ``"12 s"``,
  ``"2.5 min"``, ``"1.2 h"``): minutes from 90 s, hours from 90 min, so a figure never reads
  ``"1.0 min"`` where ``"60 s"`` says more.
- :func:`about_text`: an estimate (``"about 12 s"``; ``"under 1 s"``, never ``"about under 1 s"``).
- :func:`measured_text`: a measured duration (tenths of a second below a minute, where a small
  job's ``"0 s"`` would say nothing; then :func:`clock_words`).
- :func:`clock_words`: a running count in words (``"12 s"``, ``"2 min 05 s"``, ``"1 h 02 min"``),
  the GUI's elapsed and remaining times.
- :func:`clock_text`: the same as a clock (``"2:05"``, ``"1:02:05"``), the command line's bars.
"""

from __future__ import annotations

import math

__all__ = ["seconds_text", "about_text", "measured_text", "clock_words", "clock_text"]


def seconds_text(s: float) -> str:
    """``"under 1 s"``, ``"12 s"`` (below 90 s), ``"2.5 min"`` (below 90 min), ``"1.2 h"``."""
    if s < 1:
        return "under 1 s"
    if s < 90:
        return f"{s:.0f} s"
    if s < 5400:
        return f"{s / 60:.1f} min"
    return f"{s / 3600:.1f} h"


def about_text(s: float) -> str:
    """An estimate: ``"about 12 s"``, or ``"under 1 s"``."""
    return "under 1 s" if s < 1 else f"about {seconds_text(s)}"


def clock_words(s: float | None) -> str:
    """A running count in words: ``"12 s"``, ``"2 min 05 s"``, ``"1 h 02 min"``; ``"estimating
    ..."`` when there is no figure yet (None or not finite)."""
    if s is None or not math.isfinite(s):
        return "estimating ..."
    s = max(0, int(round(s)))
    h, rem = divmod(s, 3600)
    m, sec = divmod(rem, 60)
    return f"{h} h {m:02d} min" if h else (f"{m} min {sec:02d} s" if m else f"{sec} s")


def measured_text(s: float) -> str:
    """A measured duration: ``"0.4 s"``, ``"12.3 s"`` below a minute, else :func:`clock_words`."""
    return f"{s:.1f} s" if s < 59.95 else clock_words(s)


def clock_text(s: float | None) -> str:
    """A running count as a clock: ``"2:05"``, ``"1:02:05"``; ``"--:--"`` with no figure."""
    if s is None or not math.isfinite(s):
        return "--:--"
    s = int(round(s))
    if s >= 3600:
        return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}"
    return f"{s // 60}:{s % 60:02d}"
