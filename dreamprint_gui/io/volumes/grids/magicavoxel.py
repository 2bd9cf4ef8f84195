"""MagicaVoxel ``.vox`` voxel models: palette colours, a solid density the operator sets.

Defines :func:`read_vox`, :class:`VoxSource`, :func:`open_path` and :data:`DEFAULT_PALETTE`.

Written to the RIFF-style chunk specification (ephtracy/voxel-model,
"MagicaVoxel-file-format-vox.txt" and "-vox-extension.txt"): ``VOX `` + version, a ``MAIN``
chunk whose children are ``PACK``, ``SIZE``/``XYZI`` pairs (one per model), ``RGBA`` (palette:
colour index i in 1..255 is entry i-1), and the scene graph ``nTRN``/``nGRP``/``nSHP`` that
places models (translation ``_t``: the model's centre ``floor(size/2)``; rotated instances are
refused).  Unknown chunks are skipped.  The file's x, y, z are used as is (MagicaVoxel is
z-up, like the printer).  Voxels are unit cubes, sampled nearest by default (a voxel model is
crisp: sharp edges, the palette's colours unmixed) or trilinearly with ``sampling="linear"``
(``--sampling linear``: smooth edges, colours blended density-weighted as for any dense grid);
density is ``solid_density`` per source unit in every filled voxel.
"""

from __future__ import annotations

import math
import struct
from pathlib import Path

import numpy as np
from numba import njit

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes.base import (
    PrintGrid,
    SlabBuffers,
    check_slab,
    occupied_ranges,
    voxel_centres,
)
from dreamprint_gui.io.volumes.dense import DenseVolume

__all__ = ["read_vox", "VoxSource", "open_path", "DEFAULT_PALETTE"]

MAX_DIM = 2048
MAX_VOXELS = 1 << 30


def _default_palette() -> np.ndarray:
    """The spec's default palette, (256, 4) uint8 RGBA indexed by colour index (0 unused)."""
    steps = [0xFF, 0xCC, 0x99, 0x66, 0x33, 0x00]
    pal = [(0, 0, 0, 0)]
    for r in steps:
        for g in steps:
            for b in steps:
                pal.append((r, g, b, 255))
    pal.pop()                                     # the cube's black corner is not used
    ramp = [0xEE, 0xDD, 0xBB, 0xAA, 0x88, 0x77, 0x55, 0x44, 0x22, 0x11]
    pal += [(v, 0, 0, 255) for v in ramp] + [(0, v, 0, 255) for v in ramp] \
        + [(0, 0, v, 255) for v in ramp] + [(v, v, v, 255) for v in ramp]
    return np.array(pal, np.uint8)


DEFAULT_PALETTE = _default_palette()


class _Reader:
    def __init__(self, data: bytes, path: Path):
        self.data = data
        self.path = path

    def fail(self, what: str):
        raise DreamPrintError(f"damaged .vox: {what}", self.path)

    def i32(self, pos: int) -> int:
        if pos + 4 > len(self.data):
            self.fail("unexpected end of file")
        return struct.unpack_from("<i", self.data, pos)[0]

    def string(self, pos: int) -> tuple[str, int]:
        n = self.i32(pos)
        if n < 0 or pos + 4 + n > len(self.data):
            self.fail("bad string length")
        return self.data[pos + 4:pos + 4 + n].decode("utf-8", "replace"), pos + 4 + n

    def dict(self, pos: int) -> tuple[dict, int]:
        n = self.i32(pos)
        if n < 0 or n > 10_000:
            self.fail("bad dictionary size")
        pos += 4
        out = {}
        for _ in range(n):
            k, pos = self.string(pos)
            v, pos = self.string(pos)
            out[k] = v
        return out, pos


