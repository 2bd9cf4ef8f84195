"""InstantNGP's row path (issue 25): box and occupancy tests a row or a block at a time, the
coarse levels of the hash encoding a row at a time; against the per-voxel tests and an
independent numpy evaluation, and identical with any number of threads."""

import numpy as np
import pytest
from test_volumes_ingp import f16, make_config, param_shapes, ref_field, write_snapshot

from dreamprint_gui.io.volumes import open_source
from dreamprint_gui.io.volumes.ingp.kernels import _row_axis, sample_rows
from dreamprint_gui.io.volumes.ingp.occupancy import occupied, row_span, row_voxels


def _brute(xs, qrow, a, brow, bx, lo, hi, blo, bhi, occ, max_cascade):
    keep = []
    for i, x in enumerate(xs):
        q = qrow + a * x
        v = brow + bx * x
        if np.any(q < lo) or np.any(q > hi) or np.any(v < blo) or np.any(v > bhi):
            continue
        if occupied(q, occ, max_cascade):
            keep.append(i)
    return keep


@pytest.mark.parametrize("seed", range(6))
def test_row_tests_keep_exactly_the_per_voxel_voxels(seed):
    rng = np.random.default_rng(seed)
    max_cascade = seed % 3
    n = 16
    # blobs of occupied cells, so that rows cross runs of empty and occupied cells
    occ = np.zeros((max_cascade + 1, n, n, n), np.uint8)
    for m in range(max_cascade + 1):
        c = rng.uniform(0, n, (4, 3))
        z, y, x = np.meshgrid(*(np.arange(n),) * 3, indexing="ij")
        for cx, cy, cz in c:
            occ[m][(x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2 < rng.uniform(4, 30)] = 1
    ax = seed % 3
    a = np.zeros(3)
    a[ax] = rng.choice([-1.0, 1.0]) * rng.uniform(0.5, 2.0)
    xs = np.sort(rng.uniform(-1.5, 1.5, 1)) + np.linspace(-1.2, 1.2, 301)
    w = 2.0 ** max_cascade
    lo, hi = np.full(3, 0.5 - 0.45 * w), np.full(3, 0.5 + 0.5 * w)
    th = rng.uniform(0, 0.5)
    R = np.array([[np.cos(th), -np.sin(th), 0], [np.sin(th), np.cos(th), 0], [0, 0, 1.0]])
    blo, bhi = np.full(3, -0.8 * w), np.full(3, 1.2 * w)
    bx = R @ a
    q = np.empty(3)
    out = np.empty(xs.size, np.int64)
    n_rows = 0
    for _ in range(150):
        qrow = rng.uniform(0.5 - 0.55 * w, 0.5 + 0.55 * w, 3)
        brow = R @ qrow
        want = _brute(xs, qrow, a, brow, bx, lo, hi, blo, bhi, occ, max_cascade)
        i0, i1 = row_span(xs, qrow, a, brow, bx, lo, hi, blo, bhi)
        k = row_voxels(xs, i0, i1, qrow, a, ax, occ, True, max_cascade, q, out)
        assert out[:k].tolist() == want
        n_rows += bool(want)
    assert n_rows > 20


def _snapshot(tmp_path, seed, interpolation="Linear"):
    rng = np.random.default_rng(seed)
    # levels from coarse (row form: a lattice cell spans several voxels) to fine (voxel by
    # voxel): s = 3 .. 451 against ~200 voxels across the aabb
    cfg = make_config(n_levels=7, n_feat=2, log2_t=12, base=4, pls=2.2, d_width=32,
                      d_hidden=1, r_width=32, r_hidden=2, interpolation=interpolation)
    dm, rm, levels = param_shapes(cfg)
    table = f16(rng.uniform(-1, 1, (sum(n for _s, _r, n, _h in levels), 2)))
    dmats = [f16(rng.normal(0, 0.5, sh)) for sh in dm]
    rmats = [f16(rng.normal(0, 0.5, sh)) for sh in rm]
    # occupancy: a ball with a hole, Morton order
    idx = np.arange(128 ** 3)
    xyz = [np.zeros_like(idx) for _ in range(3)]
    for b in range(7):
        for k in range(3):
            xyz[k] |= ((idx >> (3 * b + k)) & 1) << b
    c = [(v + 0.5) / 128 - 0.5 for v in xyz]
    r2 = c[0] ** 2 + c[1] ** 2 + c[2] ** 2
    grid = ((r2 < 0.4 ** 2) & (r2 > 0.15 ** 2)).astype(np.float32)
    ds = {"scale": 0.8, "offset": [0.5, 0.4, 0.3], "aabb_scale": 1}
    p = write_snapshot(tmp_path / "rows.ingp", cfg, dmats, rmats, table, dataset=ds,
                       density_grid=grid)
    return p, dmats, rmats, table, levels


def _reference(src, xs, ys, zs, dmats, rmats, table, levels):
    """The numpy reference of the snapshot at the source's grid points (z, y, x order):
    which points are inside the unit cube and occupied, and the field (sigma, rgb) there.
    Source = (C^T q - offset) / scale, with source -z as instant-ngp -y (view "down")."""
    Z, Y, X = np.meshgrid(zs, ys, xs, indexing="ij")
    q = np.stack([Y * 0.8 + 0.4, Z * 0.8 + 0.3, X * 0.8 + 0.5], -1).reshape(-1, 3)
    occ = src.model.occupancy
    keep = np.array([bool(np.all(v >= 0) and np.all(v <= 1) and occupied(v, occ, 0))
                     for v in q])
    want_s, want_c = ref_field(q[keep], dmats, rmats, table, levels, 2,
                               [np.array([0, -1.0, 0])])
    return keep, want_s, want_c


def test_row_path_matches_numpy_reference(tmp_path):
    p, dmats, rmats, table, levels = _snapshot(tmp_path, 11)
    src = open_source(p, view="down", threads=1)
    # source = (C^T q - offset) / scale; ngp z varies along a row (source x)
    xs = (np.linspace(0.0, 1.0, 203) - 0.5) / 0.8
    ys = (np.linspace(0.03, 0.97, 9) - 0.4) / 0.8
    zs = (np.linspace(0.1, 0.9, 5) - 0.3) / 0.8
    assert _row_axis(src._A, xs) == 2
    rgb, sig = src.evaluate(xs, ys, zs)
    keep, want_s, want_c = _reference(src, xs, ys, zs, dmats, rmats, table, levels)
    assert 0.2 < keep.mean() < 0.8
    np.testing.assert_array_equal(sig.reshape(-1) > 0, keep)
    # float32 positions against float64 (as the per-voxel path: test_volumes_ingp)
    np.testing.assert_allclose(sig.reshape(-1)[keep], want_s, rtol=1e-4)
    np.testing.assert_allclose(rgb.reshape(-1, 3)[keep], want_c, atol=2e-4)
    assert np.all(rgb.reshape(-1, 3)[~keep] == 0)
    # against the voxel-by-voxel path (decreasing x and y take it): the same float32
    # positions, the trilinear sums in another order only
    assert _row_axis(src._A, xs[::-1]) == -1 and _row_axis(src._A, ys[::-1], 1) == -1
    rgb_v, sig_v = src.evaluate(xs[::-1], ys[::-1], zs)
    sig_v, rgb_v = sig_v[:, ::-1, ::-1], rgb_v[:, ::-1, ::-1]
    np.testing.assert_array_equal(sig_v > 0, sig > 0)
    np.testing.assert_allclose(sig, sig_v, rtol=3e-6, atol=0)
    np.testing.assert_allclose(rgb, rgb_v, rtol=0, atol=3e-6)


def test_column_path_matches_numpy_reference(tmp_path):
    """Finer voxels along source y than x: lines run along y (instant-ngp x)."""
    p, dmats, rmats, table, levels = _snapshot(tmp_path, 15)
    src = open_source(p, view="down", threads=1)
    xs = (np.linspace(0.05, 0.95, 7) - 0.5) / 0.8
    ys = (np.linspace(0.0, 1.0, 190) - 0.4) / 0.8
    zs = (np.linspace(0.2, 0.8, 4) - 0.3) / 0.8
    assert src._line_axis(xs, ys) == 1 and src._line_axis(ys, xs) == 0
    rgb, sig = src.evaluate(xs, ys, zs)
    keep, want_s, want_c = _reference(src, xs, ys, zs, dmats, rmats, table, levels)
    np.testing.assert_array_equal(sig.reshape(-1) > 0, keep)
    np.testing.assert_allclose(sig.reshape(-1)[keep], want_s, rtol=1e-4)
    np.testing.assert_allclose(rgb.reshape(-1, 3)[keep], want_c, atol=5e-4)
    # the same kernel along rows (la = 0): float32 rounding apart
    sig0 = np.empty_like(sig)
    rgb0 = np.empty_like(rgb)
    sample_rows(0, zs.size * ys.size, 0, xs, ys, zs, *src._kernel_args(1.0), sig0, rgb0)
    np.testing.assert_array_equal(sig0 > 0, sig > 0)
    np.testing.assert_allclose(sig, sig0, rtol=3e-6, atol=0)
    np.testing.assert_allclose(rgb, rgb0, rtol=0, atol=3e-6)


@pytest.mark.parametrize("interpolation", ["Linear", "Smoothstep"])
@pytest.mark.parametrize("n_x, n_y", [(150, 23), (23, 150)])
def test_row_path_identical_with_any_threads_and_slab(tmp_path, interpolation, n_x, n_y):
    p, *_ = _snapshot(tmp_path, 12, interpolation)
    xs = np.linspace(-0.6, 0.6, n_x)
    ys = np.linspace(-0.5, 0.7, n_y)
    zs = np.linspace(-0.4, 0.9, 13)
    one = open_source(p, threads=1)
    assert one._line_axis(xs, ys) == (0 if n_x > n_y else 1)
    rgb1, sig1 = one.evaluate(xs, ys, zs)
    assert np.count_nonzero(sig1) > 1000
    for n in (2, 3):
        rgb_n, sig_n = one.evaluate(xs, ys, zs, threads=n)
        np.testing.assert_array_equal(sig_n, sig1)
        np.testing.assert_array_equal(rgb_n, rgb1)
    # one layer and a few rows alone: other batches, the same bits
    rgb_l, sig_l = one.evaluate(xs, ys, zs[6:7])
    np.testing.assert_array_equal(sig_l, sig1[6:7])
    np.testing.assert_array_equal(rgb_l, rgb1[6:7])


def test_colour_only_above_the_consumers_threshold(tmp_path):
    """With SlabBuffers.colour_threshold the colour network runs only where the density
    reaches it: the density is unchanged, the colour too where it is read, 0 elsewhere."""
    from dreamprint_gui.io.volumes import grid_for_source
    from dreamprint_gui.io.volumes.base import SlabBuffers

    p, *_ = _snapshot(tmp_path, 13)
    src = open_source(p, threads=1)
    grid = grid_for_source(src, (0.2, 0.2, 0.1), height_mm=4.0)
    z0, z1 = grid.shape_xyz[2] // 2 - 2, grid.shape_xyz[2] // 2 + 2
    rgb, sig = src.sample_slab(grid, z0, z1)
    fg = sig[sig > 0]
    cut = np.float32(np.median(fg))
    out = SlabBuffers(colour_where_dense=True, colour_threshold=cut)
    rgb_c, sig_c = src.sample_slab(grid, z0, z1, out=out)
    np.testing.assert_array_equal(sig_c, sig)
    read = sig >= cut
    assert 0.3 < read.sum() / fg.size < 0.7
    np.testing.assert_array_equal(rgb_c[read], rgb[read])
    assert np.all(rgb_c[~read] == 0)
    # a consumer that reads colour wherever the density is positive gets all of it
    rgb_a, _ = src.sample_slab(grid, z0, z1, out=SlabBuffers(colour_where_dense=True))
    np.testing.assert_array_equal(rgb_a, rgb)


def test_job_labels_unchanged_by_the_colour_cut(tmp_path, monkeypatch):
    """A print job's slices are the same bytes whether or not the snapshot's colour network is
    skipped below the job's background threshold (also through --content solid)."""
    from dreamprint_gui.cli import main
    from dreamprint_gui.io.volumes.ingp.snapshot import IngpSource

    p, *_ = _snapshot(tmp_path, 14)
    # the density straddles the job's threshold: a scale that puts its median there
    args = ["--height-mm", "1.5", "--table-size", "17", "--workers", "2", "--slab-layers",
            "4", "--fit", "box", "--density-scale", "0.04"]

    def slices(name, extra=()):
        out = tmp_path / name
        assert main(["convert", str(p), "-o", str(out), *args, *extra]) == 0
        return {f.name: f.read_bytes() for f in sorted((out / "slices").iterdir())}

    cut = slices("CUT")
    solid = slices("SOLID_CUT", ["--content", "solid"])
    run = IngpSource._run
    calls = []

    def no_cut(self, xs, ys, zs, factor, sigma, rgb, threads, colour_cut=0.0):
        run(self, xs, ys, zs, factor, sigma, rgb, threads, 0.0)
        dense = sigma[sigma > 0]
        if colour_cut > 0 and dense.size:
            calls.append(float(np.mean(dense < colour_cut)))   # voxels the cut skips

    monkeypatch.setattr(IngpSource, "_run", no_cut)
    assert slices("FULL") == cut
    assert slices("SOLID_FULL", ["--content", "solid"]) == solid
    assert calls and 0.1 < np.mean(calls) < 0.9
