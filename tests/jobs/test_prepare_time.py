"""Preparing a job is estimated before it starts (issue 46, job/prepare_time.py): the source from
its size and kind, the colour tables cold (a first build) or warm (cached), first-use builds;
the CLI says it before the work and the pre-flight states it beside the conversion."""

from __future__ import annotations

import json
import re
import time

import numpy as np
import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.core.printer import load_printer
from dreamprint_gui.core.profile import load_profile
from dreamprint_gui.gamut.tables import build_estimate
from dreamprint_gui.job import prepare_time
from dreamprint_gui.job.halftone import MASK_BUILD_SECONDS
from dreamprint_gui.job.plan import ConvertSettings
from dreamprint_gui.job.preflight import Preflight
from dreamprint_gui.job.prepare_time import (
    SETUP_SECONDS,
    SOURCE_MODEL,
    TABLE_LOAD_SECONDS,
    estimate_preparation,
    source_bytes,
    source_seconds,
)


def test_the_source_is_estimated_from_its_kind_and_size(tmp_path):
    """seconds = fixed + MB x seconds per MB of the kind; a MetaImage header counts its data."""
    head = tmp_path / "scan.mhd"
    head.write_text("ObjectType = Image\nNDims = 3\nDimSize = 100 100 100\n"
                    "ElementType = MET_UCHAR\nElementDataFile = scan.raw\n")
    (tmp_path / "scan.raw").write_bytes(bytes(1_000_000))
    assert source_bytes(str(head)) == head.stat().st_size + 1_000_000
    fixed, per_mb = SOURCE_MODEL[".mhd"]
    assert source_seconds(str(head)) == pytest.approx(fixed + per_mb * source_bytes(str(head))
                                                      / 1e6)
    small, big = tmp_path / "a.ply", tmp_path / "b.ply"
    small.write_bytes(bytes(1_000_000))
    big.write_bytes(bytes(11_000_000))
    slope = (source_seconds(str(big)) - source_seconds(str(small))) / 10
    assert slope == pytest.approx(SOURCE_MODEL[".ply"][1])
    assert source_seconds("demo") == SOURCE_MODEL["demo"][0]
    assert source_bytes(str(tmp_path)) == sum(p.stat().st_size for p in tmp_path.iterdir())


def test_cold_tables_are_a_first_build_warm_ones_a_load(tmp_path, monkeypatch):
    s = ConvertSettings(source="demo", height_mm=10.0, table_size=17)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))      # empty table and mask caches
    monkeypatch.delenv("DREAMPRINT_CACHE", raising=False)     # (which it would replace)
    monkeypatch.setattr(prepare_time, "machine_slowdown", lambda: 1.0)    # an idle machine
    monkeypatch.setattr(prepare_time, "parallel_slowdown", lambda: 1.0)
    cold = estimate_preparation(s)
    printer = load_printer(None)
    profile = load_profile(None).with_settings(layer_thickness_mm=printer.layer_thickness_mm)
    assert cold.tables_cold and cold.tables_s == build_estimate(profile, None, 17, None) > 0
    assert cold.builds["the blue-noise mask"] == MASK_BUILD_SECONDS
    assert cold.source_s == SOURCE_MODEL["demo"][0]
    assert cold.setup_s == SETUP_SECONDS
    assert cold.total_s == pytest.approx(cold.source_s + cold.tables_s + SETUP_SECONDS
                                         + sum(cold.builds.values()))
    line = cold.describe()
    assert line.startswith("preparing: about ") and "a first build" in line
    assert "the blue-noise mask: first use" in line
    monkeypatch.setattr(prepare_time, "build_estimate", lambda *a, **k: None)   # cached
    monkeypatch.setattr(prepare_time, "mask_build_estimate", lambda v: None)
    warm = estimate_preparation(s)
    assert not warm.tables_cold and warm.tables_s == TABLE_LOAD_SECONDS
    assert "first build" not in warm.describe() and warm.total_s < cold.total_s
    monkeypatch.setattr(prepare_time, "machine_slowdown", lambda: 3.0)    # a shared machine
    busy = estimate_preparation(s)
    assert busy.total_s == pytest.approx(3.0 * warm.total_s)
    assert "; the machine 3.0 x slower than idle now" in busy.describe()
    # a first build keeps every core busy: scaled by the every-core probe, the rest by one
    # thread's
    monkeypatch.setattr(prepare_time, "build_estimate", lambda *a, **k: 20.0)
    monkeypatch.setattr(prepare_time, "parallel_slowdown", lambda: 5.0)
    shared = estimate_preparation(s)
    assert shared.tables_s == pytest.approx(100.0) and shared.parallel_slowdown == 5.0
    assert shared.source_s == pytest.approx(3.0 * SOURCE_MODEL["demo"][0])


def test_the_slowdown_is_the_share_of_a_core_this_thread_gets():
    """wall / CPU of the probe: 1 on its own; about 2 when another thread of this process
    competes for the same core (both pinned to one CPU)."""
    import os
    import threading

    assert 1.0 <= prepare_time.machine_slowdown() < 50
    if not hasattr(os, "sched_setaffinity"):
        return
    keep = os.sched_getaffinity(0)
    stop = threading.Event()

    def spin():
        while not stop.is_set():
            pass

    try:
        os.sched_setaffinity(0, {min(keep)})
        t = threading.Thread(target=spin, daemon=True)
        t.start()
        shared = prepare_time.machine_slowdown(0.2)
    finally:
        stop.set()
        os.sched_setaffinity(0, keep)
    assert shared > 1.4


