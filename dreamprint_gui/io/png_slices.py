"""Fast PNG encoding of material-label slices.

Defines
-------
- :func:`encode_labels_png`: labels (rows, cols) uint8 + palette (n, 3) -> PNG bytes, either
  24-bit RGB (colour type 2) or 8-bit indexed (colour type 3 with a PLTE chunk).
- :func:`png_bytes`: wrap raw filtered scanlines into a PNG file (signature, IHDR, IDAT, IEND).
- :func:`read_png_labels`: decode a slice back to labels through Pillow (for checks).

PNG (ISO/IEC 15948, W3C PNG 2nd ed.): the image data is a zlib stream (RFC 1950) of the
scanlines, each preceded by its filter-type byte (section 9; type 0 = None is used here: with
random halftone labels no filter predicts better, and it keeps the encoder one pass). The zlib
stream is produced at level 1 by libdeflate (``imagecodecs.deflate_encode``), several times
faster than Pillow's encoder (MEASURED.md), whose portable match finder gives the same bytes on
every machine. zlib-ng was measured 5x faster on nearly uniform slices (0.6 vs 3.3 ns per voxel)
but is not used: it picks SIMD code paths by CPU at run time and its output bytes then differ
between machines (zlib-ng issue #795), which would break byte-identical jobs on a mixed Dask
cluster. Chunks carry a CRC-32 over type + data (section 5.3), computed with :func:`zlib.crc32`.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np
from numba import njit

from ..errors import DreamPrintError

__all__ = ["encode_labels_png", "png_bytes", "read_png_labels"]

_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _chunk(kind: bytes, data: bytes) -> bytes:
    return (struct.pack(">I", len(data)) + kind + data
            + struct.pack(">I", zlib.crc32(data, zlib.crc32(kind)) & 0xFFFFFFFF))


@njit(cache=True, nogil=True)
def _rows_rgb(labels, palette, out):
    h, w = labels.shape
    stride = 1 + 3 * w
    for r in range(h):
        base = r * stride
        out[base] = 0  # filter type None
        p = base + 1
        for c in range(w):
            lab = labels[r, c]
            out[p] = palette[lab, 0]
            out[p + 1] = palette[lab, 1]
            out[p + 2] = palette[lab, 2]
            p += 3


@njit(cache=True, nogil=True)
def _rows_index(labels, out):
    h, w = labels.shape
    stride = 1 + w
    for r in range(h):
        base = r * stride
        out[base] = 0
        for c in range(w):
            out[base + 1 + c] = labels[r, c]


def png_bytes(width: int, height: int, colour_type: int, idat: bytes | bytearray,
              palette: np.ndarray | None = None) -> bytes:
    """A PNG file from an already zlib-compressed IDAT stream (bit depth 8)."""
    ihdr = struct.pack(">IIBBBBB", width, height, 8, colour_type, 0, 0, 0)
    parts = [_SIGNATURE, _chunk(b"IHDR", ihdr)]
    if colour_type == 3:
        if palette is None:
            raise ValueError("an indexed PNG needs a palette")
        parts.append(_chunk(b"PLTE", np.ascontiguousarray(palette, dtype=np.uint8).tobytes()))
    parts += [_chunk(b"IDAT", idat), _chunk(b"IEND", b"")]
    return b"".join(parts)


def encode_labels_png(labels: np.ndarray, palette: np.ndarray, mode: str = "rgb",
                      level: int = 1) -> bytes:
    """PNG bytes of a label image: pixel = ``palette[label]``.

    ``labels`` (rows, cols) uint8 (any strides: a transposed or flipped view is fine);
    ``palette`` (n, 3) uint8 with every label < n; ``mode`` "rgb" or "palette".
    """
    import imagecodecs

    if labels.ndim != 2 or labels.dtype != np.uint8:
        raise ValueError("labels must be a 2-D uint8 array")
    pal = np.ascontiguousarray(palette, dtype=np.uint8)
    h, w = labels.shape
    if h == 0 or w == 0:
        raise ValueError("a PNG needs at least one row and one column")
    if mode == "rgb":
        raw = np.empty(h * (1 + 3 * w), dtype=np.uint8)
        _rows_rgb(labels, pal, raw)
        ctype = 2
    elif mode == "palette":
        raw = np.empty(h * (1 + w), dtype=np.uint8)
        _rows_index(labels, raw)
        ctype = 3
    else:
        raise ValueError(f"unknown PNG mode {mode!r}")
    idat = imagecodecs.deflate_encode(raw, level=level)  # zlib-wrapped (RFC 1950)
    return png_bytes(w, h, ctype, idat, pal if ctype == 3 else None)


def read_png_labels(path: str | Path, palette: np.ndarray) -> np.ndarray:
    """Labels of a slice written with ``palette``; raises if a pixel has another colour."""
    from PIL import Image

    try:
        with Image.open(path) as im:
            im.load()
            if im.mode == "P":
                idx = np.asarray(im)
                pal = np.asarray(im.getpalette()[: 3 * (int(idx.max()) + 1)],
                                 dtype=np.uint8).reshape(-1, 3)
                rgb = pal[idx]
            else:
                rgb = np.asarray(im.convert("RGB"))
    except OSError as exc:
        raise DreamPrintError(f"unreadable PNG slice: {exc}", path) from None
    pal = np.asarray(palette, dtype=np.uint8)
    key = (rgb[..., 0].astype(np.int32) << 16) | (rgb[..., 1].astype(np.int32) << 8) | rgb[..., 2]
    pkey = (pal[:, 0].astype(np.int32) << 16) | (pal[:, 1].astype(np.int32) << 8) | pal[:, 2]
    order = np.argsort(pkey)
    pos = np.searchsorted(pkey[order], key)
    pos = np.clip(pos, 0, len(pkey) - 1)
    ok = pkey[order][pos] == key
    if not ok.all():
        bad = rgb[~ok][0]
        raise DreamPrintError(f"pixel colour {tuple(int(v) for v in bad)} is no material code "
                              "of the job's printer", path)
    return order[pos].astype(np.uint8)
