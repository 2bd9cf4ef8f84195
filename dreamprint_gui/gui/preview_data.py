"""What the preview shows, computed by the engine on a coarse grid (no Qt here).

Defines :class:`PreviewData` and :func:`compute_preview`: the source sampled on a downsampled,
isotropic grid of the operator's physical size (``VolumeSource.sample_slab``), and the predicted
print of the same voxels after table lookup and density alignment
(``gamut.predicted_appearance``), both as sRGB colour and density in 1/mm, plus
:func:`opacity_per_voxel` (Beer-Lambert: alpha = 1 - exp(-sigma * voxel size)), which is how the
volume view turns densities into per-voxel opacity.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["PreviewData", "compute_preview", "opacity_per_voxel", "PREVIEW_VOXELS"]

PREVIEW_VOXELS = 96  # voxels along the longest axis of the preview grid (interaction stays smooth)


@dataclass
class PreviewData:
    """Source and predicted print on the same preview grid; arrays are (z, y, x[, 3])."""

    source_rgb: NDArray[np.float32]
    source_sigma: NDArray[np.float32]  # 1/mm
    print_rgb: NDArray[np.float32]
    print_sigma: NDArray[np.float32]  # 1/mm
    voxel_mm: float  # isotropic preview voxel edge
    size_mm: tuple[float, float, float]  # physical size x, y, z
    print_shape_xyz: tuple[int, int, int] | None  # the printer grid it stands for
    background: str  # "clear" | "empty"

    @property
    def shape_xyz(self) -> tuple[int, int, int]:
        z, y, x = self.source_sigma.shape
        return (x, y, z)

    def downsample_note(self) -> str:
        nx, ny, nz = self.shape_xyz
        text = f"preview grid {nx} x {ny} x {nz} voxels of {self.voxel_mm * 1000:.0f} um"
        if self.print_shape_xyz is not None:
            px, py, pz = self.print_shape_xyz
            factor = (px * py * pz) / max(1, nx * ny * nz)
            if factor > 1:
                text += (f" (downsampled from the print's {px} x {py} x {pz} voxels, "
                         f"1:{factor:,.0f})")
        return text


def opacity_per_voxel(sigma_per_mm: NDArray, voxel_mm: float) -> NDArray[np.float32]:
    """Opacity of one voxel of edge ``voxel_mm`` in a medium of density sigma (Beer-Lambert)."""
    s = np.clip(np.asarray(sigma_per_mm, dtype=np.float64), 0.0, None)
    return (-np.expm1(-s * voxel_mm)).astype(np.float32)


def preview_voxel_mm(bounds: tuple[tuple[float, float, float], tuple[float, float, float]],
                     height_mm: float, n: int = PREVIEW_VOXELS) -> float:
    """Isotropic voxel edge giving ``n`` voxels along the longest physical axis."""
    lo, hi = np.asarray(bounds[0], float), np.asarray(bounds[1], float)
    ext = hi - lo
    if not (ext[2] > 0 and math.isfinite(ext[2])):
        raise ValueError("the source has no height")
    size = ext * (height_mm / ext[2])
    return float(size.max() / n)


def compute_preview(source, profile, tables, *, height_mm: float, density_scale: float = 1.0,
                    background: str = "clear", printer=None,
                    density_threshold: float | None = None,
                    n: int = PREVIEW_VOXELS) -> PreviewData:
    """Sample ``source`` on a coarse grid and predict the print (engine calls only).

    ``background``: voxels whose source density is below ``density_threshold`` become Clear
    (``"clear"``, whatever the alignment predicts for a zero target) or nothing (``"empty"``),
    as the job pipeline does.
    """
    from ..engine import gamut
    from ..io.volumes import grid_for_source

    v = preview_voxel_mm(source.bounds, height_mm, n)
    grid = grid_for_source(source, (v, v, v), height_mm=height_mm)
    nx, ny, nz = grid.shape_xyz
    rgb, sigma = source.sample_slab(grid, 0, nz, density_scale=density_scale)
    rgb = np.asarray(rgb, dtype=np.float32)
    sigma = np.asarray(sigma, dtype=np.float32)
    p_rgb, p_sigma = gamut.predicted_appearance(tables, profile, rgb, sigma)
    p_rgb = np.clip(np.asarray(p_rgb, dtype=np.float32), 0.0, 1.0)
    p_sigma = np.asarray(p_sigma, dtype=np.float32).copy()
    if background == "empty" and density_threshold is not None:
        p_sigma[sigma < density_threshold] = 0.0
    print_shape = None
    if printer is not None:
        pgrid = grid_for_source(source, tuple(printer.voxel_mm), height_mm=height_mm)
        print_shape = tuple(int(s) for s in pgrid.shape_xyz)
    return PreviewData(rgb, sigma, p_rgb, p_sigma, v,
                       (nx * v, ny * v, nz * v), print_shape, background)
