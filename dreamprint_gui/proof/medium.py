"""The printed object as a participating medium: labels -> block fractions -> sigma_t, albedo.

Defines
-------
- :class:`BlockMedium`: per coarse cell, the fraction of each label (C, M, Y, K, W, Cl, empty)
  among the print voxels of its block, with the block size in voxels, the cell size in mm and
  how many layers per block were read.
- :func:`block_fractions`: build it from a labels-per-layer function (a real job's slices or the
  engine's own labelling of a layer, :mod:`.labels`).
- :func:`medium_coefficients`: per cell and band, ``sigma_t`` and ``albedo`` of the mixture.
- :func:`background_fractions`: the same cells with the object taken out (every printed voxel
  the job's background: Clear in a Clear block, air without), what no ink in the object changes.

Method (the step between the halftoned labels and the renderer): a cell of ``bx x by x bz`` print
voxels holds label fractions f_m; KM K and S mix linearly in the fractions (paper eq. 5, the
same rule the tables use for concentrations), so the cell's coefficients are::

    K_cell = sum_m f_m K_m,  S_cell = sum_m f_m S_m   (empty voxels contribute 0)
    (sigma_a, sigma_s) = the conversion of (K_cell, S_cell) keeping a thick patch's KM
                         reading R_inf (:mod:`.km_to_rte`; Gate's K/2, 4S/3 at its limits)

Averaging inside a block replaces the voxel-scale ink pattern (tens of micrometres) by its mean;
the error of that against full-resolution labels is measured by
``benchmarks/bench_proof.py --block-error`` on a small job (the demo at 3 mm, 96 px, 64 spp,
dE2000 over the object against the render of one cell per printer voxel): another seed of the
full-resolution render (the noise floor) 4.66 mean / 12.3 p95; blocks of 2 x 6 x 11 voxels
(0.17 mm) 5.69 / 13.6; 4 x 11 x 22 (0.31 mm, the 40 mm default) 7.06 / 16.0; the same reading 2
layers per block (the default) 7.95 / 17.6. On a 3 mm object a 0.3 mm cell is a tenth of it;
the error shrinks as the print grows relative to the cell (``--cells`` sets the count).
Of each block's ``bz`` layers, ``layers_per_block`` evenly spaced ones are read (all in x and y):
a stratified sample whose fraction error is the halftone's local variance over the sampled
voxels (blue noise keeps it below i.i.d. sampling). ``layers_per_block = 0`` reads every layer.
Cells reaching beyond the print grid count the missing voxels as empty (air).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from dreamprint_gui.job.plan import JobCancelled
from dreamprint_gui.proof.km_to_rte import MAP_GEOMETRY, rte_coefficients
from dreamprint_gui.proof.optics import Optics

__all__ = ["BlockMedium", "block_fractions", "medium_coefficients", "block_for_cell",
           "background_fractions", "cell_counts", "N_LABELS", "EMPTY", "CLEAR"]

N_LABELS = 7
EMPTY = 6
CLEAR = 5  # INKS order: C, M, Y, K, W, Cl


@dataclass(frozen=True)
class BlockMedium:
    fractions: NDArray[np.float32]          # (ncz, ncy, ncx, 7)
    block_xyz: tuple[int, int, int]         # print voxels per cell along x, y, z
    voxel_mm: tuple[float, float, float]
    grid_shape_xyz: tuple[int, int, int]    # the print grid's voxels
    layers_read: int

    @property
    def cell_mm(self) -> tuple[float, float, float]:
        return tuple(b * v for b, v in zip(self.block_xyz, self.voxel_mm, strict=True))

    @property
    def cells_xyz(self) -> tuple[int, int, int]:
        ncz, ncy, ncx = self.fractions.shape[:3]
        return (ncx, ncy, ncz)

    @property
    def print_size_mm(self) -> tuple[float, float, float]:
        return tuple(n * v for n, v in zip(self.grid_shape_xyz, self.voxel_mm, strict=True))

    @property
    def box_mm(self) -> tuple[NDArray, NDArray]:
        """(lo, hi) of the cells in the proof's world (mm, the print grid centred on 0)."""
        lo = -0.5 * np.asarray(self.print_size_mm)
        return lo, lo + np.asarray(self.cells_xyz) * np.asarray(self.cell_mm)

    def describe(self) -> dict:
        return {"block_voxels_xyz": list(self.block_xyz),
                "cell_mm": [round(c, 4) for c in self.cell_mm],
                "cells_xyz": list(self.cells_xyz), "layers_read": self.layers_read,
                "layers_total": self.grid_shape_xyz[2]}


def block_for_cell(voxel_mm: tuple[float, float, float], size_mm: tuple[float, float, float],
                   max_cells: int) -> tuple[int, int, int]:
    """Block (voxels per cell, x y z) giving about ``max_cells`` cells on the longest axis,
    cells as near cubic as the voxel allows."""
    cell = max(size_mm) / max(1, int(max_cells))
    cell = max(cell, max(voxel_mm))
    return tuple(max(1, int(round(cell / v))) for v in voxel_mm)


