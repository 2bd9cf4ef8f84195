"""The separable dense sampler against closed forms: trilinear interpolation reproduces any
function linear in each axis exactly, and colour stored premultiplied comes back unchanged."""

import numpy as np
import pytest

from dreamprint_gui.io.volumes.sampling import sample_dense, sample_dense_density


def _grid(nz=7, ny=9, nx=11):
    z, y, x = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
    return z.astype(np.float64), y.astype(np.float64), x.astype(np.float64)


def test_trilinear_reproduces_multilinear_functions():
    z, y, x = _grid()

    def fn(zz, yy, xx):
        return 1.0 + 0.5 * xx - 0.25 * yy + 0.125 * zz + 0.03 * xx * yy * zz

    vol = np.stack([fn(z, y, x), 2.0 - 0.1 * x], axis=-1).astype(np.float32)
    rng = np.random.default_rng(1)
    uz = np.sort(rng.uniform(0, 6, 13))
    uy = np.sort(rng.uniform(0, 8, 17))   # finer than the source: rows share source rows
    ux = np.sort(rng.uniform(0, 10, 5))   # coarser than the source
    out = sample_dense(vol, uz, uy, ux, pad=0.0)
    Z, Y, X = np.meshgrid(uz, uy, ux, indexing="ij")
    np.testing.assert_allclose(out[..., 0], fn(Z, Y, X), rtol=2e-6, atol=2e-6)
    np.testing.assert_allclose(out[..., 1], 2.0 - 0.1 * X, rtol=2e-6, atol=2e-6)


def test_outside_and_padding():
    vol = np.ones((4, 4, 4, 1), np.float32)
    u = np.array([-1.0, -0.5, 0.0, 3.0, 3.5, 4.0])
    cell = sample_dense(vol, u, u, u, pad=0.5)[..., 0]
    valid = np.array([False, True, True, True, True, False])
    np.testing.assert_array_equal(cell, np.einsum("i,j,k->ijk", valid, valid, valid) * 1.0)
    point = sample_dense(vol, u, u, u, pad=0.0)[..., 0]
    v0 = np.array([False, False, True, True, False, False])
    np.testing.assert_array_equal(point, np.einsum("i,j,k->ijk", v0, v0, v0) * 1.0)


def test_density_and_premultiplied_colour():
    z, y, x = _grid()
    dens = np.clip(x - 4.0, 0.0, None)                 # zero on the low-x side, linear beyond
    dens[:, 3, :] = 0.0                                # an empty source row
    colour = np.array([0.2, 0.5, 0.9])
    vol = np.concatenate([dens[..., None], dens[..., None] * colour], axis=-1)
    vol = vol.astype(np.float32)
    uz = np.linspace(0, 6, 5)
    uy = np.linspace(0, 8, 23)
    ux = np.linspace(0, 10, 31)
    rgb, sigma = sample_dense_density(vol, uz, uy, ux, pad=0.0, scale=3.0)
    ref = sample_dense(vol, uz, uy, ux, pad=0.0)
    np.testing.assert_allclose(sigma, 3.0 * np.maximum(ref[..., 0], 0), rtol=1e-6, atol=1e-7)
    pos = sigma > 0
    assert pos.any() and (~pos).any()
    np.testing.assert_allclose(rgb[pos], np.broadcast_to(colour, rgb[pos].shape), rtol=1e-5)
    assert not rgb[~pos].any()
    # one channel: density only, no colour
    rgb1, sigma1 = sample_dense_density(vol[..., :1].copy(), uz, uy, ux, pad=0.0, scale=3.0)
    assert rgb1 is None
    np.testing.assert_array_equal(sigma1, sigma)


def test_print_coarser_than_the_source_in_z_reads_only_the_layers_it_needs():
    z, y, x = _grid(nz=60, ny=5, nx=6)

    def fn(zz, yy, xx):
        return 3.0 + 0.02 * zz * yy - 0.1 * xx + 0.001 * zz * yy * xx

    vol = fn(z, y, x)[..., None].astype(np.float32)
    uz = np.array([0.5, 13.25, 31.0, 58.9])            # four layers of 60, far apart
    uy = np.linspace(0, 4, 7)
    ux = np.linspace(0, 5, 9)
    rgb, sigma = sample_dense_density(vol, uz, uy, ux, pad=0.0, scale=1.0)
    Z, Y, X = np.meshgrid(uz, uy, ux, indexing="ij")
    np.testing.assert_allclose(sigma, fn(Z, Y, X), rtol=2e-6)


