"""The built-in procedural source ``open_source("demo")``: a small planet, worth printing.

Defines :class:`DemoCloud` and :func:`demo_fields`. The scene shows what a volumetric print
does best, and prints at the default size (40 mm high) with no pre-flight warning:

* **a dense planet** (reads as solid: optical depth ~45 across its diameter) whose surface
  runs once round the printable hue circle by longitude, in latitude bands alternating with
  their tints (a colour half-way to the printable white), band edges ~4 mm apart along a
  meridian at 40 mm;
* **a translucent tilted ring** round it (about 1/mm: the planet shows through it), its hue
  running the other way round;
* **a soft haze** of seeded Gaussian wisps above it (up to 0.5/mm), pale blue and white.

Every colour is one the built-in inks print (the palette is the printed colour of the sRGB hue
circle: ``tests/io/volumes/test_demo.py`` checks that each lies within 1 dE2000 of what the
built-in inks print, by the gamut's direct solve), and each part's density stays at or below
about half the densest its colour can print (White, the lightest, 3.5/mm). Pre-flight
(measured): no warning at 30-40 mm; at 20 mm the planet doubles to 4/mm and 1.4 % of the
printed voxels clamp; from 60 mm the job is over 98 % Clear or empty (the density rule keeps
the optical depth, not the ink share).
Densities are set for a print :data:`DESIGN_HEIGHT_MM` high: the density rule
(``sigma [1/mm] = source density / mm per source unit``) thins them on a larger print and
thickens them on a smaller one, so the look (optical depth) is the same at every size.

The fields are evaluated once per process (about 0.3 s, memoised) on a cell-centred
``resolution``^3 grid (default 128^3, 34 MB) that is sampled trilinearly like any dense source.
Density is 0 outside a sphere of radius 0.45 around the cube's centre; bounds are [0, 1]^3.
"""

from __future__ import annotations

import functools

import numpy as np

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.print_size import DEMO_HEIGHT_MM
from dreamprint_gui.io.volumes.dense import DenseSource, DenseVolume
from dreamprint_gui.io.volumes.sampling import rasterise_gaussians
from dreamprint_gui.io.volumes.splats.cloud import GaussianCloud

__all__ = ["DemoCloud", "demo_fields", "demo_colours", "occupied_height", "PALETTE",
           "PRINTABLE_WHITE", "DESIGN_HEIGHT_MM"]

DESIGN_HEIGHT_MM = DEMO_HEIGHT_MM

# The hue circle the demo runs round: the printed colour (sRGB) of the fully saturated sRGB hues
# at 30-degree steps (red, orange, yellow, ..., rose) as the built-in profile's 100^3 de2000
# table prints them (the most saturated colours the inks reach at each hue), then a fifth of
# the way to their own grey, so that a coarse table, or an operator's own inks, print them too.
_HUE_EDGE = np.array([
    (0.701, 0.358, 0.250), (0.747, 0.499, 0.264), (0.767, 0.789, 0.210),
    (0.664, 0.783, 0.352), (0.600, 0.767, 0.370), (0.556, 0.770, 0.487),
    (0.517, 0.776, 0.768), (0.295, 0.518, 0.759), (0.243, 0.258, 0.550),
    (0.420, 0.304, 0.589), (0.752, 0.412, 0.668), (0.722, 0.358, 0.494),
])
PALETTE = (0.8 * _HUE_EDGE + 0.2 * _HUE_EDGE.mean(axis=1, keepdims=True)).astype(np.float32)
PRINTABLE_WHITE = np.array((0.767, 0.806, 0.820), np.float32)  # the W ink, optically thick

# Extinction of each part at DESIGN_HEIGHT_MM, 1/mm (the palette's densest printable: 4.7-15,
# White 3.5; lookup --density shows it per colour)
PLANET_PER_MM = 2.0
RING_PER_MM = 0.9
HAZE_PEAK_PER_MM = 0.5

CENTRE = np.array((0.5, 0.5, 0.43))      # the planet's centre (x, y, z)
PLANET_RADIUS = 0.19
RING_RADII = (0.27, 0.37)                # inner and outer radius of the ring, in its plane
RING_HALF_THICKNESS = 0.022
RING_TILT = np.radians(22.0)             # about x
BANDS = 9                                # latitude bands from pole to pole


def _hue(angle: np.ndarray) -> np.ndarray:
    """The palette's colour at ``angle`` (radians) round the hue circle, linear between steps."""
    t = (np.mod(angle, np.float32(2 * np.pi)) * np.float32(len(PALETTE) / (2 * np.pi)))
    i = np.floor(t).astype(np.int64) % len(PALETTE)
    f = (t - np.floor(t))[..., None]
    return (1 - f) * PALETTE[i] + f * PALETTE[(i + 1) % len(PALETTE)]


def _edge(distance_inside: np.ndarray, width: float) -> np.ndarray:
    """0 outside, 1 deeper than ``width`` inside, smooth between (no aliased steps)."""
    t = np.clip(distance_inside / width + 0.5, 0.0, 1.0)
    return t * t * (3 - 2 * t)


def _haze(seed: int) -> GaussianCloud:
    """Seeded wisps over the planet's north pole, drifting to one side."""
    rng = np.random.default_rng(int(seed))
    n = 60
    s = rng.random(n)
    means = np.stack([0.42 + 0.22 * s + rng.normal(0, 0.03, n),
                      0.5 + rng.normal(0, 0.05, n),
                      0.66 + 0.16 * s + rng.normal(0, 0.02, n)], axis=1)
    sigmas = rng.uniform(0.015, 0.035, size=(n, 3))
    tint = rng.random(n)[:, None]
    rgb = tint * PRINTABLE_WHITE + (1 - tint) * PALETTE[7]   # white to the palette's azure
    return GaussianCloud("demo", "demo haze", means, sigmas, rng.normal(size=(n, 4)),
                         np.ones(n), rgb, 0, bounds=((0.0,) * 3, (1.0,) * 3))


