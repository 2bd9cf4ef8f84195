"""Durations in words: one rule for the CLI, the job's notes and the GUI (core/durations)."""

from __future__ import annotations

import math

from dreamprint_gui.core.durations import (
    about_text,
    clock_text,
    clock_words,
    measured_text,
    seconds_text,
)


def test_estimates_in_round_words():
    assert about_text(0.4) == "under 1 s"  # not "about under 1 s"
    assert about_text(12.2) == "about 12 s"
    assert about_text(150) == "about 2.5 min"
    assert seconds_text(89.4) == "89 s"  # minutes from 90 s: never "1.0 min"
    assert seconds_text(90) == "1.5 min"
    assert seconds_text(5399) == "90.0 min"
    assert seconds_text(7200) == "2.0 h"


def test_running_counts_as_words_and_as_a_clock():
    assert clock_words(None) == clock_words(math.nan) == "estimating ..."
    assert clock_words(7.4) == "7 s"
    assert clock_words(125) == "2 min 05 s"
    assert clock_words(3725) == "1 h 02 min"
    assert clock_text(None) == "--:--"
    assert clock_text(125) == "2:05"
    assert clock_text(3725) == "1:02:05"


def test_measured_durations_keep_tenths_below_a_minute():
    assert measured_text(0.44) == "0.4 s"
    assert measured_text(59.9) == "59.9 s"
    assert measured_text(60.0) == "1 min 00 s"
