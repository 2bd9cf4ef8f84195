"""The source renders kept on disk (proof/source_cache.py): a hit is the render itself, bit for
bit; anything the image depends on misses; a damaged or unwritable cache only costs a render."""

import numpy as np
import pytest

from dreamprint_gui.proof import source_cache
from dreamprint_gui.proof.cameras import View
from dreamprint_gui.proof.source_cache import cached_render_source
from dreamprint_gui.proof.source_render import SourceField, render_source


def _field(seed=0):
    rng = np.random.default_rng(seed)
    sigma = rng.uniform(0, 2, (6, 7, 8)).astype(np.float32)
    colour = rng.uniform(0, 1, (6, 7, 8, 3)).astype(np.float32)
    return SourceField(sigma, colour, np.array([-4.0, -3.5, -3.0]), np.ones(3), False)


VIEW = View(30.0, 20.0, 7.0, 30.0)


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("DREAMPRINT_CACHE", str(tmp_path))
    return tmp_path / source_cache.CACHE_NAME


def test_a_hit_is_the_render_bit_for_bit(cache):
    ref = render_source(_field(), VIEW, 24)
    rgb, a, hit = cached_render_source(_field(), VIEW, 24)
    assert not hit and len(list(cache.glob("*.npz"))) == 1
    rgb2, a2, hit2 = cached_render_source(_field(), VIEW, 24)
    assert hit2
    for x in (rgb, rgb2):
        assert np.array_equal(x, ref[0])
    assert np.array_equal(a2, ref[1]) and np.array_equal(a, ref[1])


def test_what_the_image_depends_on_misses(cache):
    cached_render_source(_field(), VIEW, 24)
    f = _field()
    one_cell = SourceField(f.sigma.copy(), f.colour, f.lo_mm, f.cell_mm, f.nearest)
    one_cell.sigma[3, 3, 3] += 1e-3
    colour = SourceField(f.sigma, f.colour.copy(), f.lo_mm, f.cell_mm, f.nearest)
    colour.colour[0, 0, 0, 2] += 1e-3
    others = [
        (one_cell, VIEW, 24, None),
        (colour, VIEW, 24, None),
        (SourceField(f.sigma, f.colour, f.lo_mm + 0.1, f.cell_mm, f.nearest), VIEW, 24, None),
        (SourceField(f.sigma, f.colour, f.lo_mm, f.cell_mm, True), VIEW, 24, None),
        (f, View(31.0, 20.0, 7.0, 30.0), 24, None),
        (f, VIEW, 25, None),
        (f, VIEW, 24, 0.5),
    ]
    for field, view, res, rho in others:
        rgb, a, hit = cached_render_source(field, view, res, floor_rho=rho)
        assert not hit
        ref = render_source(field, view, res, floor_rho=rho)
        assert np.array_equal(rgb, ref[0]) and np.array_equal(a, ref[1])
    assert len(list(cache.glob("*.npz"))) == 1 + len(others)


def test_a_damaged_entry_is_rendered_again(cache):
    cached_render_source(_field(), VIEW, 24)
    (entry,) = cache.glob("*.npz")
    entry.write_bytes(b"not an npz")
    rgb, _, hit = cached_render_source(_field(), VIEW, 24)
    assert not hit and np.array_equal(rgb, render_source(_field(), VIEW, 24)[0])
    assert cached_render_source(_field(), VIEW, 24)[2]       # written again


def test_an_unwritable_cache_renders(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    monkeypatch.setenv("DREAMPRINT_CACHE", str(blocker))     # a file: no folder under it
    rgb, _, hit = cached_render_source(_field(), VIEW, 16)
    assert not hit and np.array_equal(rgb, render_source(_field(), VIEW, 16)[0])


def test_the_oldest_entries_go_beyond_the_limit(cache, monkeypatch):
    monkeypatch.setattr(source_cache, "MAX_ENTRIES", 2)
    for k in range(4):
        cached_render_source(_field(k), VIEW, 8)
    assert len(list(cache.glob("*.npz"))) == 2
    assert cached_render_source(_field(3), VIEW, 8)[2]
    assert not cached_render_source(_field(0), VIEW, 8)[2]
