"""The built-in procedural source ``open_source("demo")``: a deterministic coloured cloud.

Defines :class:`DemoCloud`: a few hundred soft anisotropic Gaussian blobs (seeded, so every
install sees the same cloud) inside the unit cube, colours varying smoothly with position,
evaluated analytically at any resolution by the splat rasteriser (no big arrays).  Density is
0 beyond the blobs' 3-sigma support, which stays inside a sphere of radius 0.45 around the cube
centre, so bounds are [0, 1]^3.
"""

from __future__ import annotations

import numpy as np

from ...errors import DreamPrintError
from .splats import GaussianCloud

__all__ = ["DemoCloud"]


class DemoCloud(GaussianCloud):
    """``n_blobs`` Gaussians from seed ``seed``; opacities 0.2-0.6, colours by position."""

    def __init__(self, n_blobs: int = 400, seed: int = 7):
        if not 1 <= int(n_blobs) <= 100_000:
            raise DreamPrintError(f"demo blob count must be 1..100000, got {n_blobs}")
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
        super().__init__("demo", "demo (procedural cloud)", means, sigmas, quats, opacity, rgb,
                         0, bounds=((0.0, 0.0, 0.0), (1.0, 1.0, 1.0)))
