"""VTK image data: XML ``.vti``, legacy ``.vtk`` (STRUCTURED_POINTS), MetaImage ``.mhd/.mha``,
NRRD ``.nrrd/.nhdr`` (including detached data-file lists; :mod:`.nrrd`), the others read
through VTK via pyvista.

Defines :func:`open_path` and :class:`ImageSource`.

Scalar arrays map to density through a window: ``t = clip((v - low) / (high - low), 0, 1)``,
density ``= t * density`` (1/source unit), colour from a matplotlib colormap of ``t`` or one
uniform colour.  Four-component arrays are RGBA: colour = RGB, density = A * ``density``
(8-bit arrays are scaled by 1/255).  Point data sits at ``origin + index * spacing`` (VTK's
convention), cell data at cell centres.

References: VTK file formats (VTK User's Guide ch. 19, "VTK File Formats"); MetaImage
(ITK MetaIO); NRRD format 5 (teem.sourceforge.net/nrrd/format.html, "data file" lists).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes.base import PrintGrid, SlabBuffers, check_slab, voxel_centres
from dreamprint_gui.io.volumes.dense import (
    DenseLayers,
    DenseSource,
    DenseVolume,
    apply_window,
    check_claimed_size,
    colormap_lut,
)
from dreamprint_gui.io.volumes.grids.nrrd import read_nrrd

__all__ = ["open_path", "ImageSource"]

_FORMAT_NAMES = {".vti": "VTK XML image data (.vti)", ".vtk": "legacy VTK structured points",
                 ".mhd": "MetaImage", ".mha": "MetaImage", ".nrrd": "NRRD", ".nhdr": "NRRD"}

_DIM_PATTERNS = [
    re.compile(rb"DimSize\s*=\s*(\d+)\s+(\d+)\s+(\d+)"),
    re.compile(rb"sizes\s*:\s*(\d+)\s+(\d+)\s+(\d+)(?:\s+(\d+))?"),
    re.compile(rb"DIMENSIONS\s+(\d+)\s+(\d+)\s+(\d+)"),
    re.compile(rb'WholeExtent\s*=\s*"\s*(-?\d+)\s+(-?\d+)\s+(-?\d+)\s+(-?\d+)\s+(-?\d+)\s+(-?\d+)'),
]


def _precheck(path: Path) -> None:
    """Parse the header's claimed dimensions and refuse sizes the bytes on disk cannot hold."""
    with open(path, "rb") as f:
        head = f.read(1 << 16)
    n = None
    for pat in _DIM_PATTERNS:
        m = pat.search(head)
        if not m:
            continue
        g = [int(x) for x in m.groups() if x is not None]
        if len(g) == 6:
            n = (g[1] - g[0] + 1) * (g[3] - g[2] + 1) * (g[5] - g[4] + 1)
            if min(g[1] - g[0], g[3] - g[2], g[5] - g[4]) < 0:
                raise DreamPrintError("the header's extent is empty or inverted", path)
        else:
            n = int(np.prod(g, dtype=object))
        break
    if n is None:
        return
    available = path.stat().st_size
    detached = (b"ElementDataFile" in head and b"LOCAL" not in head) or b"data file" in head \
        or b"datafile" in head
    if detached:
        # data lives in sibling files (possibly a list or a %d pattern): count the folder's bytes
        available = 0
        for i, p in enumerate(path.parent.iterdir()):
            if i > 100_000:
                break
            if p.is_file():
                available += p.stat().st_size
    check_claimed_size(n, 1, available, path)


def _read(path: Path):
    import pyvista as pv
    if path.suffix.lower() in (".nrrd", ".nhdr"):

        values, origin, spacing = read_nrrd(path)
        img = pv.ImageData(dimensions=values.shape[2::-1], spacing=spacing, origin=origin)
        flat = values.reshape(img.n_points, -1)
        img.point_data["NRRD"] = flat[:, 0] if flat.shape[1] == 1 else flat
        return img
    _precheck(path)
    try:
        mesh, problems = _read_capturing(pv, path)
    except Exception as exc:  # noqa: BLE001 - VTK raises assorted types on bad input
        raise DreamPrintError(f"cannot read as VTK image data: {exc}", path) from None
    if problems:
        # VTK and MetaIO report short or unparsable data as messages and return a zero-padded
        # image; a print job must never be made from that.
        raise DreamPrintError(f"damaged or truncated file: {problems[0]}", path)
    if isinstance(mesh, pv.MultiBlock):
        blocks = [b for b in mesh if isinstance(b, pv.ImageData)]
        if not blocks:
            raise DreamPrintError("contains no image data", path)
        mesh = blocks[0]
    if not isinstance(mesh, pv.ImageData):
        raise DreamPrintError(f"holds {type(mesh).__name__}, not image data (a regular grid)",
                              path)
    if mesh.n_points == 0 or (not mesh.point_data.keys() and not mesh.cell_data.keys()):
        raise DreamPrintError("no voxel data (empty, damaged or truncated file)", path)
    d = np.asarray(mesh.direction_matrix)
    if not np.allclose(d, np.eye(3), atol=1e-6):
        raise DreamPrintError("the image is rotated (direction matrix not identity): resample "
                              "it axis-aligned first", path)
    return mesh


