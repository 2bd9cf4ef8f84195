"""PrintGrid placement, the density rule and dispatch."""

import math

import numpy as np
import pytest

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes import grid_for_source, open_source
from dreamprint_gui.io.volumes.base import linear_to_srgb, mm_per_unit, voxel_centres


class _Box:
    bounds = ((-1.0, 0.0, 2.0), (3.0, 2.0, 4.0))   # extents 4, 2, 2


def test_height_scales_z_extent_and_keeps_aspect():
    g = grid_for_source(_Box(), (0.1, 0.2, 0.05), height_mm=10)
    assert g.mm_per_unit == pytest.approx(5.0)
    assert g.shape_xyz == (200, 50, 200)
    # grid covers the bounds, centred
    for a in range(3):
        c = voxel_centres(g, a)
        half = g.voxel_mm[a] / g.mm_per_unit / 2
        assert c[0] - half <= _Box.bounds[0][a] + 1e-12
        assert c[-1] + half >= _Box.bounds[1][a] - 1e-12
        assert (c[0] + c[-1]) / 2 == pytest.approx(sum(_Box.bounds[i][a] for i in (0, 1)) / 2)


def test_size_takes_largest_fitting_uniform_scale():
    g = grid_for_source(_Box(), (0.5, 0.5, 0.5), size_mm=(40, 40, 10))
    assert g.mm_per_unit == pytest.approx(5.0)          # z limits: 2 units -> 10 mm
    g = grid_for_source(_Box(), (0.5, 0.5, 0.5), size_mm=(8, 40, 40))
    assert g.mm_per_unit == pytest.approx(2.0)          # x limits: 4 units -> 8 mm
    assert g.shape_xyz == (16, 8, 8)


def test_mm_per_unit_closed_form():
    """The one scale rule (grid_for_source's, and what ``inspect`` states): height / z extent,
    or the smallest size / extent over the axes that have an extent."""
    assert mm_per_unit((2.0, 4.0, 8.0), height_mm=16.0) == 2.0
    assert mm_per_unit((2.0, 4.0, 8.0), size_mm=(10.0, 10.0, 10.0)) == 1.25
    assert mm_per_unit((0.0, 4.0, 8.0), size_mm=(1.0, 10.0, 40.0)) == 2.5  # flat x: ignored
    with pytest.raises(DreamPrintError, match="flat in z"):
        mm_per_unit((2.0, 4.0, 0.0), height_mm=1.0)
    with pytest.raises(DreamPrintError, match="no extent"):
        mm_per_unit((0.0, 0.0, 0.0), size_mm=(1.0, 1.0, 1.0))


def test_exactly_one_size_and_positive_values():
    with pytest.raises(DreamPrintError):
        grid_for_source(_Box(), (0.1, 0.1, 0.1))
    with pytest.raises(DreamPrintError):
        grid_for_source(_Box(), (0.1, 0.1, 0.1), height_mm=1, size_mm=(1, 1, 1))
    with pytest.raises(DreamPrintError):
        grid_for_source(_Box(), (0.1, 0, 0.1), height_mm=1)
    with pytest.raises(DreamPrintError):
        grid_for_source(_Box(), (0.1, 0.1, 0.1), height_mm=-2)


def test_srgb_encoding_closed_form():
    x = np.array([0.0, 0.002, 0.0031308, 0.18, 0.5, 1.0, 1.5], np.float32)
    want = [0.0, 12.92 * 0.002, 12.92 * 0.0031308, 1.055 * 0.18 ** (1 / 2.4) - 0.055,
            1.055 * 0.5 ** (1 / 2.4) - 0.055, 1.0, 1.0]
    np.testing.assert_allclose(linear_to_srgb(x.copy()), want, rtol=1e-5, atol=1e-6)


def test_unknown_file_is_refused(tmp_path):
    p = tmp_path / "x.bin"
    p.write_bytes(b"hello world")
    with pytest.raises(DreamPrintError, match="not a volume format"):
        open_source(p)
    with pytest.raises(DreamPrintError, match="no such file"):
        open_source(tmp_path / "missing.vdb")