def read_vox(path: Path):
    """Models and palette: ([(size xyz, voxels (N, 4) uint8 x y z index, offset xyz)], palette)."""
    data = path.read_bytes()
    r = _Reader(data, path)
    if data[:4] != b"VOX ":
        raise DreamPrintError("not a MagicaVoxel file (no 'VOX ' magic)", path)
    if data[8:12] != b"MAIN":
        r.fail("no MAIN chunk")
    pos = 20 + r.i32(12)                         # skip MAIN's own content
    end = min(len(data), pos + r.i32(16))
    sizes, voxels, palette = [], [], None
    nodes: dict[int, tuple[str, dict, list[int], list[int]]] = {}
    while pos + 12 <= end:
        cid = data[pos:pos + 4]
        n, m = r.i32(pos + 4), r.i32(pos + 8)
        body = pos + 12
        if n < 0 or m < 0 or body + n > len(data):
            r.fail(f"chunk {cid!r} runs past the end of the file")
        if cid == b"SIZE":
            s = tuple(r.i32(body + 4 * k) for k in range(3))
            if not all(1 <= v <= MAX_DIM for v in s):
                r.fail(f"model size {s} out of range 1..{MAX_DIM}")
            sizes.append(s)
        elif cid == b"XYZI":
            count = r.i32(body)
            if count < 0 or 4 + 4 * count > n:
                r.fail(f"XYZI claims {count:,} voxels in a {n:,}-byte chunk")
            voxels.append(np.frombuffer(data, np.uint8, 4 * count, body + 4).reshape(-1, 4))
        elif cid == b"RGBA":
            if n < 1024:
                r.fail("short RGBA palette")
            rgba = np.frombuffer(data, np.uint8, 1024, body).reshape(256, 4)
            palette = np.concatenate([np.zeros((1, 4), np.uint8), rgba[:255]])
        elif cid in (b"nTRN", b"nGRP", b"nSHP"):
            nid = r.i32(body)
            attrs, p = r.dict(body + 4)
            if cid == b"nTRN":
                child = r.i32(p)
                frames = r.i32(p + 12)
                fr, _ = r.dict(p + 16) if frames > 0 else ({}, 0)
                nodes[nid] = ("T", fr, [child], [])
            elif cid == b"nGRP":
                k = r.i32(p)
                if k < 0 or k > 1_000_000:
                    r.fail("bad group size")
                nodes[nid] = ("G", attrs, [r.i32(p + 4 + 4 * q) for q in range(k)], [])
            else:
                k = r.i32(p)
                if k < 0 or k > 1_000_000:
                    r.fail("bad shape size")
                models, q = [], p + 4
                for _ in range(k):
                    models.append(r.i32(q))
                    _, q = r.dict(q + 4)
                nodes[nid] = ("S", attrs, [], models)
        pos = body + n + m
    if len(sizes) != len(voxels) or not sizes:
        r.fail("no model (SIZE/XYZI pairs missing or unmatched)")
    for s, v in zip(sizes, voxels, strict=True):
        if len(v) and (np.any(v[:, 0] >= s[0]) or np.any(v[:, 1] >= s[1])
                       or np.any(v[:, 2] >= s[2])):
            r.fail("voxel outside its model's size")
    placed = _place(nodes, sizes, path)
    models = [(sizes[i], voxels[i], off) for i, off in placed]
    return models, (DEFAULT_PALETTE if palette is None else palette)


