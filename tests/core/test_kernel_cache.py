"""First-use compiles (issue 46): which modules' kernels numba has not cached (the one rule the
job's and the colour tables' announcements follow), the announcement, and the heartbeat while
numba compiles, and only then. No 16 s compile here: the cache folder is a temporary one and
the compile a two-line function."""

import time
from types import ModuleType

import numba
import pytest

from dreamprint_gui.core import kernel_cache
from dreamprint_gui.core import progress as core_progress
from dreamprint_gui.gamut import forward, optimise


def _index(folder, home: str) -> None:
    sub = folder / "some_source_folder"
    sub.mkdir(exist_ok=True)
    (sub / f"{home}.kernel-12.py311.nbi").write_bytes(b"")


def test_uncached_until_every_home_of_the_modules_kernels_has_an_index(tmp_path, monkeypatch):
    """gamut.optimise holds its own kernels and forward's (the table solve calls both): it is
    uncached until both modules have an index in the folder."""
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    assert kernel_cache.uncached(optimise)
    _index(tmp_path, "optimise")
    assert kernel_cache.uncached(optimise)            # forward's kernels still compile
    _index(tmp_path, "forward")
    assert not kernel_cache.uncached(optimise)
    assert kernel_cache.uncached(forward)             # it also holds kubelka_munk's
    _index(tmp_path, "kubelka_munk")
    assert not kernel_cache.uncached(forward)


def test_no_kernels_or_no_cache_folder_is_not_a_compile(tmp_path, monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    assert not kernel_cache.uncached(ModuleType("empty"))
    monkeypatch.delenv("NUMBA_CACHE_DIR")
    assert not kernel_cache.uncached(optimise)


def test_an_inlined_kernel_is_never_cached_on_its_own_and_does_not_count(tmp_path, monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    mod = ModuleType("m")
    mod.f = numba.njit(cache=True, inline="always")(lambda x: x + 1)
    assert not kernel_cache.uncached(mod)


def test_the_notice_says_what_why_and_how_long():
    assert kernel_cache.compile_notice("compiling the colour kernels", "first run", 16) == \
        "compiling the colour kernels: first run, about 16 s; cached after"
    assert "about 2.5 min" in kernel_cache.compile_notice("x", "y", 150)


def test_the_heartbeat_speaks_while_numba_compiles_and_only_then(monkeypatch):
    monkeypatch.setattr(core_progress, "HEARTBEAT_S", 0.01)
    said: list[float] = []
    with kernel_cache.while_compiling(said.append):
        time.sleep(0.1)                               # work, no compile: nothing said
    assert said == []

    def fresh(x):                                      # a new function: numba compiles it
        s = 0.0
        for i in range(x):
            s += i ** 0.5
        return s

    with kernel_cache.while_compiling(said.append):
        numba.njit(fresh)(10)
        n = len(said)
        time.sleep(0.1)                               # compiled: quiet again
    assert n >= 1 and said == sorted(said)
    assert len(said) <= n + 1


@pytest.mark.parametrize("cold", [True, False])
def test_a_table_build_announces_its_compile_only_when_cold(tmp_path, monkeypatch, cold):
    """get_tables(notify=) says 'compiling the colour kernels ... about 16 s; cached after'
    before a build whose kernels are not cached (kernels_estimate, here patched), nothing
    when they are, and nothing on a table loaded from the cache."""
    from dreamprint_gui.core.profile import default_profile
    from dreamprint_gui.gamut import tables

    monkeypatch.setattr(tables, "kernels_estimate", lambda: 16.0 if cold else None)
    heard: list[str] = []
    p = default_profile()
    tables.get_tables(p, "srgb", 5, cache=tmp_path, notify=heard.append)
    notices = [m for m in heard if m.startswith("compiling the colour kernels")]
    if cold:
        assert notices[0] == ("compiling the colour kernels: first run after an install or "
                              "upgrade, about 16 s; cached after")
    else:
        assert notices == []
    heard.clear()
    tables.get_tables(p, "srgb", 5, cache=tmp_path, notify=heard.append)   # cached: silent
    assert heard == []


def test_the_preparation_estimate_counts_the_colour_compile_before_a_cold_build(monkeypatch):
    from dreamprint_gui.job import prepare_time
    from dreamprint_gui.job.plan import ConvertSettings

    s = ConvertSettings(source="demo", output=None, height_mm=10.0, table_size=7,
                        objective="srgb")
    monkeypatch.setattr(prepare_time, "build_estimate", lambda *a, **k: 1.0)   # cold tables
    monkeypatch.setattr(prepare_time, "kernels_estimate", lambda: 16.0)
    cold = prepare_time.estimate_preparation(s)
    assert cold.builds["compiling the colour kernels"] == pytest.approx(16.0 * cold.slowdown)
    monkeypatch.setattr(prepare_time, "kernels_estimate", lambda: None)
    assert "compiling the colour kernels" not in prepare_time.estimate_preparation(s).builds
    monkeypatch.setattr(prepare_time, "build_estimate", lambda *a, **k: None)  # cached tables
    monkeypatch.setattr(prepare_time, "kernels_estimate", lambda: 16.0)
    assert "compiling the colour kernels" not in prepare_time.estimate_preparation(s).builds
