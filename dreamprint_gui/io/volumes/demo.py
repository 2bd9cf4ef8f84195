"""The built-in procedural source ``open_source("demo")``: a deterministic coloured cloud.

Defines :class:`DemoCloud`: a few hundred soft anisotropic Gaussian blobs (seeded, so every
install sees the same cloud) inside the unit cube, colours varying smoothly with position.
The blobs are rasterised once per process (about 0.3 s, memoised) onto a cell-centred
``resolution``^3 grid (default 128^3, 34 MB) that is then sampled trilinearly like any dense
source: evaluating hundreds of Gaussians per printer voxel ran at ~1.5e7 voxels/s per core, the
baked grid at several times 1e8.  The demo *is* that baked grid: a pure function of (n_blobs,
seed, resolution), sampled with the same kernel as every dense volume.  Density is 0 beyond the
blobs' 3-sigma support, which stays inside a sphere of radius 0.45 around the cube centre, so
bounds are [0, 1]^3 and the outer cells are empty.
"""

from __future__ import annotations

import functools

import numpy as np

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes.dense import DenseSource, DenseVolume
from dreamprint_gui.io.volumes.sampling import rasterise_gaussians
from dreamprint_gui.io.volumes.splats import GaussianCloud

__all__ = ["DemoCloud", "demo_gaussians"]


def demo_gaussians(n_blobs: int = 400, seed: int = 7) -> GaussianCloud:
    """The demo's blobs as a Gaussian cloud (opacities 0.2-0.6, colours by position)."""
    rng = np.random.default_rng(int(seed))
    n = int(n_blobs)
    # centres uniformly in a ball of radius 0.3 around the cube centre
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    r = 0.3 * rng.random(n) ** (1 / 3)
    means = 0.5 + d * r[:, None]
    sigmas = rng.uniform(0.015, 0.05, size=(n, 3))      # 3 sigma <= 0.15: inside r 0.45
    quats = rng.normal(size=(n, 4))
    opacity = rng.uniform(0.2, 0.6, n)
    p = (means - 0.2) / 0.6
    rgb = np.clip(np.stack([0.2 + 0.8 * p[:, 0], 0.3 + 0.6 * p[:, 1] * (1 - p[:, 0]),
                            1.0 - 0.8 * p[:, 2]], axis=1), 0.0, 1.0)
    return GaussianCloud("demo", "demo (procedural cloud)", means, sigmas, quats, opacity, rgb,
                         0, bounds=((0.0, 0.0, 0.0), (1.0, 1.0, 1.0)))


@functools.lru_cache(maxsize=2)
def _baked(n_blobs: int, seed: int, resolution: int) -> np.ndarray:
    """(n, n, n, 4) float32: density and density-premultiplied colour at the cell centres."""
    g = demo_gaussians(n_blobs, seed)
    c = (np.arange(resolution) + 0.5) / resolution
    dens, col = rasterise_gaussians(np.arange(len(g.mean)), g.mean, g.inv_cov, g.peak, g.rgb,
                                    g.half, c, c, c)
    data = np.concatenate([dens[..., None], col], axis=3)
    data.flags.writeable = False  # shared by every DemoCloud of this process
    return data


class DemoCloud(DenseSource):
    """``n_blobs`` Gaussians from seed ``seed``, baked on a ``resolution``^3 grid."""

    def __init__(self, n_blobs: int = 400, seed: int = 7, resolution: int = 128):
        if not 1 <= int(n_blobs) <= 100_000:
            raise DreamPrintError(f"demo blob count must be 1..100000, got {n_blobs}")
        if not 8 <= int(resolution) <= 512:
            raise DreamPrintError(f"demo resolution must be 8..512, got {resolution}")
        n = int(resolution)
        vol = DenseVolume(_baked(int(n_blobs), int(seed), n), (0.5 / n,) * 3, (1.0 / n,) * 3,
                          cell_centred=True)
        super().__init__("demo", "demo (procedural cloud)", vol, premultiplied=True)
        self.bounds = ((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))  # exactly, whatever the rounding

    def info(self) -> dict:
        n = self.volume.data.shape[0]
        return {"format": self.format, "grids": [{"name": "demo", "shape_zyx": [n, n, n],
                                                  "baked_from": "Gaussian blobs"}]}
