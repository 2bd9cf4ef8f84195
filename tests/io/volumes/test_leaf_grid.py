"""Sparse VDB grids densified over their leaves (``io.volumes.vdb.leaf_grid``) give the sparse
sampler's densities bit for bit, and the fused print-job path (``job.sample_label.leaf_grid_job``)
writes what the general path writes (sample the slab, then ``slab_labels``)."""

import numpy as np
import pytest

from dreamprint_gui.io.volumes import grid_for_source, open_source
from dreamprint_gui.io.volumes.base import SlabBuffers
from dreamprint_gui.io.volumes.sampling import SparseBlocks
from dreamprint_gui.io.volumes.vdb.leaf_grid import LeafGridPlan, densify, leaf_grid_layer
from dreamprint_gui.job.plan import ConvertSettings, prepare_job
from dreamprint_gui.job.sample_label.leaf_grid_job import leaf_grid_slab_labels
from dreamprint_gui.job.slab import _labels_of_slab


def _random_blocks(seed=3, bg=0.0):
    """Leaves of random values (negative ones, -0.0 and NaN among them) with gaps between."""
    rng = np.random.default_rng(seed)
    origins = np.array([(i, j, k) for i in range(-16, 24, 8) for j in range(0, 32, 8)
                        for k in range(8, 40, 8) if rng.random() < 0.6], np.int64)
    values = rng.uniform(-1.0, 4.0, (len(origins), 8, 8, 8, 1)).astype(np.float32)
    values[rng.random(values.shape) < 0.3] = 0.0
    flat = values.reshape(-1)
    flat[rng.integers(0, flat.size, 4)] = -0.0
    flat[rng.integers(0, flat.size, 2)] = np.nan
    return SparseBlocks(origins, values, np.float32(bg))


class _Blocks:
    """A minimal VDB-like source around SparseBlocks (unit voxels, index = world)."""

    layer_kind = "leaf_grid"

    def __init__(self, blocks):
        from dreamprint_gui.io.volumes.vdb.openvdb import VdbSource

        self.blocks = blocks
        self.density = type("G", (), {})()
        self.density.blocks = blocks
        self.density.origin = np.array([0.3, -0.2, 0.1])
        self.density.scale = np.array([0.5, 0.5, 0.5])
        self.density.sample = lambda grid, z0, z1: self._sample(grid, z0, z1)
        self.colour_grids = []
        self.is_level_set = False
        self.colour_encoding = "linear"
        self.uniform_colour = np.array([0.9, 0.4, 0.2], np.float32)
        lo = (-20.0, -4.0, 4.0)
        self.bounds = (lo, (14.0, 18.0, 22.0))
        self._leaf_plan = LeafGridPlan(blocks, self.density.origin, self.density.scale)
        self._densify = lambda: None          # sample_slab keeps the sparse sampler here
        self.sample_slab = VdbSource.sample_slab.__get__(self)
        self.layer_plan = VdbSource.layer_plan.__get__(self)

    def _sample(self, grid, z0, z1):
        from dreamprint_gui.io.volumes.base import voxel_centres
        from dreamprint_gui.io.volumes.sampling import sample_sparse

        g = self.density
        u = [(voxel_centres(grid, a, *((z0, z1) if a == 2 else (0, None))) - g.origin[a])
             / g.scale[a] for a in range(3)]
        return sample_sparse(self.blocks, u[2], u[1], u[0])


@pytest.mark.parametrize("voxel", [(0.13, 0.07, 0.11), (1.3, 0.9, 0.6)])
def test_densified_layers_equal_the_sparse_sampler(voxel):
    src = _Blocks(_random_blocks())
    grid = grid_for_source(src, voxel, size_mm=(20, 20, 20))
    _, ref = src.sample_slab(grid, 0, grid.shape_xyz[2], density_scale=1.7)
    assert np.isnan(ref).any() and (ref > 0).any()
    plan = src.layer_plan(grid, 0, grid.shape_xyz[2], density_scale=1.7)
    dense, rows, k0, wk, j0, wj, i0, wi, plane, scale, _ = plan
    out = np.full(ref.shape, 5.0, np.float32)
    for k in range(len(k0)):
        leaf_grid_layer(dense, rows, k0[k], wk[k], j0, wj, i0, wi, plane, scale,
                        out[k].reshape(-1))
    np.testing.assert_array_equal(out.view(np.uint32), ref.view(np.uint32))


def test_densify_refuses_what_it_cannot_reproduce():
    b = _random_blocks(bg=0.5)
    assert densify(b.origins, b.values, b.background) is None      # background not 0
    b = _random_blocks(bg=-0.0)
    assert densify(b.origins, b.values, b.background) is None
    far = SparseBlocks(np.array([[0, 0, 0], [8 * 4096, 8 * 4096, 0]]),
                       np.ones((2, 8, 8, 8, 1), np.float32), np.float32(0))
    assert densify(far.origins, far.values, far.background) is None  # too large


