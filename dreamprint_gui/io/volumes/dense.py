"""Sources held as a regular, axis-aligned grid of samples (VTK images, radiance grids, voxels).

Defines :class:`DenseVolume` (samples + placement, trilinear slab sampling),
:class:`DenseSource` (density + colour channels -> the :class:`~.base.VolumeSource` contract),
:func:`colormap_lut` and :func:`check_claimed_size` (refuse headers that claim more voxels than
the bytes on disk can hold, before any reader allocates).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes.base import (
    PrintGrid,
    SlabBuffers,
    check_slab,
    linear_to_srgb_inplace,
    uniform_rgb,
    voxel_centres,
)
from dreamprint_gui.io.volumes.dense_sampler import (
    DenseLayers,
    rows_with_data,
    sample_dense,
    sample_dense_density,
)

__all__ = ["DenseVolume", "DenseSource", "DenseLayers", "colormap_lut", "check_claimed_size",
           "apply_window", "bounds_list", "window_kernel"]

# zlib/gzip cannot expand data by more than ~1032:1; allow headroom for the other codecs.
MAX_EXPANSION = 1100


def check_claimed_size(n_values: int, bytes_per_value: int, available_bytes: int, path) -> None:
    """Refuse a header whose claimed size the file's bytes could not possibly hold."""
    if n_values < 0:
        raise DreamPrintError("negative dimensions in the header", path)
    need = int(n_values) * int(bytes_per_value)
    if need > MAX_EXPANSION * int(available_bytes) + (1 << 20):
        raise DreamPrintError(f"the header claims {n_values:,} values but the file holds only "
                              f"{available_bytes:,} bytes: damaged or truncated", path)


class DenseVolume:
    """Samples ``data`` (nz, ny, nx, C) float32 at ``origin + index * spacing`` (x, y, z).

    ``cell_centred``: each sample is a voxel whose box reaches half a spacing beyond its
    centre (bounds = outer faces); otherwise samples are points (bounds = outer samples).
    """

    def __init__(self, data: np.ndarray, origin, spacing, cell_centred: bool):
        if data.ndim != 4:
            raise ValueError("data must be (nz, ny, nx, C)")
        self.data = np.ascontiguousarray(data, np.float32)
        self.origin = np.asarray(origin, float)
        self.spacing = np.asarray(spacing, float)
        if np.any(~np.isfinite(self.spacing)) or np.any(self.spacing <= 0):
            raise DreamPrintError(f"grid spacing must be positive, got {tuple(self.spacing)}")
        self.pad = 0.5 if cell_centred else 0.0
        nxyz = np.array(self.data.shape[2::-1], float)
        lo = self.origin - self.pad * self.spacing
        hi = self.origin + (nxyz - 1 + self.pad) * self.spacing
        self.bounds = (tuple(float(v) for v in lo), tuple(float(v) for v in hi))
        self._rows_nz: np.ndarray | None = None

    def rows_with_data(self) -> np.ndarray:
        """(nz, ny) bool, rows holding data (:func:`.dense_sampler.rows_with_data`), found on first
        use (a scan of the grid, e.g. while a job is prepared) and kept: ``data`` must not
        change afterwards."""
        if self._rows_nz is None:
            self._rows_nz = rows_with_data(self.data)
        return self._rows_nz

    def _indices(self, grid: PrintGrid, z0: int, z1: int) -> list[np.ndarray]:
        return [(voxel_centres(grid, a, *((z0, z1) if a == 2 else (0, None)))
                 - self.origin[a]) / self.spacing[a] for a in range(3)]

    def sample(self, grid: PrintGrid, z0: int, z1: int) -> np.ndarray:
        """Trilinear samples at the printer voxel centres of layers z0..z1-1: (Z, Y, X, C)."""
        u = self._indices(grid, z0, z1)
        return sample_dense(self.data, u[2], u[1], u[0], self.pad, self.rows_with_data())

    def sample_density(self, grid: PrintGrid, z0: int, z1: int, scale: float, out=None):
        """(colour (Z, Y, X, 3) or None, density x ``scale`` (Z, Y, X)) of a density grid
        (channel 0 density, channels 1-3 colour premultiplied by it): see
        :func:`.dense_sampler.sample_dense_density`."""
        u = self._indices(grid, z0, z1)
        return sample_dense_density(self.data, u[2], u[1], u[0], self.pad, scale, out,
                                    self.rows_with_data())


