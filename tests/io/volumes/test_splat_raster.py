"""The tiled splat rasteriser: exact 3-sigma support and values against a direct sum, and
bit-identical results whatever the slab boundaries, threads or workers; the walk and the
exact row-by-row path against closed forms and a direct evaluation."""

from concurrent.futures import ThreadPoolExecutor
from math import erf

import numpy as np
import pytest

from dreamprint_gui.io.volumes import grid_for_source
from dreamprint_gui.io.volumes.base import voxel_centres
from dreamprint_gui.io.volumes.splats.cloud import GaussianCloud, peak_density
from dreamprint_gui.io.volumes.splats.raster import (
    SCAN_X,
    TILE_X,
    TILE_Y,
    TILE_Z,
    rasterise_splats,
    tile_layers,
)


def _rot(q):
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _cloud(n=40, seed=3):
    rng = np.random.default_rng(seed)
    means = rng.uniform(-0.8, 0.8, (n, 3))
    sig = rng.uniform(0.03, 0.25, (n, 3))
    sig[: n // 4, 0] *= 0.05                    # strongly flattened kernels, as 3DGS makes
    quats = rng.normal(size=(n, 4))
    opac = rng.uniform(0.05, 0.95, n)
    rgb = rng.uniform(0, 1, (n, 3))
    return means, sig, quats, opac, rgb


def _direct(means, sig, quats, opac, rgb, g, cut):
    """Density and density-weighted colour summed Gaussian by Gaussian over every voxel."""
    zc, yc, xc = np.meshgrid(voxel_centres(g, 2), voxel_centres(g, 1), voxel_centres(g, 0),
                             indexing="ij")
    p = np.stack([xc, yc, zc], -1)
    peak = peak_density(opac, sig)
    dens = np.zeros(p.shape[:3])
    col = np.zeros(p.shape[:3] + (3,))
    for mu, s, q, pk, c in zip(means, sig, quats, peak, rgb, strict=True):
        r = _rot(q)
        inv = r @ np.diag(s ** -2.0) @ r.T
        d = p - mu
        m2 = np.einsum("...i,ij,...j->...", d, inv, d)
        w = np.where(m2 <= cut, pk * np.exp(-m2 / 2), 0.0)
        dens += w
        col += w[..., None] * c
    return dens, col


@pytest.mark.parametrize("voxel_x, scan", [(0.012, False), (0.15, True)])
def test_support_and_values_match_a_direct_sum(voxel_x, scan):
    cloud = _cloud()
    s = GaussianCloud("c", "t", *cloud, bounds=((-1, -1, -1), (1, 1, 1)))
    g = grid_for_source(s, (voxel_x, 0.04, 0.05), size_mm=(2, 2, 2))  # 167 (13) x 50 x 40
    rgb, d = s.sample_slab(g, 0, g.shape_xyz[2])
    # The rasteriser finds a row's run of voxels inside the ellipsoid by testing q along rows
    # of boxes at most SCAN_X voxels wide in x, by the closed-form interval in wider ones: the
    # fine grid has only wide boxes, the coarse one mostly narrow ones.
    width = 2 * s.half[:, 0] / voxel_x
    assert np.mean(width <= SCAN_X) > 0.5 if scan else np.all(width > SCAN_X)
    # the cut is q <= 9: voxels within rounding of the boundary may fall either side
    lo, _ = _direct(*cloud, g, 9.0 - 1e-9)
    hi, col = _direct(*cloud, g, 9.0 + 1e-9)
    assert np.all(d >= lo.astype(np.float32) * (1 - 1e-6))
    assert np.all(d <= hi.astype(np.float32) * (1 + 1e-6))
    np.testing.assert_allclose(d, hi, rtol=1e-6, atol=1e-7 * hi.max())
    assert np.array_equal(d > 0, hi > 0)
    inside = hi > 1e-3 * hi.max()
    np.testing.assert_allclose(rgb[inside], col[inside] / hi[inside][:, None], atol=2e-6)
    assert np.all(rgb[d == 0] == 0)


def test_gaussians_across_tile_boundaries_match_a_direct_sum():
    # A grid of 2.5 tiles along every axis, whatever the tile sizes (in z: tiles of 7, 7 and 6
    # layers, tile_layers): Gaussians whose boxes cross tile boundaries are walked from
    # their box's corner again in every tile they reach
    cloud = _cloud(40, 7)
    s = GaussianCloud("c", "t", *cloud, bounds=((-1, -1, -1), (1, 1, 1)))
    tiles = np.array([TILE_X, TILE_Y, TILE_Z]) * 2.5
    g = grid_for_source(s, tuple(2.0 / tiles), size_mm=(2, 2, 2))
    assert np.array_equal(g.shape_xyz, tiles.astype(int))
    pitch = 2.0 / tiles
    lo_v = np.floor((s.mean - s.half + 1) / pitch)
    hi_v = np.floor((s.mean + s.half + 1) / pitch)
    tz = tile_layers(int(g.shape_xyz[2]))
    assert tz == 7
    for axis, tile in enumerate((TILE_X, TILE_Y, tz)):
        assert np.sum(lo_v[:, axis] // tile != hi_v[:, axis] // tile) >= 5
    rgb, d = s.sample_slab(g, 0, g.shape_xyz[2])
    hi, col = _direct(*cloud, g, 9.0 + 1e-9)
    np.testing.assert_allclose(d, hi, rtol=1e-6, atol=1e-7 * hi.max())
    inside = hi > 1e-3 * hi.max()
    np.testing.assert_allclose(rgb[inside], col[inside] / hi[inside][:, None], atol=2e-6)


def test_bit_identical_across_slab_boundaries_and_threads():
    s = GaussianCloud("c", "t", *_cloud(60, 5), bounds=((-1, -1, -1), (1, 1, 1)))
    g = grid_for_source(s, (0.01, 0.03, 0.01), size_mm=(2, 2, 2))   # 200 x 67 x 200
    nz = g.shape_xyz[2]
    whole = s.sample_slab(g, 0, nz)
    for size in (1, 7, 9, 13, 16, 17):         # tiles of 1, 7, 5 + 4, 7 + 6, 8 + 8, 6 + 6 + 5
        parts = [s.sample_slab(g, z, min(z + size, nz)) for z in range(0, nz, size)]
        for i in range(2):
            assert np.array_equal(np.concatenate([p[i] for p in parts]), whole[i])
    with ThreadPoolExecutor(2) as ex:
        parts = list(ex.map(lambda z: s.sample_slab(g, z, min(z + 50, nz)), range(0, nz, 50)))
    for i in range(2):
        assert np.array_equal(np.concatenate([p[i] for p in parts]), whole[i])


def _raster(s, g, walk=True):
    """Density (scale 1: per source unit) and colour of a whole grid, by either path."""
    pitch = tuple(float(v) / g.mm_per_unit for v in g.voxel_mm)
    rgb, d = rasterise_splats(np.arange(len(s.mean)), s._packed, g.origin, pitch, g.shape_xyz,
                              0, g.shape_xyz[2], 1.0, walk=walk)
    return rgb, d, np.prod(pitch)


@pytest.mark.parametrize("walk", [True, False])
def test_one_gaussian_integral_and_peak_closed_form(walk):
    """A rotated Gaussian centred on a voxel: the peak voxel holds s, and the voxels' sum is
    its integral inside q <= 9, s (2 pi)^(3/2) sigma1 sigma2 sigma3 P(chi2_3 <= 9), with
    P(chi2_3 <= 9) = erf(3 / sqrt 2) - sqrt(2 / pi) 3 exp(-9/2)."""
    sig = np.array([[0.09, 0.05, 0.03]])
    q = np.array([[0.9, 0.3, -0.2, 0.25]])
    g0 = grid_for_source(GaussianCloud("c", "t", np.zeros((1, 3)), sig, q, [0.6], [[1, 0, 0]],
                                       bounds=((-0.5,) * 3, (0.5,) * 3)),
                         (0.01, 0.01, 0.01), size_mm=(1, 1, 1))
    # the mean on a voxel centre of the grid
    mean = np.array([[voxel_centres(g0, a)[50] for a in range(3)]])
    s = GaussianCloud("c", "t", mean, sig, q, [0.6], [[1, 0, 0]],
                      bounds=((-0.5,) * 3, (0.5,) * 3))
    rgb, d, dv = _raster(s, g0, walk)
    assert d[50, 50, 50] == pytest.approx(s.peak[0], rel=1e-7)
    inside = erf(3 / np.sqrt(2)) - np.sqrt(2 / np.pi) * 3 * np.exp(-4.5)
    integral = s.peak[0] * (2 * np.pi) ** 1.5 * np.prod(sig) * inside
    assert d.astype(np.float64).sum() * dv == pytest.approx(integral, rel=1e-3)  # 2e-4 here
    assert np.all(rgb[d > 0] == [1, 0, 0])


def _needles(n=24, seed=11):
    """Thin, strongly tilted Gaussians (axis ratios up to 60) and some round ones."""
    rng = np.random.default_rng(seed)
    means = rng.uniform(-0.6, 0.6, (n, 3))
    sig = rng.uniform(0.05, 0.3, (n, 3))
    sig[: n // 2, 0] = rng.uniform(0.005, 0.02, n // 2)      # needles and pancakes
    sig[: n // 3, 1] = rng.uniform(0.005, 0.02, n // 3)
    quats = rng.normal(size=(n, 4))
    return means, sig, quats, rng.uniform(0.1, 0.9, n), rng.uniform(0, 1, (n, 3))


@pytest.mark.parametrize("walk", [True, False])
def test_thin_tilted_gaussians_match_direct_evaluation(walk):
    """Needles tilted across the grid, walked where the walk stays in float64's range and
    rasterised row by row where it would not, against the direct sum Gaussian by Gaussian."""
    from dreamprint_gui.io.volumes.splats.raster import _setup

    cloud = _needles()
    s = GaussianCloud("c", "t", *cloud, bounds=((-1, -1, -1), (1, 1, 1)))
    g = grid_for_source(s, (0.02, 0.03, 0.025), size_mm=(2, 2, 2))    # 100 x 67 x 80
    rgb, d, _ = _raster(s, g, walk)
    pitch = np.array([float(v) / g.mm_per_unit for v in g.voxel_mm])
    box = np.empty((len(s.mean), 6), np.int64)
    state = np.empty((len(s.mean), 32))
    _setup(np.arange(len(s.mean)), s._packed, np.asarray(g.origin, float), pitch,
           np.asarray(g.shape_xyz, np.int64), 0, g.shape_xyz[2], walk, box, state)
    walked = state[:, 0] > 0
    assert (walked.sum() > len(walked) // 2 and not walked.all()) if walk else not walked.any()
    lo, _ = _direct(*cloud, g, 9.0 - 1e-9)
    hi, col = _direct(*cloud, g, 9.0 + 1e-9)
    assert g.mm_per_unit == 1.0                      # _raster's scale 1 is _direct's unit
    assert np.all(d >= lo.astype(np.float32) * (1 - 1e-6))
    assert np.all(d <= hi.astype(np.float32) * (1 + 1e-6))
    np.testing.assert_allclose(d, hi, rtol=1e-6, atol=1e-7 * hi.max())
    inside = hi > 1e-3 * hi.max()
    np.testing.assert_allclose(rgb[inside], col[inside] / hi[inside][:, None], atol=2e-6)


def test_splat_job_identical_with_one_or_two_workers(shared_data, tmp_path):
    """The INRIA sample converted with 1 worker and with 2 (other slab sizes): the same
    slices, byte for byte, and the same manifest figures."""
    import hashlib

    from dreamprint_gui.core.generators import drain
    from dreamprint_gui.job.plan import ConvertSettings
    from dreamprint_gui.job.run import run_conversion

    src = str(shared_data / "splats" / "inria3dgs_iter7000_sh3_9080.ply")
    out = {}
    for workers, slab in ((1, None), (2, 5)):
        job = tmp_path / f"J{workers}"
        gen = run_conversion(ConvertSettings(source=src, output=str(job), height_mm=3.0,
                                             table_size=17, seed=3, workers=workers,
                                             slab_layers=slab))
        m = drain(gen)
        h = hashlib.sha256()
        for f in sorted((job / "slices").iterdir()):
            h.update(f.read_bytes())
        out[workers] = (h.hexdigest(), m["voxel_counts"], m["mean_concentration"])
    assert out[1] == out[2]
    assert sum(out[1][1].values() if isinstance(out[1][1], dict) else out[1][1]) > 0


@pytest.mark.parametrize("walk", [True, False])
def test_accumulator_left_clean_and_channel_gaps_untouched(walk):
    """Slabs of 3-17 layers (tiles of unequal height, lanes past a tile's layers), Gaussians
    starting and ending inside tiles: each tile clears exactly the cells it touched (the
    accumulator is all zero after the slab), and no write lands in the 64 cells between two
    channels or outside the accumulator."""
    from dreamprint_gui.io.volumes.splats import raster as sr

    s = GaussianCloud("c", "t", *_needles(30, 4), bounds=((-1, -1, -1), (1, 1, 1)))
    g = grid_for_source(s, (0.01, 0.03, 0.02), size_mm=(2, 2, 2))    # 200 x 67 x 100
    pitch = np.array([float(v) / g.mm_per_unit for v in g.voxel_mm])
    shape = np.asarray(g.shape_xyz, np.int64)
    guard = 4096
    for z0, z1 in ((40, 43), (40, 49), (41, 54), (38, 55)):
        room = np.zeros(4 * sr._CHS + 2 * guard)
        flat = room[guard: guard + 4 * sr._CHS]
        gcol = np.zeros(TILE_Y * TILE_Z)
        rcol = np.zeros(TILE_Y * TILE_Z)
        rgb = np.zeros((z1 - z0, shape[1], shape[0], 3), np.float32)
        d = np.zeros((z1 - z0, shape[1], shape[0]), np.float32)
        sr._splat_kernel(np.arange(len(s.mean)), s._packed, np.asarray(g.origin, float), pitch,
                         shape, z0, z1, walk, 1.0, flat, gcol, rcol, rgb, d)
        assert np.count_nonzero(d) > 1000
        assert not room.any()
        expect = rasterise_splats(np.arange(len(s.mean)), s._packed, g.origin, pitch, shape,
                                  z0, z1, 1.0, walk=walk)
        assert np.array_equal(d, expect[1]) and np.array_equal(rgb, expect[0])
