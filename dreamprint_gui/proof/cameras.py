"""The proof's cameras: orthographic views orbiting the print, shared by both renderers.

Defines :class:`View` and :func:`orbit_views`. World units are mm with the print grid centred
on the origin, z up (the build direction). A view looks at the origin from azimuth ``az`` and
elevation ``el`` and frames a square of half-width ``half_mm`` (the bounding sphere of the
print, 2 % margin), so every view of a print shows it at the same scale.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["View", "orbit_views", "ELEVATION_DEG"]

ELEVATION_DEG = 20.0


@dataclass(frozen=True)
class View:
    azimuth_deg: float
    elevation_deg: float
    half_mm: float
    distance_mm: float

    @property
    def direction(self) -> NDArray[np.float64]:
        """Unit vector from the origin towards the camera."""
        a, e = math.radians(self.azimuth_deg), math.radians(self.elevation_deg)
        return np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])

    @property
    def eye(self) -> NDArray[np.float64]:
        return self.direction * self.distance_mm

    def basis(self) -> tuple[NDArray, NDArray, NDArray]:
        """(right, up, forward) unit vectors of the image (x to the right, y up)."""
        fwd = -self.direction
        right = np.cross(fwd, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right)
        up = np.cross(right, fwd)
        return right, up, fwd

    def rays(self, resolution: int, sub: int = 1) -> tuple[NDArray, NDArray]:
        """Ray origins (res*sub, res*sub, 3), rows from the top, and the common direction, for
        pixel sub-samples at ``(i + (k + 0.5) / sub) / res`` across the film."""
        right, up, fwd = self.basis()
        n = resolution * sub
        u = (np.arange(n) + 0.5) / n * 2.0 - 1.0
        xs = u * self.half_mm
        ys = -u * self.half_mm
        o = (self.eye[None, None, :] + xs[None, :, None] * right[None, None, :]
             + ys[:, None, None] * up[None, None, :])
        return o, fwd

    def pixel_rays(self, resolution: int, rows: NDArray, cols: NDArray, sub: int
                   ) -> NDArray[np.float64]:
        """Ray origins (len(rows), sub * sub, 3) of the pixels (``rows``, ``cols``) at ``sub x
        sub`` sub-samples each, placed as :meth:`rays` places them (direction: :meth:`rays`')."""
        right, up, _ = self.basis()
        k = (np.arange(sub) + 0.5) / sub
        cols = np.asarray(cols, np.float64)[:, None]
        rows = np.asarray(rows, np.float64)[:, None]
        xs = ((cols + k[None, :]) / resolution * 2.0 - 1.0) * self.half_mm       # (n, sub)
        ys = -((rows + k[None, :]) / resolution * 2.0 - 1.0) * self.half_mm
        o = (self.eye[None, None, None, :] + xs[:, None, :, None] * right
             + ys[:, :, None, None] * up)                                        # (n, sy, sx, 3)
        return o.reshape(len(rows), sub * sub, 3)

    def describe(self) -> dict:
        return {"azimuth_deg": self.azimuth_deg, "elevation_deg": self.elevation_deg,
                "half_width_mm": round(self.half_mm, 4), "projection": "orthographic"}


def orbit_views(size_mm: tuple[float, float, float], n: int,
                elevation_deg: float = ELEVATION_DEG) -> list[View]:
    """``n`` views evenly spaced in azimuth (from 30 degrees) at ``elevation_deg``."""
    radius = 0.5 * math.sqrt(sum(s * s for s in size_mm))
    half = 1.02 * radius
    return [View(30.0 + 360.0 * k / n, float(elevation_deg), half, 4.0 * radius + 1.0)
            for k in range(int(n))]