def colormap_lut(name: str | None, colour=None, n: int = 256) -> np.ndarray:
    """(n, 3) float32 sRGB-encoded lookup table: a matplotlib colormap or one uniform colour."""
    if name:
        try:
            import matplotlib
            cmap = matplotlib.colormaps[name]
        except (KeyError, ValueError):
            raise DreamPrintError(f"unknown colormap {name!r}") from None
        return np.asarray(cmap(np.linspace(0, 1, n))[:, :3], np.float32)
    c = (1.0, 1.0, 1.0) if colour is None else colour
    c = np.asarray(c, np.float32).reshape(-1)
    if c.shape != (3,) or np.any(~np.isfinite(c)) or np.any(c < 0) or np.any(c > 1):
        raise DreamPrintError(f"a colour is three numbers in [0, 1], got {colour}")
    return np.tile(c, (n, 1))


@njit(cache=True, nogil=True)
def window_kernel(v, lo, inv_width, lut, dens, rgb, sigma):
    """Window values ``v`` into ``sigma`` (``t * dens``, ``t = (v - lo) * inv_width`` clamped
    to [0, 1]) and colour ``rgb`` (``lut`` at the nearest of its nodes to ``t``), in place."""
    n = lut.shape[0] - 1
    flat_v = v.reshape(-1)
    fs = sigma.reshape(-1)
    fr = rgb.reshape(-1, 3)
    for q in range(flat_v.shape[0]):
        t = (flat_v[q] - lo) * inv_width
        t = min(max(t, 0.0), 1.0)
        fs[q] = t * dens
        i = int(t * n + 0.5)
        fr[q, 0] = lut[i, 0]
        fr[q, 1] = lut[i, 1]
        fr[q, 2] = lut[i, 2]


def apply_window(v: np.ndarray, low: float, high: float, lut: np.ndarray, density: float):
    """``t = clip((v - low) / (high - low), 0, 1)`` -> (colour ``lut[t]`` (..., 3), ``t * density``)
    in one compiled pass."""
    v = np.ascontiguousarray(v, np.float32)
    rgb = np.empty(v.shape + (3,), np.float32)
    sigma = np.empty(v.shape, np.float32)
    window_kernel(v, np.float32(low), np.float32(1.0 / (high - low)),
                   np.ascontiguousarray(lut, np.float32), np.float32(density), rgb, sigma)
    return rgb, sigma


def bounds_list(bounds) -> list[list[float]]:
    return [[float(v) for v in bounds[0]], [float(v) for v in bounds[1]]]


class DenseSource:
    """A dense grid holding density (1/source unit) and optionally colour channels.

    ``volume.data`` channel 0 is density; channels 1-3 (if present) colour in
    ``colour_encoding``; with one channel, ``uniform_colour`` (sRGB-encoded) is used.
    Colour is interpolated density-weighted (stored premultiplied, in place, unless
    ``premultiplied`` says it already is), so a transparent voxel's colour does not bleed into
    its neighbours.
    """

    def __init__(self, name: str, fmt: str, volume: DenseVolume, colour_encoding: str = "srgb",
                 uniform_colour=(1.0, 1.0, 1.0), grids_info: list[dict] | None = None,
                 premultiplied: bool = False):
        self.name = name
        self.format = fmt
        self.volume = volume
        self.colour_encoding = colour_encoding
        self.uniform_colour = np.asarray(uniform_colour, np.float32)
        self.bounds = volume.bounds
        self._grids_info = grids_info or []
        if volume.data.shape[3] == 4 and not premultiplied:
            d = volume.data
            d[..., 1:4] *= d[..., :1]       # premultiply once, in the source's own storage

    def sample_slab(self, grid: PrintGrid, z0: int, z1: int, *, density_scale: float = 1.0,
                    out: SlabBuffers | None = None):
        check_slab(grid, z0, z1)
        rgb, sigma = self.volume.sample_density(grid, z0, z1, density_scale / grid.mm_per_unit,
                                                out)
        if rgb is None:
            rgb = uniform_rgb(sigma.shape, self.uniform_colour,
                              None if out is None else out.take(sigma.shape)[0])
        elif self.colour_encoding == "linear":
            rgb = linear_to_srgb_inplace(rgb)      # the slab's own array (out or new)
        return rgb, sigma

    def layer_plan(self, grid: PrintGrid, z0: int, z1: int, *, density_scale: float = 1.0
                   ) -> tuple | None:
        """The arguments of :func:`...job.sample_label.dense_job.dense_slab_labels` before its layer
        arrays, for layers z0..z1-1: the samples :meth:`sample_slab` gives, a layer at a time
        (linear colour sRGB-encoded by the same :mod:`.srgb_encode`)."""
        check_slab(grid, z0, z1)
        vol = self.volume
        u = vol._indices(grid, z0, z1)
        plan = DenseLayers(vol.data, u[2], u[1], u[0], vol.pad)
        return (vol.data, vol.rows_with_data(), *plan.args(),
                np.float32(density_scale / grid.mm_per_unit), self.uniform_colour,
                self.colour_encoding == "linear")

    def info(self) -> dict:
        return {"format": self.format, "grids": self._grids_info}