def demo_fields(resolution: int = 128, seed: int = 7) -> tuple[np.ndarray, np.ndarray]:
    """(extinction at DESIGN_HEIGHT_MM in 1/mm (n, n, n), sRGB colour (n, n, n, 3)), (z, y, x)."""
    n = int(resolution)
    c = (np.arange(n) + 0.5) / n
    g = _haze(seed)
    haze, haze_col = rasterise_gaussians(np.arange(len(g.mean)), g.mean, g.inv_cov, g.peak,
                                         g.rgb, g.half, c, c, c)
    haze_scale = HAZE_PEAK_PER_MM / (float(haze.max()) or 1.0)
    sigma = np.empty((n, n, n), np.float32)
    rgb = np.empty((n, n, n, 3), np.float32)
    y, x = np.meshgrid(c.astype(np.float32), c.astype(np.float32), indexing="ij")
    dx, dy = x - CENTRE[0], y - CENTRE[1]
    longitude = np.arctan2(dy, dx)
    ct, st = np.float32(np.cos(RING_TILT)), np.float32(np.sin(RING_TILT))
    for k in range(n):  # a layer at a time: the arrays stay in cache (0.3 s for 128^3)
        dz = np.float32(c[k] - CENTRE[2])
        # the planet: hue by longitude, tints in every other latitude band
        r = np.sqrt(dx * dx + dy * dy + dz * dz)
        planet = PLANET_PER_MM * _edge(PLANET_RADIUS - r, 1.5 / n)
        lat = np.arcsin(np.clip(dz / np.maximum(r, 1e-9), -1, 1))
        band = np.floor((lat / np.pi + 0.5) * BANDS).astype(np.int64)
        tint = np.where(band % 2 == 1, np.float32(0.5), np.float32(0.0))[..., None]
        planet_rgb = (1 - tint) * _hue(longitude) + tint * PRINTABLE_WHITE
        # the ring, in a plane tilted about x: (dx, v) in the plane, w across it
        v, w = ct * dy + st * dz, -st * dy + ct * dz
        rho = np.sqrt(dx * dx + v * v)
        inside = np.minimum(np.minimum(rho - RING_RADII[0], RING_RADII[1] - rho),
                            RING_HALF_THICKNESS - np.abs(w))
        ring = RING_PER_MM * _edge(inside, 1.5 / n)
        ring_rgb = _hue(np.pi / 3 - np.arctan2(v, dx))
        # the haze, scaled to its peak, none inside the planet
        h = np.where(r < PLANET_RADIUS + 2.0 / n, np.float32(0), haze[k] * np.float32(haze_scale))
        h_rgb = haze_col[k] / np.maximum(haze[k], 1e-12)[..., None]
        s = planet + ring + h
        weighted = planet[..., None] * planet_rgb + ring[..., None] * ring_rgb \
            + h[..., None] * h_rgb
        rgb[k] = np.clip(weighted / np.maximum(s, 1e-12)[..., None], 0.0, 1.0)
        s[(x - .5) ** 2 + (y - .5) ** 2 + (c[k] - .5) ** 2 > 0.45 ** 2] = 0.0
        sigma[k] = s
    return sigma, rgb


def demo_colours(count: int = 400) -> np.ndarray:
    """(count, 3) sRGB colours the demo holds: its occupied cells of a 32^3 evaluation, every
    k-th in z, y, x order (deterministic), for checks that want the demo's colours."""
    sigma, rgb = demo_fields(32)
    cols = rgb[sigma > 0.05].astype(np.float64)
    step = max(1, len(cols) // int(count))
    return cols[::step][:int(count)]


def occupied_height(sigma: np.ndarray) -> float:
    """The z extent (source units) of the non-empty cells: what --fit occupied prints."""
    n = sigma.shape[0]
    zs = np.nonzero(sigma.reshape(n, -1).max(axis=1) > 0)[0]
    return (zs[-1] - zs[0] + 1) / n


@functools.lru_cache(maxsize=2)
def _baked(seed: int, resolution: int) -> np.ndarray:
    """(n, n, n, 4) float32: density per source unit and density-premultiplied colour."""
    sigma, rgb = demo_fields(resolution, seed)
    # per source unit, for a print DESIGN_HEIGHT_MM high: sigma [1/mm] * mm per unit
    dens = sigma * np.float32(DESIGN_HEIGHT_MM / occupied_height(sigma))
    data = np.concatenate([dens[..., None], dens[..., None] * rgb], axis=3)
    data.flags.writeable = False  # shared by every DemoCloud of this process
    return data


class DemoCloud(DenseSource):
    """The demo planet (haze from seed ``seed``), evaluated on a ``resolution``^3 grid."""

    def __init__(self, seed: int = 7, resolution: int = 128):
        if not 8 <= int(resolution) <= 512:
            raise DreamPrintError(f"demo resolution must be 8..512, got {resolution}")
        n = int(resolution)
        vol = DenseVolume(_baked(int(seed), n), (0.5 / n,) * 3, (1.0 / n,) * 3,
                          cell_centred=True)
        super().__init__("demo", "demo (procedural planet)", vol, premultiplied=True)
        self.bounds = ((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))  # exactly, whatever the rounding

    def info(self) -> dict:
        n = self.volume.data.shape[0]
        return {"format": self.format, "grids": [{"name": "demo", "shape_zyx": [n, n, n],
                                                  "baked_from": "a planet, a ring and a haze"}]}
