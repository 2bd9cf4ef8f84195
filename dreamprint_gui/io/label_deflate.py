"""A zlib stream (RFC 1950 / RFC 1951) of a label image's PNG scanlines, encoded from its runs.

Defines
-------
- :func:`label_zlib`: labels (rows, cols) uint8 -> the zlib-compressed PNG image data (IDAT) of
  the image whose pixel is ``palette[label]`` (24-bit RGB) or ``label`` (8-bit indexed), every
  scanline with filter type 0 (None).

A slice of a print job holds at most seven distinct pixels, in runs: long runs of background
and single voxels of ink among Clear where the halftone placed them. A general deflate encoder
(libdeflate level 1: ~3.7 ns per voxel here) spends its time hashing and searching for matches
that a run already states, so this one emits the matches directly from the labels, without
building the scanlines (~1 ns per voxel):

- the first pixel of a run is a copy of the last pixel of the same colour (a length-3 match at
  that distance, RFC 1951 section 3.2.5) when that is shorter than its three literal bytes;
- the rest of the run is a match at distance = bytes per pixel (an overlapping copy of the
  pixel before, section 3.2.3), split into matches of at most 258 bytes;
- everything goes into one final block with the fixed Huffman codes (section 3.2.6): no code
  tables to build, and a slice's symbols are so few that dynamic codes would save ~20 %;
- the Adler-32 of the uncompressed scanlines (RFC 1950 section 8) is advanced per run in
  closed form: a run of r pixels of bytes b_0..b_{p-1} (sum S) adds r*S to s1 and
  p*r*s1 + S*p*r(r-1)/2 + r*sum_k (p-k)*b_k to s2, mod 65521.

The output depends on the labels and palette only (integer code, no CPU-specific path), so a
slice is byte-identical on every machine; any inflater decodes it (tests: zlib, Pillow).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["label_zlib", "max_zlib_size"]

_ADLER = 65521


def _reverse(code: int, n: int) -> int:
    # Huffman codes are packed most significant bit first into an LSB-first bit stream.
    r = 0
    for _ in range(n):
        r = (r << 1) | (code & 1)
        code >>= 1
    return r


def _fixed_tables():
    """Fixed-Huffman bit patterns (already bit-reversed) and their lengths, RFC 1951 3.2.6."""
    lit = np.zeros(288, np.int64)
    lit_n = np.zeros(288, np.int64)
    for v in range(288):
        if v < 144:
            c, n = 0x30 + v, 8
        elif v < 256:
            c, n = 0x190 + v - 144, 9
        elif v < 280:
            c, n = v - 256, 7
        else:
            c, n = 0xC0 + v - 280, 8
        lit[v], lit_n[v] = _reverse(c, n), n
    # length 3..258 -> symbol 257..285 + extra bits, as one pattern
    base = [3, 4, 5, 6, 7, 8, 9, 10, 11, 13, 15, 17, 19, 23, 27, 31, 35, 43, 51, 59, 67, 83, 99,
            115, 131, 163, 195, 227, 258]
    extra = [0] * 8 + [1] * 4 + [2] * 4 + [3] * 4 + [4] * 4 + [5] * 4 + [0]
    ln = np.zeros(259, np.int64)
    ln_n = np.zeros(259, np.int64)
    for length in range(3, 259):
        s = max(i for i in range(29) if base[i] <= length)
        if length == 258:
            s = 28
        sym = 257 + s
        ln[length] = lit[sym] | ((length - base[s]) << lit_n[sym])
        ln_n[length] = lit_n[sym] + extra[s]
    # distance 1..32768 -> code 0..29 (5 bits) + extra bits
    dbase = [1, 2, 3, 4, 5, 7, 9, 13, 17, 25, 33, 49, 65, 97, 129, 193, 257, 385, 513, 769, 1025,
             1537, 2049, 3073, 4097, 6145, 8193, 12289, 16385, 24577]
    dextra = [0, 0, 0, 0] + [i // 2 for i in range(2, 28)]
    ds = np.zeros(32769, np.int64)
    ds_n = np.zeros(32769, np.int64)
    c = 0
    for d in range(1, 32769):
        while c < 29 and dbase[c + 1] <= d:
            c += 1
        ds[d] = _reverse(c, 5) | ((d - dbase[c]) << 5)
        ds_n[d] = 5 + dextra[c]
    return lit, lit_n, ln, ln_n, ds, ds_n


_LIT, _LIT_N, _LEN, _LEN_N, _DIST, _DIST_N = _fixed_tables()


def max_zlib_size(rows: int, cols: int) -> int:
    """An upper bound on :func:`label_zlib`'s output (at most 27 bits per pixel, 8 per row)."""
    return rows * (4 * cols + 1) + 64