def _place(nodes, sizes, path) -> list[tuple[int, tuple[int, int, int]]]:
    """(model id, min-corner offset) per instance, from the scene graph (or all at 0)."""
    if not nodes or 0 not in nodes:
        return [(i, (0, 0, 0)) for i in range(len(sizes))]
    out = []
    stack = [(0, np.zeros(3, np.int64), 0)]
    while stack:
        nid, t, depth = stack.pop()
        if depth > 64 or nid not in nodes:
            continue
        kind, attrs, children, models = nodes[nid]
        if kind == "T":
            if attrs.get("_r", "4") not in ("4",):          # 4 = identity rotation byte
                raise DreamPrintError("rotated model instances are not supported: apply the "
                                      "rotation in MagicaVoxel first", path)
            try:
                dt = np.array([int(v) for v in attrs.get("_t", "0 0 0").split()], np.int64)
            except ValueError:
                raise DreamPrintError("damaged .vox: bad translation", path) from None
            t = t + (dt if dt.shape == (3,) else 0)
        for c in children:
            stack.append((c, t, depth + 1))
        for m in models:
            if 0 <= m < len(sizes):
                s = np.asarray(sizes[m])
                out.append((m, tuple(int(v) for v in t - s // 2)))
    return out or [(i, (0, 0, 0)) for i in range(len(sizes))]


@njit(cache=True, nogil=True)
def _nearest_kernel(idx, iz, iy, ix, rgb_lut, dens_lut, rgb, sigma):
    for k in range(iz.shape[0]):
        a = iz[k]
        for j in range(iy.shape[0]):
            b = iy[j]
            for i in range(ix.shape[0]):
                c = ix[i]
                if a < 0 or b < 0 or c < 0:
                    sigma[k, j, i] = 0.0
                    rgb[k, j, i, 0] = 0.0
                    rgb[k, j, i, 1] = 0.0
                    rgb[k, j, i, 2] = 0.0
                    continue
                p = idx[a, b, c]
                sigma[k, j, i] = dens_lut[p]
                rgb[k, j, i, 0] = rgb_lut[p, 0]
                rgb[k, j, i, 1] = rgb_lut[p, 1]
                rgb[k, j, i, 2] = rgb_lut[p, 2]


class VoxSource:
    """Palette-index voxels (uint8, z y x) over the union of the placed models."""

    def __init__(self, path: Path, models, palette, solid_density: float,
                 sampling: str = "nearest"):
        if sampling not in ("nearest", "linear"):
            raise DreamPrintError(f"sampling must be 'nearest' or 'linear', got {sampling!r}",
                                  path)
        self.sampling = sampling
        self.name = str(path)
        self.format = "MagicaVoxel"
        self.colour_encoding = "srgb"
        if not (np.isfinite(solid_density) and solid_density >= 0):
            raise DreamPrintError(f"solid density must be >= 0, got {solid_density}", path)
        lo = np.min([off for _, _, off in models], axis=0)
        hi = np.max([np.add(off, s) for s, _, off in models], axis=0)
        dims = hi - lo
        if math.prod(int(v) for v in dims) > MAX_VOXELS:
            raise DreamPrintError(f"models spread over {dims.tolist()} voxels: too large", path)
        self.index = np.zeros(tuple(int(v) for v in dims[::-1]), np.uint8)
        self._grids = []
        for n, (s, v, off) in enumerate(models):
            o = np.asarray(off) - lo
            self.index[v[:, 2].astype(np.int64) + o[2], v[:, 1].astype(np.int64) + o[1],
                       v[:, 0].astype(np.int64) + o[0]] = v[:, 3]
            col = v[:, 3]
            self._grids.append({
                "name": f"model {n}", "class": "palette voxels", "shape": list(s),
                "active_voxels": int(np.count_nonzero(col)),
                "min": int(col.min()) if len(col) else None,
                "max": int(col.max()) if len(col) else None, "dtype": "uint8 palette index",
                "bounds": [[float(x) for x in off], [float(x + y) for x, y in zip(off, s,
                                                                                   strict=True)]]})
        self.lo = lo.astype(float)
        self.bounds = (tuple(float(v) for v in lo), tuple(float(v) for v in hi))
        self.rgb_lut = (palette[:, :3].astype(np.float32) / 255.0)
        self.solid_density = float(solid_density)
        self._dense = None
        if sampling == "linear":

            filled = (self.index > 0).astype(np.float32)
            data = np.empty(self.index.shape + (4,), np.float32)
            data[..., 0] = filled
            data[..., 1:4] = self.rgb_lut[self.index] * filled[..., None]  # premultiplied
            # cell-centred unit voxels: sample (i, j, k) sits at lo + (i, j, k) + 1/2
            self._dense = DenseVolume(data, self.lo + 0.5, (1.0, 1.0, 1.0), cell_centred=True)

    def sample_slab(self, grid: PrintGrid, z0: int, z1: int, *, density_scale: float = 1.0,
                    out: SlabBuffers | None = None):
        check_slab(grid, z0, z1)
        if self._dense is not None:
            rgb, sigma = self._dense.sample_density(
                grid, z0, z1, self.solid_density * density_scale / grid.mm_per_unit, out)
            return rgb, sigma
        idx = []
        for a, rng in ((2, (z0, z1)), (1, (0, None)), (0, (0, None))):
            u = np.floor(voxel_centres(grid, a, *rng) - self.lo[a]).astype(np.int64)
            n = self.index.shape[2 - a]
            u[(u < 0) | (u >= n)] = -1
            idx.append(u)
        dens_lut = np.full(256, self.solid_density * density_scale / grid.mm_per_unit,
                           np.float32)
        dens_lut[0] = 0.0
        shape = (len(idx[0]), len(idx[1]), len(idx[2]))
        if out is not None:
            rgb, sigma = out.take(shape)
        else:
            rgb = np.empty(shape + (3,), np.float32)
            sigma = np.empty(shape, np.float32)
        _nearest_kernel(self.index, idx[0], idx[1], idx[2], self.rgb_lut, dens_lut, rgb, sigma)
        return rgb, sigma

    def occupied_bounds(self):
        """The box of the filled voxels (source units), exactly; None if none is filled."""
        ranges = occupied_ranges(self.index > 0)
        if ranges is None:
            return None
        return (tuple(float(self.lo[a] + i0) for a, (i0, _) in enumerate(ranges)),
                tuple(float(self.lo[a] + i1) for a, (_, i1) in enumerate(ranges)))

    def info(self) -> dict:
        return {"format": self.format, "grids": self._grids}


def open_path(path: Path, fmt: str = "magicavoxel", *, solid_density: float = 1.0,
              sampling: str = "nearest") -> VoxSource:
    """Open a .vox file; every filled voxel has density ``solid_density`` (1/source unit);
    ``sampling`` "nearest" (default, crisp) or "linear" (smooth)."""
    models, palette = read_vox(path)
    return VoxSource(path, models, palette, solid_density, sampling)