def _read_capturing(pv, path: Path):
    """``pv.read`` with every complaint collected instead of printed.

    VTK reports through its output window (caught by ``VtkErrorCatcher``), pyvista through Python
    warnings, and MetaIO by writing straight to the process's stdout/stderr, so those two file
    descriptors are redirected to a temporary file for the duration of the read.
    """
    import sys
    import tempfile
    import warnings

    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    with tempfile.TemporaryFile() as sink:
        os.dup2(sink.fileno(), 1)
        os.dup2(sink.fileno(), 2)
        try:
            with warnings.catch_warnings(record=True) as caught, \
                    pv.VtkErrorCatcher(raise_errors=False, send_to_logging=False) as vtk_errors:
                warnings.simplefilter("always")
                mesh = pv.read(path)
        finally:
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
        sink.seek(0)
        raw = sink.read().decode("utf-8", "replace")
    problems = [_one_line(e.alert) for e in vtk_errors.events if e.alert.strip()]
    problems += [_one_line(str(w.message)) for w in caught if "error" in str(w.message).lower()]
    problems += [_one_line(re.sub(r"\x1b\[[0-9;]*m", "", line)) for line in raw.splitlines()
                 if re.search(r"error|fail|not read completely|cannot", line, re.I)]
    return mesh, list(dict.fromkeys(problems))


def _one_line(message: str) -> str:
    """The last line of a reader's complaint, without its indentation and quotes (VTK quotes
    MetaIO's message on a tab-indented line of its own)."""
    line = message.strip().splitlines()[-1].strip()
    if len(line) > 1 and line[0] == line[-1] == '"':
        line = line[1:-1].strip()
    return line


def _arrays(mesh):
    out = []
    for assoc, data in (("point", mesh.point_data), ("cell", mesh.cell_data)):
        for k in data.keys():
            out.append((k, assoc, data[k]))
    return out


def _grid_info(mesh, name, assoc, arr) -> dict:
    a = np.asarray(arr)
    ncomp = 1 if a.ndim == 1 else a.shape[1]
    dims = list(mesh.dimensions) if assoc == "point" else [max(1, d - 1) for d in mesh.dimensions]
    b = mesh.bounds
    vals = a if ncomp == 1 else a[:, -1] if ncomp == 4 else np.linalg.norm(a, axis=1)
    extra = {}
    if ncomp == 1 or not a.size:
        lo = float(np.nanmin(a)) if a.size else None
        hi = float(np.nanmax(a)) if a.size else None
    else:  # per component (a vector or RGBA array), and the magnitude of a vector
        lo = [float(v) for v in np.nanmin(a, axis=0)]
        hi = [float(v) for v in np.nanmax(a, axis=0)]
        if ncomp != 4:
            extra["magnitude"] = [float(np.nanmin(vals)), float(np.nanmax(vals))]
    cls = "rgba image" if ncomp == 4 else "scalar image" if ncomp == 1 else "vector image"
    return {"name": name, "class": cls,
            "shape": dims + ([ncomp] if ncomp > 1 else []),
            "active_voxels": int(np.count_nonzero(vals)), "min": lo, "max": hi,
            "dtype": str(a.dtype), "bounds": [[b[0], b[2], b[4]], [b[1], b[3], b[5]]], **extra}


class ImageSource:
    """A scalar image windowed to density, coloured by a colormap or one colour."""

    def __init__(self, name, fmt, volume: DenseVolume, window, density, lut, grids_info):
        self.name = name
        self.format = fmt
        self.volume = volume
        self.bounds = volume.bounds
        self.colour_encoding = "srgb"
        self.window = (float(window[0]), float(window[1]))
        self.density = float(density)
        self.lut = lut
        self._grids_info = grids_info

    def sample_slab(self, grid: PrintGrid, z0: int, z1: int, *, density_scale: float = 1.0,
                    out: SlabBuffers | None = None):
        check_slab(grid, z0, z1)
        v = self.volume.sample(grid, z0, z1)[..., 0]
        lo, hi = self.window
        rgb, sigma = apply_window(v, lo, hi, self.lut,
                                  self.density * density_scale / grid.mm_per_unit)
        if lo < 0:
            # outside the image the sampler gives value 0, which a window below 0 would lift
            out = _outside(self.volume, grid, z0, z1)
            if out is not None:
                sigma[out] = 0.0
        return rgb, sigma

    layer_kind = "window"  # job.sample_label.dense_job.window_slab_labels

    def layer_plan(self, grid: PrintGrid, z0: int, z1: int, *, density_scale: float = 1.0
                   ) -> tuple:
        """The arguments of :func:`...job.sample_label.dense_job.window_slab_labels` before its
        layer arrays, for layers z0..z1-1: :meth:`sample_slab`'s samples and window, a layer at a
        time, plus one layer's sample buffer."""
        check_slab(grid, z0, z1)
        vol = self.volume
        u = vol._indices(grid, z0, z1)
        plan = DenseLayers(vol.data, u[2], u[1], u[0], vol.pad)
        lo, hi = self.window
        masks = _outside_axes(vol, grid, z0, z1)
        return (vol.data, vol.rows_with_data(), *plan.args(), np.float32(lo),
                np.float32(1.0 / (hi - lo)), np.ascontiguousarray(self.lut, np.float32),
                np.float32(self.density * density_scale / grid.mm_per_unit), bool(lo < 0), *masks,
                np.empty(len(u[1]) * len(u[0]), np.float32))

    def info(self) -> dict:
        return {"format": self.format, "grids": self._grids_info}