def test_demo_is_deterministic_bounded_and_zero_outside():
    s = open_source("demo")
    assert s.bounds == ((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    g = grid_for_source(s, (0.1, 0.1, 0.05), height_mm=5)
    rgb1, d1 = s.sample_slab(g, 40, 60)
    rgb2, d2 = open_source("demo").sample_slab(g, 40, 60)
    assert np.array_equal(d1, d2) and np.array_equal(rgb1, rgb2)
    assert d1.max() > 0 and rgb1.dtype == np.float32 and d1.dtype == np.float32
    assert rgb1.shape == (20, g.shape_xyz[1], g.shape_xyz[0], 3)
    assert 0 <= rgb1.min() and rgb1.max() <= 1
    # outside the soft boundary (corner layer) density is exactly 0
    _, d0 = s.sample_slab(g, 0, 2)
    assert not d0.any()
    # slabs are independent of how the grid is cut
    _, whole = s.sample_slab(g, 40, 60)
    _, a = s.sample_slab(g, 40, 47)
    _, b = s.sample_slab(g, 47, 60)
    np.testing.assert_allclose(np.concatenate([a, b]), whole, rtol=1e-6)
    # density rule: scale and mm per unit enter linearly
    _, d3 = s.sample_slab(g, 40, 60, density_scale=2.5)
    np.testing.assert_allclose(d3, 2.5 * d1, rtol=1e-5)
    assert math.isclose(g.mm_per_unit, 5.0)


def test_concurrent_slabs_match_sequential(shared_data):
    from concurrent.futures import ThreadPoolExecutor

    for f in ("demo", shared_data / "volumes" / "ironProt.vtk"):
        s = open_source(f)
        g = grid_for_source(s, (0.2, 0.2, 0.1), height_mm=6)
        cuts = list(range(0, g.shape_xyz[2], 7)) + [g.shape_xyz[2]]
        spans = list(zip(cuts[:-1], cuts[1:], strict=True))
        seq = [s.sample_slab(g, a, b)[1] for a, b in spans]
        with ThreadPoolExecutor(4) as ex:
            par = list(ex.map(lambda ab, s=s, g=g: s.sample_slab(g, *ab)[1], spans))
        for x, y in zip(seq, par, strict=True):
            assert np.array_equal(x, y)


def test_unknown_reader_option_is_named(shared_data):
    with pytest.raises(DreamPrintError, match="unknown reader option 'bogus'.*window"):
        open_source(shared_data / "volumes" / "ironProt.vtk", bogus=1)
    s = open_source(shared_data / "volumes" / "blender_mantaflow_fluid_data_0190.vdb",
                    grid="shadow")
    assert s.density.name == "shadow"


def test_reused_slab_buffers_give_what_fresh_arrays_give(shared_data):
    """A worker's buffers hold the previous slab (here: NaN); every element is rewritten."""
    from dreamprint_gui.io.volumes.base import SlabBuffers

    for f in ("demo", shared_data / "volumes" / "ironProt.vtk",
              shared_data / "voxels" / "magicavoxel_chr_knight.vox",
              shared_data / "splats" / "inria3dgs_iter7000_sh3_9080.ply"):
        s = open_source(f)
        g = grid_for_source(s, (0.2, 0.2, 0.1), height_mm=6)
        nx, ny, nz = g.shape_xyz
        buf = SlabBuffers()
        buf.take((nz, ny, nx))
        buf.rgb[...] = np.nan
        buf.sigma[...] = np.nan
        for z0, z1 in ((0, nz // 2), (nz // 2, nz), (0, 3)):
            rgb, d = s.sample_slab(g, z0, z1, out=buf)
            ref_rgb, ref_d = s.sample_slab(g, z0, z1)
            np.testing.assert_array_equal(d, ref_d)
            np.testing.assert_array_equal(rgb, ref_rgb)


def test_colour_where_dense_leaves_only_empty_rows_colour_unwritten():
    from dreamprint_gui.io.volumes.base import SlabBuffers

    s = open_source("demo")
    g = grid_for_source(s, (0.2, 0.2, 0.1), height_mm=6)
    nx, ny, nz = g.shape_xyz
    buf = SlabBuffers(colour_where_dense=True)
    buf.take((nz, ny, nx))
    buf.rgb[...] = np.nan
    buf.sigma[...] = np.nan
    rgb, d = s.sample_slab(g, 0, nz, out=buf)
    ref_rgb, ref_d = s.sample_slab(g, 0, nz)
    np.testing.assert_array_equal(d, ref_d)
    dense = d > 0
    np.testing.assert_array_equal(rgb[dense], ref_rgb[dense])
    rows = d.max(axis=2) > 0  # rows with density are written whole, as fresh arrays would be
    np.testing.assert_array_equal(rgb[rows], ref_rgb[rows])
    assert np.isnan(rgb[~rows]).all() and (~rows).any()  # the others were left alone


def test_dense_sampler_outside_the_source_writes_zeros():
    from dreamprint_gui.io.volumes.base import SlabBuffers
    from dreamprint_gui.io.volumes.sampling import sample_dense_density

    vol = np.ones((4, 4, 4, 4), np.float32)
    buf = SlabBuffers()
    buf.take((2, 3, 5))
    buf.rgb[...] = np.nan
    buf.sigma[...] = np.nan
    inside = np.array([0.5, 1.5])
    for ux, uy in ((np.full(5, -9.0), np.arange(3.0)), (np.arange(5.0), np.full(3, 9.0))):
        rgb, d = sample_dense_density(vol, inside, uy, ux, 0.5, 1.0, buf)
        assert not d.any() and not rgb.any()


