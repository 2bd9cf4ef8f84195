"""InstantNGP's own volume exports: the RGBA PNG slice sequence and the raw RGBA volumes.

Defines :func:`open_path`, :func:`is_ingp_volume_dir`, :func:`read_png_slices` and
:func:`read_raw_volume`.  Both are written by instant-ngp's testbed ("Export mesh / volume /
slices" in ``src/testbed.cu``; writers in ``src/marching_cubes.cu``), sampling the network at
the voxel centres ``(i + 0.5) / res`` of the render box:

* **RGBA PNG sequence** (``save_rgba_grid_to_png_sequence``): a folder (``rgba_slices`` or
  ``<name>_rgba_slices``) of ``{z:04d}_{w}x{h}.png``, one per z layer, 8-bit RGBA, image row 0
  at the largest y.  Alpha is ``1 - exp(-sigma * 0.01)`` (``get_rgba_on_grid`` with depth 0.01
  instant-ngp units) and RGB is the colour premultiplied by that alpha.  Read back:
  ``sigma = -ln(1 - A/255) / depth`` per instant-ngp unit (A = 255 taken as 254.5, half a step
  below opaque), colour ``RGB / A``.  The files do not hold the box: one voxel is ``voxel_size``
  instant-ngp units, by default ``1 / max(w, h, layers)`` (instant-ngp makes the longest side
  ``res`` voxels, and an ``aabb_scale`` 1 scene's render box is the unit cube).
* **Raw volumes** (``save_rgba_grid_to_raw_file``): ``volume_raw/{w}x{h}x{d}_{cascade}.bin``,
  float32 RGBA, x fastest, then y (row 0 at the largest y), then z; A is the density itself
  (``density_as_alpha``), RGB the colour, not premultiplied.  Cascade ``c`` spans the cube
  ``0.5 -+ 2^c / 2`` in instant-ngp units (with its centre zeroed for c > 0, where the finer
  cascade lies); a folder opens cascade 0.

Swapped exports ("Swap Y&Z") need nothing special: read the same way they come out turned
(x, -z, y), a rotation that puts instant-ngp's up axis (y) on the build axis.  Source units are
instant-ngp units; density per unit then follows the product's rule (:mod:`.base`).  The
sampling is the dense-grid sampler's (:class:`~.dense.DenseSource`).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes.dense import DenseSource, DenseVolume, check_claimed_size

__all__ = ["open_path", "is_ingp_volume_dir", "is_ingp_volume_name", "read_png_slices",
           "read_raw_volume", "PNG_NAME", "RAW_NAME", "PNG_DEPTH"]

PNG_NAME = re.compile(r"^(\d+)_(\d+)x(\d+)\.png$", re.IGNORECASE)
RAW_NAME = re.compile(r"^(\d+)x(\d+)x(\d+)_(\d+)\.bin$", re.IGNORECASE)
PNG_DEPTH = 0.01            # the depth get_rgba_on_grid turns density into alpha with


def _pngs(folder: Path) -> list[tuple[int, int, int, Path]]:
    out = []
    for p in folder.iterdir():
        m = PNG_NAME.match(p.name)
        if m:
            out.append((int(m.group(1)), int(m.group(2)), int(m.group(3)), p))
    return sorted(out)


def _raws(folder: Path) -> list[tuple[int, Path]]:
    return sorted((int(m.group(4)), p) for p in folder.iterdir()
                  if (m := RAW_NAME.match(p.name)))


def is_ingp_volume_name(name: str) -> bool:
    """A file named like one of instant-ngp's PNG slices or raw volumes."""
    return bool(PNG_NAME.match(name) or RAW_NAME.match(name))


def is_ingp_volume_dir(folder: Path) -> bool:
    """A folder holding instant-ngp PNG slices (``NNNN_WxH.png``) or raw volumes and no EXR."""
    try:
        names = [p.name for p in folder.iterdir()]
    except OSError:
        return False
    if any(n.lower().endswith(".exr") for n in names):
        return False
    return any(PNG_NAME.match(n) or RAW_NAME.match(n) for n in names)


def read_png_slices(folder: Path) -> tuple[np.ndarray, np.ndarray]:
    """(rgba uint8 (nz, ny, nx, 4) with row index growing with y, slice files) of a sequence."""
    from PIL import Image

    files = _pngs(folder)
    if not files:
        raise DreamPrintError("no instant-ngp RGBA slices (NNNN_WxH.png) in the folder", folder)
    idx = [f[0] for f in files]
    if idx != list(range(len(files))):
        missing = sorted(set(range(max(idx) + 1)) - set(idx))
        raise DreamPrintError(f"slice sequence has gaps (missing {missing[:5]}"
                              f"{'...' if len(missing) > 5 else ''})", folder)
    sizes = {(w, h) for _, w, h, _ in files}
    if len(sizes) != 1:
        raise DreamPrintError(f"slices of different sizes in one sequence: {sorted(sizes)}",
                              folder)
    (w, h), = sizes
    check_claimed_size(w * h * len(files) * 4, 1, sum(f[3].stat().st_size for f in files),
                       folder)
    data = np.empty((len(files), h, w, 4), np.uint8)
    for k, (_, _, _, p) in enumerate(files):
        try:
            with Image.open(p) as im:
                if im.size != (w, h):
                    raise DreamPrintError(f"image is {im.size[0]} x {im.size[1]}, its name says "
                                          f"{w} x {h}", p)
                a = np.asarray(im.convert("RGBA"))
        except DreamPrintError:
            raise
        except Exception as exc:  # noqa: BLE001 - Pillow raises assorted types on bad input
            raise DreamPrintError(f"cannot read PNG slice: {exc}", p) from None
        data[k] = a[::-1]
    return data, np.array([f[3] for f in files])


