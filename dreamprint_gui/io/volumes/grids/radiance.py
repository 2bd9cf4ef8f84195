"""Radiance grids: a field (NeRF, InstantNGP, TRELLIS...) sampled by its user onto a grid.

Defines :func:`open_path`, :func:`read_npz_grid`, :func:`read_exr_stack` and
:data:`NPZ_LAYOUT` (the documented ``.npz`` layout).

``.npz`` layout (``numpy.savez`` / ``savez_compressed``, no pickles)::

    sigma   float (nz, ny, nx)       extinction density per source unit (>= 0)
    rgb     float (nz, ny, nx, 3)    colour in [0, 1]; optional (white if absent)
    bounds  float (2, 3)             [[xmin, ymin, zmin], [xmax, ymax, zmax]] of the whole grid
    colour_encoding  str             "srgb" (default: what NeRF-style fields learn from
                                     8-bit photographs) or "linear"; optional

Voxels are cell-centred: voxel (k, j, i) fills one cell of the box split into nx x ny x nz.

OpenEXR slice stack: a folder of ``.exr`` files (or one of them), sorted by name with numbers
compared numerically, one file per z layer, the first at the bottom.  Image rows run top to
bottom, so row 0 is the largest y.  Colour from R, G, B (scene-linear, the EXR convention),
density from the ``density`` channel, else ``sigma``, else ``A`` (alpha as density per
voxel: with ``voxel_size`` in source units, density = A / voxel_size would make one voxel
reach alpha's optical depth; we keep the value as given and the operator scales it with the
density scale).  The grid spans ``[0, nx] x [0, ny] x [0, nz] * voxel_size``.
"""

from __future__ import annotations

import re
import zipfile
import zlib
from pathlib import Path

import numpy as np

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes.dense import (
    DenseSource,
    DenseVolume,
    bounds_list,
    check_claimed_size,
)

__all__ = ["open_path", "read_npz_grid", "read_exr_stack", "NPZ_LAYOUT"]

NPZ_LAYOUT = {"sigma": "(nz, ny, nx) density per source unit",
              "rgb": "(nz, ny, nx, 3) colour in [0, 1] (optional)",
              "bounds": "(2, 3) min xyz, max xyz",
              "colour_encoding": "'srgb' (default) or 'linear' (optional)"}


def _npz_member(z: zipfile.ZipFile, name: str, path: Path) -> np.ndarray | None:
    member = f"{name}.npy"
    if member not in z.namelist():
        return None
    info = z.getinfo(member)
    with z.open(member) as f:
        try:
            version = np.lib.format.read_magic(f)
            reader = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                      else np.lib.format.read_array_header_2_0)
            shape, fortran, dtype = reader(f)
        except (ValueError, SyntaxError) as exc:
            raise DreamPrintError(f"member {name!r} is not a valid .npy array ({exc})",
                                  path) from None
        if dtype.hasobject:
            raise DreamPrintError(f"member {name!r} holds Python objects; refused", path)
        n = int(np.prod(shape, dtype=object))
        if n * dtype.itemsize > info.file_size:
            raise DreamPrintError(f"member {name!r} claims {n:,} values but holds "
                                  f"{info.file_size:,} bytes: damaged or truncated", path)
        check_claimed_size(n, dtype.itemsize, info.compress_size, path)
        data = f.read(n * dtype.itemsize)
        if len(data) < n * dtype.itemsize:
            raise DreamPrintError(f"member {name!r} is truncated", path)
    a = np.frombuffer(data, dtype, n)
    return a.reshape(shape[::-1]).T if fortran else a.reshape(shape)


def read_npz_grid(path: Path):
    """(sigma (nz, ny, nx), rgb (nz, ny, nx, 3) or None, bounds (2, 3), encoding)."""
    try:
        with zipfile.ZipFile(path) as z:
            sigma = _npz_member(z, "sigma", path)
            rgb = _npz_member(z, "rgb", path)
            bounds = _npz_member(z, "bounds", path)
            enc = _npz_member(z, "colour_encoding", path)
    except (zipfile.BadZipFile, OSError, EOFError, zlib.error) as exc:
        raise DreamPrintError(f"damaged .npz: {exc}", path) from None
    if sigma is None or bounds is None:
        raise DreamPrintError("a radiance .npz needs arrays 'sigma' (nz, ny, nx) and 'bounds' "
                              "(2, 3); 'rgb' (nz, ny, nx, 3) is optional", path)
    if sigma.ndim != 3 or min(sigma.shape) < 1:
        raise DreamPrintError(f"'sigma' must be (nz, ny, nx), got shape {sigma.shape}", path)
    if rgb is not None and rgb.shape != sigma.shape + (3,):
        raise DreamPrintError(f"'rgb' must be {sigma.shape + (3,)}, got {rgb.shape}", path)
    bounds = np.asarray(bounds, float)
    if bounds.shape != (2, 3) or not np.all(np.isfinite(bounds)) or np.any(bounds[1] <= bounds[0]):
        raise DreamPrintError(f"'bounds' must be [[xmin, ymin, zmin], [xmax, ymax, zmax]] with "
                              f"max > min, got {bounds.tolist()}", path)
    encoding = "srgb" if enc is None else str(enc.reshape(-1)[0]).lower()
    if encoding not in ("srgb", "linear"):
        raise DreamPrintError(f"colour_encoding must be 'srgb' or 'linear', got {encoding!r}",
                              path)
    return sigma, rgb, bounds, encoding


