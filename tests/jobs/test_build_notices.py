"""First-use builds are announced before they start, with an estimate; nothing when cached."""

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
    assert len(tables) == 1 and "first use, about" in tables[0] and "9^3" in tables[0]
    assert first[first.index(tables[0]) + 1:].count("building colour tables: 100 %") == 1
    assert any(m.startswith("building the blue-noise mask for 84 x 28 x 14 um voxels: first "
                            "use, about") for m in first)
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
