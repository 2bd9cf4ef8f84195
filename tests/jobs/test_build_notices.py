"""First-use builds are announced before they start, with an estimate; nothing when cached."""

import re

import numpy as np

from dreamprint_gui.job import halftone
from dreamprint_gui.job.plan import ConvertSettings, prepare_job
from dreamprint_gui.job.run import run_conversion


def _fast_mask(shape_zyx, voxel_mm):  # the real build takes ~15 s; its notice is under test
    n = int(np.prod(shape_zyx))
    rank = np.random.default_rng(0).permutation(n)
    return ((rank.reshape(shape_zyx) + 0.5) / n).astype(np.float32)


def test_builds_are_announced_once(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))      # colour tables
    monkeypatch.setenv("DREAMPRINT_CACHE", str(tmp_path / "dp"))     # blue-noise mask
    monkeypatch.setattr(halftone, "_generate_mask", _fast_mask)
    s = ConvertSettings(source="demo", output=tmp_path / "JOB", height_mm=0.3, table_size=9,
                        printer="j850-paper")
    first: list[str] = []
    prepare_job(s, notify=first.append)
    tables = [m for m in first if m.startswith("building colour tables (")]
    # the time said in core.durations' words: "about 12 s", or "under 1 s" for a 9^3 table
    said = r"first use, (about [\d.]+ (s|min|h)|under 1 s); cached after"
    assert len(tables) == 1 and re.search(said, tables[0]) and "9^3" in tables[0]
    assert first[first.index(tables[0]) + 1:].count("building colour tables: 100 %") == 1
    assert any(m.startswith("building the blue-noise mask for 84 x 28 x 14 um voxels: ")
               and re.search(said, m) for m in first)
    again: list[str] = []
    prepare_job(s, notify=again.append)
    assert not any("building" in m for m in again), again
    # run_conversion relays them as "preparing" messages, before the pre-flight
    s2 = ConvertSettings(source="demo", output=tmp_path / "JOB2", height_mm=0.3, table_size=10)
    gen = run_conversion(s2)
    stages = []
    for p in gen:
        stages.append((p.stage, p.message))
        if p.stage == "preflight":
            gen.close()
            break
    msgs = [m for st, m in stages if st == "preparing"]
    assert any(m.startswith("building colour tables (") for m in msgs)
    assert stages[-1][0] == "preflight"


def test_a_slow_or_large_source_is_announced(tmp_path, monkeypatch):
    """Opening a large source says so before it starts, and a slow one how long it took
    (issue 46: a MetaImage's 7.5 s of loading was silent)."""
    import time

    from dreamprint_gui.job import plan

    real_open = plan._open_source

    def slow_open(*args, **kwargs):
        time.sleep(2.2)
        return real_open("demo", {})

    big = tmp_path / "big.vdb"
    with open(big, "wb") as f:                     # a sparse file of the announcing size
        f.truncate(plan.OPENING_NOTICE_BYTES)
    monkeypatch.setattr(plan, "_open_source", slow_open)
    said: list[str] = []
    prepare_job(ConvertSettings(source=str(big), output=tmp_path / "J", height_mm=0.3,
                                table_size=9), notify=said.append)
    assert said[0] == "opening the source big.vdb (50 MB) ..."
    assert any(m.startswith("opened the source big.vdb in 2.") for m in said)