@njit(cache=True, nogil=True)
def _put(out, n, acc, nb, code, length):
    # ``length`` <= 32 and fewer than 32 bits pending: the 64-bit accumulator cannot overflow,
    # and whole 32-bit words are stored at once.
    acc |= code << nb
    nb += length
    if nb >= 32:
        out[n] = acc & 0xFF
        out[n + 1] = (acc >> 8) & 0xFF
        out[n + 2] = (acc >> 16) & 0xFF
        out[n + 3] = (acc >> 24) & 0xFF
        acc >>= 32
        nb -= 32
        n += 4
    return n, acc, nb


@njit(cache=True, nogil=True)
def _zlib_runs(labels, pix, bpp, lit, lit_n, ln, ln_n, ds, ds_n, out):
    """Deflate the scanlines of ``labels`` into ``out``; returns the number of bytes written, or
    -1 if a label has no entry in ``pix`` (n_labels, 3) int64, each label's pixel bytes (the
    first ``bpp`` used)."""
    h, w = labels.shape
    nlab = pix.shape[0]
    # per label: its literal bytes as one pattern, their sum and their Adler-32 s2 weight
    pat = np.zeros(nlab, np.int64)
    pat_n = np.zeros(nlab, np.int64)
    s_sum = np.zeros(nlab, np.int64)
    s_wt = np.zeros(nlab, np.int64)
    for q in range(nlab):
        for k in range(bpp):
            b = pix[q, k]
            pat[q] |= lit[b] << pat_n[q]
            pat_n[q] += lit_n[b]
            s_sum[q] += b
            s_wt[q] += (bpp - k) * b
    last = np.full(nlab, -(1 << 40), np.int64)  # stream offset of the last pixel of each label
    n = 0
    out[0] = 0x78  # CMF: deflate, 32 KiB window
    out[1] = 0x01  # FLG: fastest, no dictionary; (0x78 << 8 | 0x01) % 31 == 0
    n = 2
    acc = np.int64(0)
    nb = np.int64(0)
    n, acc, nb = _put(out, n, acc, nb, 3, 3)  # BFINAL = 1, BTYPE = 01 (fixed Huffman)
    s1 = np.int64(1)
    s2 = np.int64(0)
    pos = np.int64(0)
    for y in range(h):
        n, acc, nb = _put(out, n, acc, nb, lit[0], lit_n[0])  # filter type 0
        s2 = (s2 + s1) % _ADLER
        pos += 1
        x = 0
        while x < w:
            q = labels[y, x]
            if q >= nlab:
                return -1
            e = x + 1
            while e < w and labels[y, e] == q:
                e += 1
            r = e - x
            d = pos - last[q]
            if bpp >= 3 and d <= 32768 and ln_n[3] + ds_n[d] < pat_n[q]:
                n, acc, nb = _put(out, n, acc, nb, ln[3] | (ds[d] << ln_n[3]),
                                  ln_n[3] + ds_n[d])
            else:
                n, acc, nb = _put(out, n, acc, nb, pat[q], pat_n[q])
            rem = (r - 1) * bpp
            if rem >= 3:
                while rem > 0:
                    take = rem
                    if take > 258:
                        take = 258 if rem - 258 >= 3 else rem - 3
                    n, acc, nb = _put(out, n, acc, nb, ln[take] | (ds[bpp] << ln_n[take]),
                                      ln_n[take] + ds_n[bpp])
                    rem -= take
            else:
                for _ in range(r - 1):
                    n, acc, nb = _put(out, n, acc, nb, pat[q], pat_n[q])
            s2 = (s2 + bpp * r * s1 + s_sum[q] * (bpp * r * (r - 1) // 2) + r * s_wt[q]) % _ADLER
            s1 = (s1 + r * s_sum[q]) % _ADLER
            pos += r * bpp
            last[q] = pos - bpp
            x = e
    n, acc, nb = _put(out, n, acc, nb, lit[256], lit_n[256])  # end of block
    while nb > 0:
        out[n] = acc & 0xFF
        acc >>= 8
        nb -= 8
        n += 1
    for k in range(4):
        out[n + k] = ((s2 << 16 | s1) >> (24 - 8 * k)) & 0xFF
    return n + 4


def label_zlib(labels: np.ndarray, palette: np.ndarray | None, n_labels: int = 256) -> bytes:
    """zlib stream of the PNG scanlines (filter 0) of ``labels`` (rows, cols) uint8, any strides.

    ``palette`` (n, 3) uint8: 24-bit RGB pixels ``palette[label]``; None: 8-bit indexed pixels
    equal to the label, which must be below ``n_labels`` (the PLTE's length).
    """
    h, w = labels.shape
    if palette is None:
        pix = np.zeros((n_labels, 3), np.int64)
        pix[:, 0] = np.arange(n_labels)
        bpp = 1
    else:
        pix = np.ascontiguousarray(palette, dtype=np.int64).reshape(-1, 3)
        bpp = 3
    out = np.empty(max_zlib_size(h, w), np.uint8)
    n = _zlib_runs(labels, pix, bpp, _LIT, _LIT_N, _LEN, _LEN_N, _DIST, _DIST_N, out)
    if n < 0:
        raise ValueError(f"a label is not below the palette's {len(pix)} entries")
    return out[:n].tobytes()