def cell_counts(shape_xyz: tuple[int, int, int], block_xyz: tuple[int, int, int]
                ) -> tuple[int, int, int]:
    """Cells (x, y, z) of blocks of ``block_xyz`` voxels covering a print grid of ``shape_xyz``
    voxels (the last block along an axis may reach beyond the grid)."""
    return tuple(-(-int(n) // int(b)) for n, b in zip(shape_xyz, block_xyz, strict=True))


def _layer_counts(lab: NDArray[np.uint8], block_xy: tuple[int, int], ncx: int, ncy: int,
                  out: NDArray[np.float64]) -> None:
    """Add the per-cell label counts of one layer (ny, nx) to ``out`` (ncy, ncx, 7)."""
    bx, by = block_xy
    ny, nx = lab.shape
    padded = np.full((ncy * by, ncx * bx), EMPTY, np.uint8)
    padded[:ny, :nx] = lab
    cells = padded.reshape(ncy, by, ncx, bx)
    for m in range(N_LABELS):
        out[..., m] += np.count_nonzero(cells == m, axis=(1, 3))


def block_fractions(layer_labels: Callable[[int], NDArray[np.uint8]],
                    shape_xyz: tuple[int, int, int], voxel_mm: tuple[float, float, float],
                    block_xyz: tuple[int, int, int], layers_per_block: int = 4,
                    progress: Callable[[int, int], None] | None = None,
                    cancelled: Callable[[], bool] | None = None) -> BlockMedium:
    """Label fractions per cell from ``layer_labels(z) -> (ny, nx)`` labels (0..6).

    Reads ``layers_per_block`` evenly spaced layers of each block of ``block_xyz[2]`` layers
    (0: all). ``progress(done, total)`` is called per layer read; ``cancelled()`` is polled.
    """
    nx, ny, nz = (int(v) for v in shape_xyz)
    bx, by, bz = (int(v) for v in block_xyz)
    ncx, ncy, ncz = cell_counts(shape_xyz, block_xyz)
    chosen: list[list[int]] = []
    for kz in range(ncz):
        z0 = kz * bz
        if layers_per_block <= 0 or layers_per_block >= bz:
            zs = list(range(z0, z0 + bz))
        else:
            zs = [z0 + int((i + 0.5) * bz / layers_per_block) for i in range(layers_per_block)]
        chosen.append(zs)
    total = sum(len(zs) for zs in chosen)
    frac = np.zeros((ncz, ncy, ncx, N_LABELS), np.float64)
    done = 0
    for kz, zs in enumerate(chosen):
        acc = np.zeros((ncy, ncx, N_LABELS), np.float64)
        for z in zs:
            if cancelled is not None and cancelled():

                raise JobCancelled("the proof was cancelled")
            if z < nz:
                _layer_counts(np.asarray(layer_labels(z)), (bx, by), ncx, ncy, acc)
            else:  # beyond the print's top: air
                acc[..., EMPTY] += bx * by
            done += 1
            if progress is not None:
                progress(done, total)
        frac[kz] = acc / (len(zs) * bx * by)
    return BlockMedium(frac.astype(np.float32), (bx, by, bz), tuple(voxel_mm),
                       (nx, ny, nz), total)


def medium_coefficients(fractions: NDArray, K_bands: NDArray, S_bands: NDArray,
                        optics: Optics | float = 0.0, geometry: str = MAP_GEOMETRY
                        ) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """``(sigma_t, albedo)`` (..., n_bands) float32 of cells with label ``fractions`` (..., 7).

    ``K_bands``, ``S_bands``: (6, n_bands) per ink (INKS order) in 1/mm. Empty is vacuum.
    ``optics``: the proof's surface and phase function (or a phase asymmetry g without a
    surface) and ``geometry`` the instrument the K and S were read with: the conversion keeps
    a thick patch of the mixture reading KM's R_inf (:func:`.km_to_rte.rte_coefficients`).
    """
    f = np.asarray(fractions, np.float64)[..., :6]
    K = f @ np.asarray(K_bands, np.float64)
    S = f @ np.asarray(S_bands, np.float64)
    sa, ss = rte_coefficients(K, S, optics, geometry)
    st = sa + ss
    albedo = np.divide(ss, st, out=np.zeros_like(st), where=st > 0)
    return st.astype(np.float32), albedo.astype(np.float32)


def background_fractions(fractions: NDArray, background: str) -> NDArray[np.float32]:
    """Label ``fractions`` (..., 7) of cells with the object taken out: every printed voxel
    is the job's background, pure Clear for ``background`` "clear" (the Clear block fills the
    print's box), air for "empty"; a cell's air (beyond the print grid) stays air.

    The medium of the print when every voxel of the object has fallen below the background
    threshold: its direct transmittance is the floor no density factor inside the object goes
    under."""
    f = np.asarray(fractions, np.float32)
    out = np.zeros_like(f)
    printed = 1.0 - f[..., EMPTY]
    if background == "clear":
        out[..., CLEAR] = printed
        out[..., EMPTY] = f[..., EMPTY]
    elif background == "empty":
        out[..., EMPTY] = 1.0
    else:
        raise ValueError(f"background must be clear or empty, not {background!r}")
    return out
