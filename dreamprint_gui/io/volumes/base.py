"""The one interface every volume reader offers, and the printer grid.

Defines :class:`PrintGrid`, :func:`grid_for_source`, the :class:`VolumeSource` protocol,
:class:`SlabBuffers`, :func:`voxel_centres`, :func:`linear_to_srgb`. The registry of source
kinds (:func:`open_source`, :func:`sniff_format`, ``FORMATS``, ...) is :mod:`.registry`, which
imports the readers, which import this module; the registry's names are still reachable from
here (lazily, see :func:`__getattr__`) for older imports.

Conventions shared by every reader:

* Arrays are ordered (z, y, x) so a slab of layers is contiguous; z is the build direction.
  A reader's z is the printer's z; a job turns a source (``--up``, ``--rotate``) by wrapping
  it (:mod:`.orient`), so readers never see an axis swap.
* Voxel (i, j, k) of a :class:`PrintGrid` has its centre, in source units, at
  ``origin + ((i + .5) * vx, (j + .5) * vy, (k + .5) * vz) / mm_per_unit``.
* Density rule (every reader, every format)::

      sigma [1/mm] = source_density [1/source unit] * density_scale / mm_per_unit

  i.e. the source's extinction per source unit, rescaled to millimetres by the operator's
  physical size, times the operator's density scale.  Outside a source's bounds density is 0.
* Colour returned by ``sample_slab`` is always sRGB-encoded in [0, 1] (IEC 61966-2-1 transfer
  function); ``colour_encoding`` says what the file held ("srgb" or "linear").
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.print_size import check_print_size
from dreamprint_gui.io.volumes.srgb_encode import encode_inplace

__all__ = ["PrintGrid", "grid_for_source", "mm_per_unit", "VolumeSource", "voxel_centres",
           "linear_to_srgb", "linear_to_srgb_inplace", "uniform_rgb", "SlabBuffers"]


@dataclass(frozen=True)
class PrintGrid:
    """The printer's voxel grid placed in a source's coordinate system."""

    shape_xyz: tuple[int, int, int]         # voxels along x, y, z (z = build/layer direction)
    voxel_mm: tuple[float, float, float]    # printer voxel size along x, y, z in mm
    origin: tuple[float, float, float]      # source-space coordinate of the grid's min corner
    mm_per_unit: float                      # physical mm per source unit (uniform scale)

    @property
    def n_voxels(self) -> int:
        nx, ny, nz = self.shape_xyz
        return nx * ny * nz

    @property
    def size_mm(self) -> tuple[float, float, float]:
        return tuple(n * v for n, v in zip(self.shape_xyz, self.voxel_mm, strict=True))


def grid_for_source(source, voxel_mm, *, height_mm: float | None = None,
                    size_mm: tuple[float, float, float] | None = None,
                    bounds=None) -> PrintGrid:
    """Scale ``source`` to a physical size and lay the printer grid over it.

    ``height_mm``: the source's z extent becomes ``height_mm`` (aspect kept).
    ``size_mm=(X, Y, Z)``: the largest uniform scale that fits the source in that box.
    Exactly one must be given.  The grid covers the source's bounds (or ``bounds``, e.g. the
    occupied part: ``--fit occupied``) and is centred on them.
    """
    check_print_size(height_mm, size_mm)
    vox = tuple(float(v) for v in voxel_mm)
    if len(vox) != 3 or not all(math.isfinite(v) and v > 0 for v in vox):
        raise DreamPrintError(f"printer voxel size must be three positive numbers, got {voxel_mm}")
    box = source.bounds if bounds is None else bounds
    lo = np.asarray(box[0], float)
    hi = np.asarray(box[1], float)
    ext = hi - lo
    if not (np.all(np.isfinite(ext)) and np.all(ext >= 0) and ext.max() > 0):
        raise DreamPrintError(f"the source has empty or invalid bounds {source.bounds}",
                              getattr(source, "name", None))
    mpu = mm_per_unit(ext, height_mm=height_mm, size_mm=size_mm,
                      name=getattr(source, "name", None))
    shape = []
    origin = []
    for a in range(3):
        n = max(1, math.ceil(ext[a] * mpu / vox[a] - 1e-9))
        shape.append(int(n))
        surplus = (n * vox[a] / mpu - ext[a]) / 2.0
        origin.append(float(lo[a] - surplus))
    return PrintGrid(tuple(shape), vox, tuple(origin), mpu)


def mm_per_unit(extent, *, height_mm: float | None = None,
                size_mm: tuple[float, float, float] | None = None, name=None) -> float:
    """The uniform scale (mm per source unit) of :func:`grid_for_source` for bounds of
    ``extent`` (their size along x, y, z in source units): ``height_mm / extent_z``, or for
    ``size_mm = (X, Y, Z)`` the largest scale that fits the bounds in that box,
    ``min(size_i / extent_i)`` over the axes of non-zero extent. A height of a source flat in
    z, a box without a positive finite size or bounds with no extent are refused (``name``:
    the source the message names)."""
    ext = np.asarray(extent, float)
    if height_mm is not None:
        if not (math.isfinite(height_mm) and height_mm > 0):
            raise DreamPrintError(f"height must be a positive number of mm, got {height_mm}")
        if not ext[2] > 0:
            raise DreamPrintError("the source is flat in z: give a box size instead of a height",
                                  name)
        return float(height_mm) / float(ext[2])
    box = np.asarray(size_mm, float)
    if box.shape != (3,) or not np.all(np.isfinite(box)) or np.any(box <= 0):
        raise DreamPrintError(f"box size must be three positive numbers of mm, got {size_mm}")
    ok = ext > 0
    if not ok.any():
        raise DreamPrintError("the source's bounds have no extent", name)
    return float(np.min(box[ok] / ext[ok]))


def voxel_centres(grid: PrintGrid, axis: int, lo: int = 0, hi: int | None = None) -> np.ndarray:
    """Source-space centres (float64) of printer voxels ``lo..hi-1`` along ``axis`` (0=x)."""
    if hi is None:
        hi = grid.shape_xyz[axis]
    idx = np.arange(lo, hi, dtype=np.float64)
    return grid.origin[axis] + (idx + 0.5) * (grid.voxel_mm[axis] / grid.mm_per_unit)


def linear_to_srgb(c: np.ndarray) -> np.ndarray:
    """IEC 61966-2-1 sRGB encoding of linear values, clipped to [0, 1] (float32, a new array;
    :mod:`.srgb_encode`: the same bits on every CPU)."""
    return encode_inplace(np.array(c, np.float32, order="C"))


def linear_to_srgb_inplace(c: np.ndarray) -> np.ndarray:
    """:func:`linear_to_srgb` of a C-contiguous float32 array, in place (no scratch arrays:
    a slab of colour voxels is converted in the cache, ~8 ns per voxel)."""
    if c.dtype != np.float32 or not c.flags.c_contiguous:
        raise ValueError("linear_to_srgb_inplace needs a C-contiguous float32 array")
    return encode_inplace(c)


def uniform_rgb(shape: tuple[int, ...], colour, out: np.ndarray | None = None) -> np.ndarray:
    """float32 ``shape + (3,)`` filled with one colour (per-channel fill: numpy's broadcast
    copy of a length-3 vector is several times slower), into ``out`` if given."""
    if out is None:
        out = np.empty(tuple(shape) + (3,), np.float32)
    for k in range(3):
        out[..., k] = colour[k]
    return out


class SlabBuffers:
    """Reusable float32 colour (L, ny, nx, 3) and density (L, ny, nx) arrays for
    ``sample_slab(..., out=buffers)``.

    A print-job worker samples slab after slab of the same size: writing into memory it has
    already touched avoids a fresh array's page faults (~2.8 ns per voxel on this project's
    2-core VM, as much as the interpolation itself). Not thread-safe: one per worker thread.

    Sources write every element, except that with ``colour_where_dense`` a source may leave
    the colour of voxels whose density is 0 as it was (the previous slab's): a consumer that
    reads colour only where the density is positive sets it, and the dense sampler then skips
    zeroing the colour of empty rows (~0.7 ns per voxel, a sixth of its time on a small job).
    With ``colour_where_dense`` and a positive ``colour_threshold`` (density, 1/mm, float32)
    the consumer reads colour only where the density reaches that threshold (``>=``, as the
    job's background test): a source whose colour is costly may then leave the colour of
    voxels below it at 0 (an InstantNGP snapshot skips its colour network there).
    """

    def __init__(self, colour_where_dense: bool = False, colour_threshold: float = 0.0) -> None:
        self.rgb: np.ndarray | None = None
        self.sigma: np.ndarray | None = None
        self.colour_where_dense = bool(colour_where_dense)
        self.colour_threshold = np.float32(colour_threshold)

    def take(self, shape: tuple[int, int, int]) -> tuple[np.ndarray, np.ndarray]:
        """C-contiguous (rgb, sigma) views of ``shape`` (uninitialised), grown when needed."""
        n, ny, nx = (int(v) for v in shape)
        if self.sigma is None or self.sigma.shape[1:] != (ny, nx) or self.sigma.shape[0] < n:
            self.sigma = np.empty((n, ny, nx), np.float32)
            self.rgb = np.empty((n, ny, nx, 3), np.float32)
        return self.rgb[:n], self.sigma[:n]


def check_slab(grid: PrintGrid, z0: int, z1: int) -> None:
    """Refuse a slab outside the grid (a programming error upstream, but cheap to check)."""
    if not (0 <= z0 < z1 <= grid.shape_xyz[2]):
        raise ValueError(f"slab {z0}:{z1} outside the grid's {grid.shape_xyz[2]} layers")


@runtime_checkable
class VolumeSource(Protocol):
    """What every reader returns: bounds, colour model, density model, slab sampler."""

    name: str
    format: str
    bounds: tuple[tuple[float, float, float], tuple[float, float, float]]
    colour_encoding: str

    def sample_slab(self, grid: PrintGrid, z0: int, z1: int, *, density_scale: float = 1.0,
                    out: SlabBuffers | None = None) -> tuple[np.ndarray, np.ndarray]:
        """rgb float32 (z1-z0, ny, nx, 3) sRGB-encoded; density float32 (z1-z0, ny, nx) 1/mm.

        ``out``: buffers the source may write into and return (the caller must not keep the
        arrays past its next call with the same buffers); a source may ignore it."""
        ...

    def info(self) -> dict:
        """The ``dreamprint inspect --json`` description of the file."""
        ...

    # Optional: ``slab_layers``, the layers a slab should hold for ``sample_slab`` to work at
    # its best (default 1; the job gives them where that keeps all workers' slabs within
    # job.plan's MAX_SLAB_VOXELS).
    # Optional: ``layer_plan(grid, z0, z1, *, density_scale=1.0)`` -> the arguments of the
    # compiled call named by the source's ``layer_kind`` (default "dense":
    # ``job.sample_label.dense_job.dense_slab_labels``; "leaf_grid":
    # ``job.sample_label.leaf_grid_job``) up to its layer arrays, or None. A source offers it
    # so that a print job samples and labels one layer at a time (DenseSource, VdbSource,
    # NanoVdbSource).


def occupied_ranges(mask: np.ndarray) -> list[tuple[int, int]] | None:
    """Per axis x, y, z, the first and one-past-last index where a (z, y, x) boolean ``mask``
    holds anything; None when it holds nothing (the occupied box of a voxel model or of a
    coarse occupancy grid, :mod:`.orient`)."""
    if not mask.any():
        return None
    out = []
    for a in range(3):
        idx = np.flatnonzero(mask.any(axis=tuple(k for k in range(3) if k != 2 - a)))
        out.append((int(idx[0]), int(idx[-1]) + 1))
    return out