def test_rows_without_data_are_skipped_bit_for_bit():
    """A source row of +0.0 only is zeros without interpolating it; rows holding -0.0 or NaN
    count as data, so skipping changes no bit of density or colour."""
    from dreamprint_gui.io.volumes.base import SlabBuffers
    from dreamprint_gui.io.volumes.sampling import rows_with_data

    rng = np.random.default_rng(7)
    vol = rng.uniform(0.0, 2.0, (6, 8, 9, 4)).astype(np.float32)
    vol[..., 1:] *= vol[..., :1]
    vol[:, 2:5] = 0.0
    vol[1, 3, 4, 0] = -0.0
    vol[4, 2, 0, 2] = np.nan
    vol[0] = 0.0
    rows = rows_with_data(vol)
    assert rows[1, 3] and rows[4, 2] and not rows[0].any() and not rows[2, 2]
    assert rows.sum() == 5 * 5 + 2
    uz, uy, ux = np.linspace(-0.4, 5.4, 11), np.linspace(-0.4, 7.4, 15), np.linspace(0, 8, 6)
    every = np.ones(vol.shape[:2], np.bool_)
    a = sample_dense(vol, uz, uy, ux, 0.5)
    b = sample_dense(vol, uz, uy, ux, 0.5, every)
    np.testing.assert_array_equal(a.view(np.uint32), b.view(np.uint32))
    for out in (None, SlabBuffers(), SlabBuffers(colour_where_dense=True)):
        rgb, d = sample_dense_density(vol, uz, uy, ux, 0.5, 2.0, out)
        d, rgb = d.copy(), rgb.copy()
        rgb2, d2 = sample_dense_density(vol, uz, uy, ux, 0.5, 2.0, None, every)
        np.testing.assert_array_equal(d.view(np.uint32), d2.view(np.uint32))
        dense = d > 0
        np.testing.assert_array_equal(rgb[dense].view(np.uint32), rgb2[dense].view(np.uint32))


@pytest.mark.parametrize("nz", [1, 4, 40])
def test_a_layer_is_the_same_whatever_else_the_call_samples(nz):
    """The sampler keeps two planes of x-interpolated source rows and reuses them across the
    layers of a call: any order and grouping of output layers gives the same bits as sampling
    each layer alone (coarser and finer than the source, repeated and descending layers)."""
    rng = np.random.default_rng(nz)
    vol = rng.uniform(-1.0, 3.0, (nz, 9, 10, 4)).astype(np.float32)
    vol[:, 4] = 0.0
    vol.reshape(-1)[rng.integers(0, vol.size, 20)] = np.nan
    uz = np.concatenate([np.linspace(-0.6, nz - 0.4, 23), rng.uniform(-1, nz, 9),
                         [nz - 1.0, 0.0, 0.0, nz - 1.0]])
    uy, ux = np.linspace(-0.4, 8.4, 13), np.linspace(-0.5, 9.5, 7)
    whole = sample_dense(vol, uz, uy, ux, 0.5)
    rgb, sigma = sample_dense_density(vol, uz, uy, ux, 0.5, 1.5)
    for k in range(len(uz)):
        one = sample_dense(vol, uz[k:k + 1], uy, ux, 0.5)
        np.testing.assert_array_equal(whole[k:k + 1].view(np.uint32), one.view(np.uint32))
        c1, s1 = sample_dense_density(vol, uz[k:k + 1], uy, ux, 0.5, 1.5)
        np.testing.assert_array_equal(sigma[k:k + 1].view(np.uint32), s1.view(np.uint32))
        np.testing.assert_array_equal(rgb[k:k + 1].view(np.uint32), c1.view(np.uint32))


@pytest.mark.parametrize("low", [2.0, -3.0])
def test_window_layer_equals_samples_then_window(low):
    """dense_window_layer (a scalar image's window in the sampler's row pass) gives the bits of
    sampling the layer (dense_layer, RAW) and then windowing it (dense.window_kernel's
    density), layers and rows outside the grid, empty source rows and NaN included."""
    from dreamprint_gui.io.volumes.dense import window_kernel
    from dreamprint_gui.io.volumes.dense_sampler import (
        RAW,
        DenseLayers,
        dense_layer,
        dense_window_layer,
        rows_with_data,
    )

    rng = np.random.default_rng(6)
    vol = rng.uniform(-5.0, 40.0, (6, 8, 9, 1)).astype(np.float32)
    vol[:, 3] = 0.0                                        # an empty source row per layer
    vol.reshape(-1)[rng.integers(0, vol.size, 3)] = np.nan
    uz = np.linspace(-1.0, 6.2, 15)                         # layers beyond the grid
    uy = np.linspace(-0.7, 7.9, 23)
    ux = np.linspace(-0.4, 8.6, 31)
    rows = rows_with_data(vol)
    lo, inv_w, dens = np.float32(low), np.float32(1 / 25.0), np.float32(0.37)
    a, b = DenseLayers(vol, uz, uy, ux, 0.5), DenseLayers(vol, uz, uy, ux, 0.5)
    nv = len(uy) * len(ux)
    for k in range(len(uz)):
        values = np.full(nv, 5.0, np.float32)
        want = np.full(nv, 9.0, np.float32)
        dense_layer(vol, rows, k, *a.args(), values, values, want, RAW, np.float32(1.0))
        window_kernel(values, lo, inv_w, np.ones((4, 3), np.float32), dens,
                       np.empty((nv, 3), np.float32), want)
        args = b.args()
        got = np.full(nv, 9.0, np.float32)
        dense_window_layer(vol, rows, k, *args[:-1], lo, inv_w, dens, got)
        np.testing.assert_array_equal(got.view(np.uint32), want.view(np.uint32))