def test_the_every_core_probe_sees_threads_sharing_a_core(monkeypatch):
    """Two probe threads held to one CPU take twice the work's time: the every-core probe says
    about 2 x against a model machine whose hash costs what it costs here."""
    import hashlib
    import os

    if not hasattr(os, "sched_setaffinity"):
        pytest.skip("no CPU affinity on this platform")
    per = []
    for _ in range(3):
        c0 = time.thread_time()
        for _ in range(40):
            hashlib.sha256(prepare_time._HASH_BLOCK).digest()
        per.append((time.thread_time() - c0) / 40)
    monkeypatch.setattr(prepare_time, "PROBE_HASH_CPU_S", min(per))
    assert prepare_time.parallel_slowdown(0.02) >= 1.0
    keep = os.sched_getaffinity(0)
    try:
        os.sched_setaffinity(0, {min(keep)})
        shared = prepare_time.parallel_slowdown(0.05, threads=2)
    finally:
        os.sched_setaffinity(0, keep)
    assert shared > 1.6


def _pf() -> Preflight:
    return Preflight(grid_shape=(10, 10, 10), size_mm=(1, 1, 1), slices=10, total_voxels=1000,
                     disk_bytes=2000, fractions={"Cl": 1.0}, sampled_voxels=1000,
                     clamped_fraction=0.0, clamped_voxels=0, safe_density_scale=None,
                     out_of_gamut_fraction=0.0, worst_dE2000=0.0, seconds=0.4,
                     rate_voxels_per_s=2500.0, rate_source="", content={"mode": "fog"},
                     density_scale=1.0, background="clear")


def test_the_pre_flight_states_the_estimate_made_before_and_what_it_took():
    pf = _pf()
    pf.prepare_estimate = {"seconds": 65.0}
    pf.prepared_seconds = 58.0
    line = pf.short_line()
    assert ("under 1 s to convert, about 65 s in all (preparing estimated 65 s before it "
            "started: the source, the colour tables, first-use builds; it took 58 s)") in line
    assert pf.to_json()["prepare_estimate"] == {"seconds": 65.0}


def test_convert_says_the_estimate_before_preparing(tmp_path, capsys):
    out = tmp_path / "JOB"
    assert main(["convert", "demo", "-o", str(out), "--height-mm", "3", "--table-size", "17",
                 "--json"]) == 0
    captured = capsys.readouterr()
    err = captured.err.splitlines()
    # "preparing: about 2 s (...)", or "under 1 s" on a quick machine with cached tables
    first = next(i for i, ln in enumerate(err)
                 if re.match(r"preparing: (about \d|under 1 s)", ln))
    job = next(i for i, ln in enumerate(err) if ln.startswith("job: "))
    assert first < job                                  # said before the work
    m = json.loads(captured.out)
    est = m["preflight"]["prepare_estimate"]
    assert est["seconds"] > 0 and set(est) >= {"source_s", "tables_s", "tables_cold"}
    assert set(m["timings_s"]["prepare_parts"]) == {"source", "tables"}


def test_inspect_says_a_slow_opening_before_it(monkeypatch, capsys):
    """A source estimated at 2 s or more to open and place (here: the machine 100 x slower
    than idle) is said on stderr before the wait; --json's stdout stays JSON."""
    monkeypatch.setattr(prepare_time, "machine_slowdown", lambda *a: 100.0)
    assert main(["inspect", "demo", "--json"]) == 0
    out = capsys.readouterr()
    # the estimate in core.durations' words, once ("about about 3 s" was said)
    assert re.match(r"opening demo: about [\d.]+ (s|min|h) \(reading it, its up axis", out.err), \
        out.err
    json.loads(out.out)
    monkeypatch.setattr(prepare_time, "machine_slowdown", lambda *a: 1.0)
    assert main(["inspect", "demo", "--json"]) == 0
    assert capsys.readouterr().err == ""        # quick: nothing said


def test_the_slowdown_counts_slower_cpu_seconds(monkeypatch):
    """The probe's CPU time per sort against the model machine's (PROBE_SORT_CPU_S): a machine
    whose CPU second sorts a tenth as much is 10 x slower whatever its share of a core; one as
    quick or quicker counts as the model's (the share alone)."""
    monkeypatch.setattr(prepare_time, "PROBE_SORT_CPU_S", 1.0)          # far quicker: share
    share = prepare_time.machine_slowdown(0.05)
    assert 1.0 <= share < 50
    c0, n = time.thread_time(), 0
    while time.thread_time() - c0 < 0.05:
        np.sort(prepare_time._PROBE)
        n += 1
    per_sort = (time.thread_time() - c0) / n
    monkeypatch.setattr(prepare_time, "PROBE_SORT_CPU_S", per_sort / 10)
    assert prepare_time.machine_slowdown(0.05) > 4.0     # ~10 x, less the sorts' own spread