def _general_and_fused(ctx, src, kernel):
    """Labels, counts, sums and clamp report of three slabs through the general path (sample,
    then label) and through ``kernel`` (the fused layer path, whole layers or strips of rows):
    the same bits. Returns the whole job's labels."""
    nx, ny, nz = ctx.shape_xyz
    whole = None
    for z0, z1 in ((0, nz), (3, 4), (nz // 2, nz)):
        buf = SlabBuffers(colour_where_dense=ctx.kernel_args()[0] > 0)
        rgb, dens = src.sample_slab(ctx.grid, z0, z1, out=buf)
        a = (np.empty((z1 - z0, ny, nx), np.uint8), np.zeros(7, np.int64),
             np.zeros((z1 - z0, 7)), np.zeros(4))
        _labels_of_slab(ctx, rgb, dens, z0, *a)
        for strip_voxels in (1 << 15, 1, 3 * nx + 1):  # a layer; strips of 1 and 3 rows
            b = (np.empty((z1 - z0, ny, nx), np.uint8), np.zeros(7, np.int64),
                 np.zeros((z1 - z0, 7)), np.zeros(4))
            kernel(*src.layer_plan(ctx.grid, z0, z1), np.full((ny * nx, 3), np.nan, np.float32),
                   np.full(ny * nx, 7.0, np.float32), z0, *ctx.kernel_args(), *b, strip_voxels)
            for x, y in zip(a, b, strict=True):
                np.testing.assert_array_equal(x.view(np.uint8), y.view(np.uint8))
        whole = a if whole is None else whole
    return whole


@pytest.mark.parametrize("threshold", [None, 0.0])
def test_fused_path_writes_what_the_general_path_writes(tmp_path, monkeypatch, threshold):
    src = _Blocks(_random_blocks(seed=8))
    from dreamprint_gui.job import plan

    monkeypatch.setattr(plan, "_open_source", lambda spec, options, *_: src)
    s = ConvertSettings(source="vdb-like", output=tmp_path / "j", size_mm=(6, 6, 6),
                        density_threshold=threshold)
    whole = _general_and_fused(prepare_job(s), src, leaf_grid_slab_labels)
    assert whole[1][:6].sum() > 0                                  # some foreground labelled


def test_vdb_files_take_the_fused_path_unless_three_colour_grids(vdbs):
    g = None
    for name, kind in (("ramp", "leaf_grid"), ("bigtile", "leaf_grid"),
                       ("box_half_cd", "leaf_grid_colour"), ("box_rgb3", None),
                       ("far", "leaf_grid")):
        s = open_source(vdbs / f"{name}.vdb")
        g = grid_for_source(s, (0.13, 0.07, 0.11), size_mm=(5, 5, 5))
        assert (s.layer_plan(g, 0, 1) is not None) == (kind is not None), name
        assert kind is None or s.layer_kind == kind


@pytest.mark.parametrize("encoding, threshold", [("linear", None), ("srgb", None),
                                                 ("linear", 0.0)])
def test_colour_grid_fused_path_writes_what_the_general_path_writes(vdbs, tmp_path,
                                                                    monkeypatch, encoding,
                                                                    threshold):
    """A density + vec3 colour (Cd) file: the fused layer path (colour grid densified,
    sRGB-encoded or clipped where labelled) gives the general path's labels, counts, sums and
    clamp report bit for bit, for any slab."""
    from dreamprint_gui.job import plan
    from dreamprint_gui.job.sample_label.leaf_grid_job import leaf_grid_colour_slab_labels

    src = open_source(vdbs / "box_half_cd.vdb", colour_encoding=encoding)
    monkeypatch.setattr(plan, "_open_source", lambda spec, options, *_: src)
    ctx = prepare_job(ConvertSettings(source="vdb-cd", output=tmp_path / "j",
                                      size_mm=(6, 6, 6), density_threshold=threshold,
                                      density_scale=0.02))
    whole = _general_and_fused(ctx, src, leaf_grid_colour_slab_labels)
    assert len(np.unique(whole[0])) > 2                      # several materials, not uniform


@pytest.mark.parametrize("channels", [1, 3])
def test_densified_values_equal_the_sparse_sampler(channels):
    """leaf_grid_values (OpenVDB sample_slab's grids, colour ones included) gives
    sample_sparse's values bit for bit, every channel."""
    from dreamprint_gui.io.volumes.base import voxel_centres
    from dreamprint_gui.io.volumes.sampling import sample_sparse
    from dreamprint_gui.io.volumes.vdb.leaf_grid import index_axis, leaf_grid_values

    b1 = _random_blocks(seed=11)
    values = np.concatenate([b1.values * (c + 1) for c in range(channels)], axis=-1)
    values[..., -1][values[..., -1] < 0.5] = 0.0
    blocks = SparseBlocks(b1.origins, values, np.zeros(channels, np.float32))
    src = _Blocks(blocks)
    grid = grid_for_source(src, (0.21, 0.13, 0.17), size_mm=(15, 15, 15))
    u = [(voxel_centres(grid, a) - 0.3) / 0.5 for a in range(3)]
    want = sample_sparse(blocks, u[2], u[1], u[0])
    dense, lo, rows = densify(blocks.origins, blocks.values, blocks.background, channels=True)
    k0, wk = index_axis(u[2], lo[2])
    j0, wj = index_axis(u[1], lo[1])
    i0, wi = index_axis(u[0], lo[0])
    got = np.full(want.shape, 9.0, np.float32)
    leaf_grid_values(dense, rows, k0, wk, j0, wj, i0, wi,
                     np.empty((channels, dense.shape[2]), np.float32), got)
    assert (want > 0).any() and np.isnan(want).any()
    np.testing.assert_array_equal(got.view(np.uint32), want.view(np.uint32))


@pytest.mark.parametrize("threshold", [0.0, 0.6])
def test_colour_where_labelled_equals_every_value(threshold):
    """leaf_grid_values_where gives leaf_grid_values' bits over each row's span of voxels whose
    density reaches the threshold (rows with and without source data, columns outside the
    grid, NaN and -0.0 among the values) and leaves every other voxel as it was."""
    from dreamprint_gui.io.volumes.base import voxel_centres
    from dreamprint_gui.io.volumes.vdb.leaf_grid import (
        index_axis,
        leaf_grid_values,
        leaf_grid_values_where,
    )

    b1 = _random_blocks(seed=13)
    blocks = SparseBlocks(b1.origins, np.concatenate([b1.values, -b1.values, b1.values * 3],
                                                     axis=-1), np.zeros(3, np.float32))
    dense, lo, rows = densify(blocks.origins, blocks.values, blocks.background, channels=True)
    src = _Blocks(blocks)
    grid = grid_for_source(src, (0.21, 0.13, 0.17), size_mm=(15, 15, 15))
    # the print's box reaches past the grid's on every side: corners outside it
    u = [(voxel_centres(grid, a) - 0.3) / 0.5 * 1.2 - 2.0 for a in range(3)]
    k0, wk = index_axis(u[2], lo[2])
    j0, wj = index_axis(u[1], lo[1])
    i0, wi = index_axis(u[0], lo[0])
    nz, ny, nx = len(k0), len(j0), len(i0)
    want = np.empty((nz, ny, nx, 3), np.float32)
    leaf_grid_values(dense, rows, k0, wk, j0, wj, i0, wi,
                     np.empty((3, dense.shape[2]), np.float32), want)
    rng = np.random.default_rng(4)
    dens = rng.uniform(0.0, 1.0, (nz, ny, nx)).astype(np.float32)
    dens[rng.random(dens.shape) < 0.5] = 0.0
    dens[:, ::3] = np.nan                                   # rows without foreground
    dens.reshape(-1)[rng.integers(0, dens.size, 500)] = np.nan
    plane = np.empty(3 * dense.shape[2], np.float32)
    gaps = 0
    for k in range(nz):
        got = np.full((ny, nx, 3), 7.0, np.float32)
        leaf_grid_values_where(dense, rows, k0[k], wk[k], j0, wj, i0, wi, plane,
                               got.reshape(-1), dens[k].reshape(-1), np.float32(threshold))
        fg = dens[k] >= threshold
        # each row from its first to its last foreground voxel
        span = np.maximum.accumulate(fg, axis=1) & np.maximum.accumulate(fg[:, ::-1],
                                                                         axis=1)[:, ::-1]
        np.testing.assert_array_equal(got[span].view(np.uint32), want[k][span].view(np.uint32))
        assert (got[~span] == 7.0).all() and (~span).any()
        gaps += np.count_nonzero(span & ~fg)
    assert gaps > 0                                         # spans hold background voxels
    assert (want != 0).any() and np.isnan(want).any()


def test_coloured_vdb_samples_the_same_through_dense_copies(vdbs, monkeypatch):
    """A VDB with a colour grid samples the same with its grids densified as from the leaves."""
    from dreamprint_gui.io.volumes.vdb import openvdb

    for name in ("box_half_cd", "box_rgb3"):
        s = open_source(vdbs / f"{name}.vdb")
        g = grid_for_source(s, (0.13, 0.07, 0.11), size_mm=(5, 5, 5))
        rgb, d = s.sample_slab(g, 0, g.shape_xyz[2])
        assert s.density._dense is not None
        monkeypatch.setattr(openvdb, "DENSE_BUDGET", 0)
        s2 = open_source(vdbs / f"{name}.vdb")
        rgb2, d2 = s2.sample_slab(g, 0, g.shape_xyz[2])
        assert s2.density._dense is None
        monkeypatch.undo()
        np.testing.assert_array_equal(rgb.view(np.uint32), rgb2.view(np.uint32))
        np.testing.assert_array_equal(d.view(np.uint32), d2.view(np.uint32))