def _natural_key(p: Path):
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", p.name)]


def read_exr_stack(path: Path, density_channel: str | None = None):
    """(data (nz, ny, nx, 4) float32 [density, R, G, B], channel used) from a folder of EXRs."""
    import OpenEXR

    folder = path if path.is_dir() else path.parent
    files = sorted((p for p in folder.iterdir() if p.suffix.lower() == ".exr"), key=_natural_key)
    if not files:
        raise DreamPrintError("no .exr slices in the folder", folder)
    data = None
    used = None
    for k, f in enumerate(files):
        try:
            h = OpenEXR.File(str(f), separate_channels=True, header_only=True).header()
            (x0, y0), (x1, y1) = (np.asarray(v, np.int64) for v in h["dataWindow"])
            w, hgt = int(x1 - x0 + 1), int(y1 - y0 + 1)
            names = [c.name for c in h["channels"]]
            if w < 1 or hgt < 1:
                raise DreamPrintError("empty data window", f)
            check_claimed_size(w * hgt * len(names), 2, f.stat().st_size, f)
            ch = OpenEXR.File(str(f), separate_channels=True).channels()
        except DreamPrintError:
            raise
        except Exception as exc:  # noqa: BLE001 - OpenEXR raises RuntimeError/ValueError/...
            raise DreamPrintError(f"cannot read EXR slice: {exc}", f) from None
        if used is None:
            for cand in ([density_channel] if density_channel else ["density", "sigma", "A"]):
                if cand in ch:
                    used = cand
                    break
            if used is None:
                raise DreamPrintError("no density channel (density, sigma or A; has "
                                      f"{', '.join(ch)})", f)
            data = np.zeros((len(files), hgt, w, 4), np.float32)
        if (hgt, w) != data.shape[1:3]:
            raise DreamPrintError(f"slice is {w} x {hgt}, the first was {data.shape[2]} x "
                                  f"{data.shape[1]}", f)
        if used not in ch:
            raise DreamPrintError(f"slice lacks the density channel {used!r}", f)
        # rows run top to bottom: flip so row index grows with y
        data[k, :, :, 0] = np.asarray(ch[used].pixels, np.float32)[::-1]
        for c, n in enumerate("RGB", start=1):
            if n in ch:
                data[k, :, :, c] = np.asarray(ch[n].pixels, np.float32)[::-1]
            else:
                data[k, :, :, c] = 1.0
    return data, used


def open_path(path: Path, fmt: str = "radiance-npz", *, voxel_size: float = 1.0,
              density_channel: str | None = None, colour_encoding: str | None = None):
    """Open a radiance ``.npz`` or an EXR slice stack (a folder, or one slice in it)."""
    if fmt == "radiance-exr" or path.is_dir() or path.suffix.lower() == ".exr":
        data, used = read_exr_stack(path, density_channel)
        if not (np.isfinite(voxel_size) and voxel_size > 0):
            raise DreamPrintError(f"voxel size must be positive, got {voxel_size}", path)
        np.nan_to_num(data, copy=False, nan=0.0, posinf=0.0, neginf=0.0)
        np.maximum(data[..., 0], 0, out=data[..., 0])
        nz, ny, nx, _ = data.shape
        info = {"name": used, "class": "radiance grid (EXR stack)", "shape": [nx, ny, nz],
                "active_voxels": int(np.count_nonzero(data[..., 0])),
                "min": float(data[..., 0].min()), "max": float(data[..., 0].max()),
                "dtype": "float32", "bounds": [[0.0, 0.0, 0.0],
                                               [nx * voxel_size, ny * voxel_size,
                                                nz * voxel_size]]}
        vol = DenseVolume(data, (0.5 * voxel_size,) * 3, (voxel_size,) * 3, cell_centred=True)
        return DenseSource(str(path), "OpenEXR slice stack", vol, colour_encoding or "linear",
                           grids_info=[info])
    sigma, rgb, bounds, enc = read_npz_grid(path)
    nz, ny, nx = sigma.shape
    data = np.empty((nz, ny, nx, 4 if rgb is not None else 1), np.float32)
    data[..., 0] = sigma
    if rgb is not None:
        data[..., 1:] = rgb
    np.nan_to_num(data, copy=False, nan=0.0, posinf=0.0, neginf=0.0)
    np.maximum(data[..., 0], 0, out=data[..., 0])
    spacing = (bounds[1] - bounds[0]) / np.array([nx, ny, nz])
    info = {"name": "sigma", "class": "radiance grid", "shape": [nx, ny, nz],
            "active_voxels": int(np.count_nonzero(data[..., 0])),
            "min": float(sigma.min()), "max": float(sigma.max()), "dtype": str(sigma.dtype),
            "bounds": bounds_list(bounds)}
    vol = DenseVolume(data, bounds[0] + 0.5 * spacing, spacing, cell_centred=True)
    return DenseSource(str(path), "radiance grid (.npz)", vol, colour_encoding or enc,
                       grids_info=[info])
