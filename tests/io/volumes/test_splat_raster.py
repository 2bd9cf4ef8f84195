"""The tiled splat rasteriser: exact 3-sigma support and values against a direct sum, and
bit-identical results whatever the slab boundaries or threads."""

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from dreamprint_gui.io.volumes import grid_for_source
from dreamprint_gui.io.volumes.base import voxel_centres
from dreamprint_gui.io.volumes.splat_raster import SCAN_X
from dreamprint_gui.io.volumes.splats import GaussianCloud, peak_density


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


def test_bit_identical_across_slab_boundaries_and_threads():
    s = GaussianCloud("c", "t", *_cloud(60, 5), bounds=((-1, -1, -1), (1, 1, 1)))
    g = grid_for_source(s, (0.01, 0.03, 0.01), size_mm=(2, 2, 2))   # 200 x 67 x 200
    nz = g.shape_xyz[2]
    whole = s.sample_slab(g, 0, nz)
    for size in (1, 7, 13):
        parts = [s.sample_slab(g, z, min(z + size, nz)) for z in range(0, nz, size)]
        for i in range(2):
            assert np.array_equal(np.concatenate([p[i] for p in parts]), whole[i])
    with ThreadPoolExecutor(2) as ex:
        parts = list(ex.map(lambda z: s.sample_slab(g, z, min(z + 50, nz)), range(0, nz, 50)))
    for i in range(2):
        assert np.array_equal(np.concatenate([p[i] for p in parts]), whole[i])