def read_raw_volume(path: Path) -> tuple[np.ndarray, int]:
    """(rgba float32 (d, h, w, 4) with row index growing with y, cascade) of a raw export."""
    m = RAW_NAME.match(path.name)
    if not m:
        raise DreamPrintError("an instant-ngp raw volume is named WxHxD_CASCADE.bin", path)
    w, h, d, cascade = (int(v) for v in m.groups())
    if min(w, h, d) < 1 or cascade > 16:
        raise DreamPrintError("raw volume name gives an empty grid or cascade > 16", path)
    need = w * h * d * 16
    have = path.stat().st_size
    if have != need:
        raise DreamPrintError(f"{w} x {h} x {d} RGBA float32 needs {need:,} bytes, the file has "
                              f"{have:,}", path)
    try:
        a = np.fromfile(path, "<f4").reshape(d, h, w, 4)
    except (OSError, ValueError) as exc:
        raise DreamPrintError(f"cannot read raw volume: {exc}", path) from None
    return a[:, ::-1], cascade


def open_path(path: Path, fmt: str = "ingp-volume", *, voxel_size: float | None = None,
              depth: float = PNG_DEPTH, colour_encoding: str = "srgb") -> DenseSource:
    """Open an instant-ngp PNG slice folder (or one slice of it) or a raw volume (or its
    folder).  ``voxel_size``: instant-ngp units per voxel of a PNG sequence; ``depth``: the
    alpha depth it was exported with (instant-ngp's 0.01)."""
    if colour_encoding not in ("srgb", "linear"):
        raise DreamPrintError(f"colour_encoding must be 'srgb' or 'linear', got "
                              f"{colour_encoding!r}", path)
    folder = path if path.is_dir() else path.parent
    raw_file = path if path.suffix.lower() == ".bin" else None
    if raw_file is None and path.is_dir() and not _pngs(folder):
        raws = _raws(folder)
        if raws:
            raw_file = raws[0][1]
    if raw_file is not None:
        return _open_raw(raw_file, colour_encoding)
    rgba, files = read_png_slices(folder)
    nz, ny, nx, _ = rgba.shape
    vs = 1.0 / max(nx, ny, nz) if voxel_size is None else float(voxel_size)
    if not (np.isfinite(vs) and vs > 0):
        raise DreamPrintError(f"voxel_size must be a positive number, got {voxel_size}", path)
    if not (np.isfinite(depth) and depth > 0):
        raise DreamPrintError(f"depth must be a positive number, got {depth}", path)
    a = rgba[..., 3].astype(np.float32)
    data = np.empty((nz, ny, nx, 4), np.float32)
    data[..., 0] = -np.log1p(-np.minimum(a, 254.5) / 255.0) / np.float32(depth)
    inv = np.where(a > 0, 1.0 / np.maximum(a, 1.0), 0.0).astype(np.float32)
    for c in range(3):
        data[..., 1 + c] = np.minimum(rgba[..., c] * inv, 1.0)
    info = {"name": "alpha -> density", "class": "InstantNGP RGBA PNG slices",
            "shape": [nx, ny, nz], "active_voxels": int(np.count_nonzero(a)),
            "min": float(data[..., 0].min()), "max": float(data[..., 0].max()),
            "dtype": "uint8", "bounds": [[0.0, 0.0, 0.0], [nx * vs, ny * vs, nz * vs]],
            "voxel_size": vs, "alpha_depth": float(depth),
            "density": "-ln(1 - A/255) / depth per instant-ngp unit"}
    vol = DenseVolume(data, (0.5 * vs,) * 3, (vs,) * 3, cell_centred=True)
    return DenseSource(str(folder), "InstantNGP RGBA PNG slices", vol, colour_encoding,
                       grids_info=[info])


def _open_raw(path: Path, colour_encoding: str) -> DenseSource:
    rgba, cascade = read_raw_volume(path)
    d, h, w, _ = rgba.shape
    data = np.empty((d, h, w, 4), np.float32)
    data[..., 0] = rgba[..., 3]
    data[..., 1:] = rgba[..., :3]
    np.nan_to_num(data, copy=False, nan=0.0, posinf=0.0, neginf=0.0)
    np.maximum(data, 0, out=data)
    np.minimum(data[..., 1:], 1.0, out=data[..., 1:])
    half = 0.5 * (1 << cascade)
    lo = np.full(3, 0.5 - half)
    spacing = (2 * half) / np.array([w, h, d], float)
    info = {"name": "density", "class": f"InstantNGP raw volume, cascade {cascade}",
            "shape": [w, h, d], "active_voxels": int(np.count_nonzero(data[..., 0])),
            "min": float(data[..., 0].min()), "max": float(data[..., 0].max()),
            "dtype": "float32", "bounds": [lo.tolist(), (lo + 2 * half).tolist()],
            "density": "sigma per instant-ngp unit"}
    others = [p.name for c, p in _raws(path.parent) if c != cascade]
    if others:
        info["other_cascades"] = others
    vol = DenseVolume(data, lo + 0.5 * spacing, spacing, cell_centred=True)
    return DenseSource(str(path), "InstantNGP raw volume", vol, colour_encoding,
                       grids_info=[info])