def _outside_axes(volume: DenseVolume, grid: PrintGrid, z0: int, z1: int):
    """Per axis (z, y, x), which printer voxel centres lie outside the image's bounds."""

    masks = []
    for a, rng in ((2, (z0, z1)), (1, (0, None)), (0, (0, None))):
        c = voxel_centres(grid, a, *rng)
        eps = 1e-9 * volume.spacing[a]
        masks.append((c < volume.bounds[0][a] - eps) | (c > volume.bounds[1][a] + eps))
    return masks


def _outside(volume: DenseVolume, grid: PrintGrid, z0: int, z1: int):
    """Mask (Z, Y, X) of printer voxels outside the image's bounds, or None if none are."""
    masks = _outside_axes(volume, grid, z0, z1)
    if not any(m.any() for m in masks):
        return None
    mz, my, mx = masks
    return mz[:, None, None] | my[None, :, None] | mx[None, None, :]


def describe_path(path: Path) -> dict:
    """The ``inspect`` description of every array, without choosing one (a file whose arrays
    DreamPrint cannot map, e.g. 3-component vectors, can still be inspected)."""
    mesh = _read(path)
    return {"format": _FORMAT_NAMES.get(path.suffix.lower(), "VTK image data"),
            "grids": [_grid_info(mesh, *a) for a in _arrays(mesh)]}


def open_path(path: Path, fmt: str = "vtk", *, array: str | None = None, window=None,
              density: float = 1.0, colormap: str | None = None, colour=None) -> ImageSource:
    """Open a VTK/MetaImage/NRRD image.  ``array``: which data array (default: the active
    scalars); ``window=(low, high)`` in the array's units (default its min..max); ``density``:
    density at and above ``high`` (1/source unit); ``colormap`` (matplotlib name) or ``colour``
    (sRGB triple in [0, 1], default white)."""
    fmt = _FORMAT_NAMES.get(path.suffix.lower(), "VTK image data")
    mesh = _read(path)
    arrays = _arrays(mesh)
    infos = [_grid_info(mesh, *a) for a in arrays]
    chosen = None
    if array is not None:
        chosen = next((a for a in arrays if a[0] == array), None)
        if chosen is None:
            raise DreamPrintError(f"no array named {array!r} (has: "
                                  f"{', '.join(a[0] for a in arrays)})", path)
    else:
        active = mesh.active_scalars_name
        chosen = next((a for a in arrays if a[0] == active), arrays[0])
    name, assoc, arr = chosen
    a = np.asarray(arr)
    ncomp = 1 if a.ndim == 1 else a.shape[1]
    dims = tuple(mesh.dimensions) if assoc == "point" else \
        tuple(max(1, d - 1) for d in mesh.dimensions)
    spacing = np.asarray(mesh.spacing, float)
    origin = np.asarray(mesh.origin, float)
    if assoc == "cell":
        origin = origin + 0.5 * spacing
    if not np.all(np.isfinite(a)) and a.dtype.kind == "f":
        a = np.nan_to_num(a, nan=0.0, posinf=0.0, neginf=0.0)
    if ncomp == 4:
        scale = 1 / 255 if a.dtype == np.uint8 else 1.0
        data = np.empty(dims[::-1] + (4,), np.float32)
        flat = a.reshape(dims[::-1] + (4,))
        data[..., 0] = flat[..., 3] * np.float32(scale * float(density))
        data[..., 1:4] = flat[..., :3] * np.float32(scale)
        vol = DenseVolume(data, origin, spacing, cell_centred=(assoc == "cell"))
        return DenseSource(str(path), fmt, vol, "srgb", grids_info=infos)
    if ncomp != 1:
        raise DreamPrintError(f"array {name!r} has {ncomp} components: DreamPrint maps one "
                              "(scalar, windowed) or four (RGBA)", path)
    data = a.reshape(dims[::-1] + (1,)).astype(np.float32)
    if window is None:
        lo, hi = float(np.min(data)), float(np.max(data))
        if hi <= lo:
            lo = hi - 1.0       # a constant image is uniformly full density
    else:
        lo, hi = float(window[0]), float(window[1])
        if not (np.isfinite(lo) and np.isfinite(hi)) or hi <= lo:
            raise DreamPrintError(f"window low must be below high, got {tuple(window)}", path)
    lut = colormap_lut(colormap, colour)
    vol = DenseVolume(data, origin, spacing, cell_centred=(assoc == "cell"))
    return ImageSource(str(path), fmt, vol, (lo, hi), density, lut, infos)
