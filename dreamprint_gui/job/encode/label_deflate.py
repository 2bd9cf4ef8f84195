"""A zlib stream (RFC 1950 / RFC 1951) of a label image's PNG scanlines, encoded from its runs.

Defines
-------
- :func:`label_zlib`: labels (rows, cols) uint8 -> the zlib-compressed PNG image data (IDAT) of
  the image whose pixel is ``palette[label]`` (24-bit RGB) or ``label`` (8-bit indexed), every
  scanline with filter type 0 (None).
- :func:`label_zlib_stack`: the same for a stack of images (a slab's layers) in one compiled
  call.

A slice of a print job holds at most seven distinct pixels, in runs: long runs of background
and single voxels of ink among Clear where the halftone placed them. A general deflate encoder
(libdeflate level 1: ~3.7 ns per voxel here) spends its time hashing and searching for matches
that a run already states, so this one emits the matches directly from the labels, without
building the scanlines (~1 ns per voxel):

- the first pixel of a run is a copy of the last pixel of the same colour (a length-3 match at
  that distance, RFC 1951 section 3.2.5) when that is shorter than its three literal bytes;
- the rest of the run is a match at distance = bytes per pixel (an overlapping copy of the
  pixel before, section 3.2.3), split into matches of at most 258 bytes;
- everything goes into one final block with a dynamic Huffman code (section 3.2.7) fitted once
  to the token statistics of print-job slices (weights below) and built per palette: no
  per-image code building, and about half the size of the fixed code (1.3-1.7x libdeflate level
  1's output on the demo job's slices, at a third to a quarter of its time);
- the Adler-32 of the uncompressed scanlines (RFC 1950 section 8) is advanced per run in
  closed form: a run of r pixels of bytes b_0..b_{p-1} (sum S) adds r*S to s1 and
  p*r*s1 + S*p*r(r-1)/2 + r*sum_k (p-k)*b_k to s2, mod 65521.

The output depends on the labels and palette only (integer code, no CPU-specific path), so a
slice is byte-identical on every machine; any inflater decodes it (tests: zlib, Pillow).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["label_zlib", "label_zlib_stack", "max_zlib_size"]

_ADLER = 65521


def _reverse(code: int, n: int) -> int:
    # Huffman codes are packed most significant bit first into an LSB-first bit stream.
    r = 0
    for _ in range(n):
        r = (r << 1) | (code & 1)
        code >>= 1
    return r


_LEN_BASE = (3, 4, 5, 6, 7, 8, 9, 10, 11, 13, 15, 17, 19, 23, 27, 31, 35, 43, 51, 59, 67, 83, 99,
             115, 131, 163, 195, 227, 258)
_LEN_EXTRA = (0,) * 8 + (1,) * 4 + (2,) * 4 + (3,) * 4 + (4,) * 4 + (5,) * 4 + (0,)
_DIST_BASE = (1, 2, 3, 4, 5, 7, 9, 13, 17, 25, 33, 49, 65, 97, 129, 193, 257, 385, 513, 769, 1025,
              1537, 2049, 3073, 4097, 6145, 8193, 12289, 16385, 24577)
_DIST_EXTRA = (0, 0, 0, 0) + tuple(i // 2 for i in range(2, 28))
_CL_ORDER = (16, 17, 18, 0, 8, 7, 9, 6, 10, 5, 11, 4, 12, 3, 13, 2, 14, 1, 15)

# Symbol frequencies of the run tokens of print-job slices (counted on slices of the demo job,
# 1e8 voxels): the code below is fitted to them. Every symbol keeps a weight, so any image
# encodes; an unusual one is only less compact. Length symbols 257..285, distance codes 0..29.
_LEN_WEIGHTS = (46020, 1, 1, 1434, 1, 1, 1771, 1, 1083, 1, 4233, 664, 720, 607, 4326, 32, 67, 60,
                100, 443, 54, 116, 416, 480, 1238, 976, 806, 667, 7252)
_DIST_WEIGHTS = (1, 1, 30181, 5841, 18285, 1, 3671, 1124, 2075, 1092, 5160, 257, 951, 367, 159,
                 103, 1035, 1239, 387, 469, 405, 215, 231, 105, 102, 32, 50, 10, 19, 1)


def _huffman_lengths(weights, limit: int) -> list[int]:
    """Code lengths of a Huffman code for ``weights`` (> 0), at most ``limit`` bits: weights
    are flattened (halved, kept >= 1) until the tree is shallow enough."""
    import heapq

    w = [max(1, int(x)) for x in weights]
    while True:
        heap = [(x, i, (i,)) for i, x in enumerate(w)]
        heapq.heapify(heap)
        depth = [0] * len(w)
        tie = len(w)
        while len(heap) > 1:
            a = heapq.heappop(heap)
            b = heapq.heappop(heap)
            for i in a[2] + b[2]:
                depth[i] += 1
            heapq.heappush(heap, (a[0] + b[0], tie, a[2] + b[2]))
            tie += 1
        if max(depth) <= limit:
            return [max(d, 1) for d in depth]
        w = [max(1, x // 2) for x in w]


def _canonical(lengths) -> list[int]:
    """Canonical codes of ``lengths`` (RFC 1951 section 3.2.2), bit-reversed for packing."""
    count = [0] * 16
    for n in lengths:
        count[n] += 1
    count[0] = 0
    nxt = [0] * 16
    code = 0
    for b in range(1, 16):
        code = (code + count[b - 1]) << 1
        nxt[b] = code
    out = []
    for n in lengths:
        if n:
            out.append(_reverse(nxt[n], n))
            nxt[n] += 1
        else:
            out.append(0)
    return out


def _header(lit_len: list[int], dist_len: list[int]) -> list[tuple[int, int]]:
    """The bits (value, count) of a dynamic-Huffman block header (RFC 1951 section 3.2.7)."""
    seq = lit_len + dist_len
    toks: list[tuple[int, int, int]] = []  # (code-length symbol, extra value, extra bits)
    i = 0
    while i < len(seq):
        v = seq[i]
        r = 1
        while i + r < len(seq) and seq[i + r] == v:
            r += 1
        if v == 0 and r >= 3:
            r = min(r, 138)
            toks.append((17, r - 3, 3) if r <= 10 else (18, r - 11, 7))
        elif v != 0 and r >= 4:
            r = min(r, 7)  # the value once, then "repeat the previous" 3-6 times
            toks.append((v, 0, 0))
            toks.append((16, r - 4, 2))
        else:
            r = 1
            toks.append((v, 0, 0))
        i += r
    freq = [0] * 19
    for t in toks:
        freq[t[0]] += 1
    used = [k for k in range(19) if freq[k]]
    cl_len = [0] * 19
    if len(used) == 1:
        cl_len[used[0]] = 1
    else:
        for k, n in zip(used, _huffman_lengths([freq[k] for k in used], 7), strict=True):
            cl_len[k] = n
    cl_code = _canonical(cl_len)
    hclen = 19
    while hclen > 4 and cl_len[_CL_ORDER[hclen - 1]] == 0:
        hclen -= 1
    bits = [(1, 1), (2, 2), (len(lit_len) - 257, 5), (len(dist_len) - 1, 5), (hclen - 4, 4)]
    bits += [(cl_len[_CL_ORDER[k]], 3) for k in range(hclen)]
    for sym, extra, nextra in toks:
        bits.append((cl_code[sym], cl_len[sym]))
        if nextra:
            bits.append((extra, nextra))
    return bits


def _tables(palette_bytes: tuple[int, ...]):
    """The block's Huffman code for images whose pixels hold ``palette_bytes``: the header bits,
    then per literal, length (3..258, with its extra bits) and distance (1..32768, with its
    extra bits) the bit-reversed pattern and its length."""
    lit_w = [1] * 256
    lit_w[0] = 5000                  # the filter byte of every row
    for b in palette_bytes:
        lit_w[b] = max(lit_w[b], 20)  # a pixel's bytes, where no earlier copy is in reach
    lit_w += [1] + list(_LEN_WEIGHTS)  # end of block, lengths
    lit_len = _huffman_lengths(lit_w, 15)
    dist_len = _huffman_lengths(_DIST_WEIGHTS, 15)
    lit_code = _canonical(lit_len)
    dist_code = _canonical(dist_len)
    hdr = _header(lit_len, dist_len)
    lit = np.array(lit_code, np.int64)
    lit_n = np.array(lit_len, np.int64)
    ln = np.zeros(259, np.int64)
    ln_n = np.zeros(259, np.int64)
    for length in range(3, 259):
        s = 28 if length == 258 else max(i for i in range(29) if _LEN_BASE[i] <= length)
        sym = 257 + s
        ln[length] = lit[sym] | ((length - _LEN_BASE[s]) << lit_n[sym])
        ln_n[length] = lit_n[sym] + _LEN_EXTRA[s]
    ds = np.zeros(32769, np.int64)
    ds_n = np.zeros(32769, np.int64)
    c = 0
    for d in range(1, 32769):
        while c < 29 and _DIST_BASE[c + 1] <= d:
            c += 1
        ds[d] = dist_code[c] | ((d - _DIST_BASE[c]) << dist_len[c])
        ds_n[d] = dist_len[c] + _DIST_EXTRA[c]
    # the kernel writes a length-3 match and a run's match (distance 1 or 3) as one 32-bit put
    if ln_n[3] + ds_n.max() > 32 or ln_n.max() + max(ds_n[1], ds_n[3]) > 32:
        raise RuntimeError("slice deflate: a match code longer than 32 bits")
    return (np.array([b[0] for b in hdr], np.int64), np.array([b[1] for b in hdr], np.int64),
            lit, lit_n, ln, ln_n, ds, ds_n)


_TABLES: dict[tuple[int, ...], tuple] = {}


def _tables_for(palette_bytes: tuple[int, ...]):
    t = _TABLES.get(palette_bytes)
    if t is None:
        if len(_TABLES) > 16:
            _TABLES.clear()
        t = _TABLES[palette_bytes] = _tables(palette_bytes)
    return t


def max_zlib_size(rows: int, cols: int) -> int:
    """An upper bound on :func:`label_zlib`'s output: a pixel costs at most three 15-bit
    literals, a row's filter byte one, plus the header (< 400 bytes)."""
    return rows * (6 * cols + 2) + 512


@njit(cache=True, nogil=True)
def _put(out, n, acc, nb, code, length):
    # ``length`` <= 32 and fewer than 32 bits pending: the 64-bit accumulator cannot overflow.
    # The low word is stored every time and kept only once it is full: no branch to mispredict
    # (the buffer has slack for the extra stores).
    acc |= code << nb
    nb += length
    out[n] = acc & 0xFF
    out[n + 1] = (acc >> 8) & 0xFF
    out[n + 2] = (acc >> 16) & 0xFF
    out[n + 3] = (acc >> 24) & 0xFF
    full = nb >= 32
    n += 4 if full else 0
    acc = (acc >> 32) if full else acc
    nb = (nb - 32) if full else nb
    return n, acc, nb


@njit(cache=True, nogil=True)
def _zlib_runs(labels, pix, bpp, hdr, hdr_n, lit, lit_n, ln, ln_n, ds, ds_n, out):
    """Deflate the scanlines of ``labels`` into ``out``; returns the number of bytes written, or
    -1 if a label has no entry in ``pix`` (n_labels, 3) int64, each label's pixel bytes (the
    first ``bpp`` used). ``hdr``, ``hdr_n``: the block header's bits; the rest: the code."""
    h, w = labels.shape
    nlab = pix.shape[0]
    # per label: its literal bytes' bit count, their sum and their Adler-32 s2 weight
    pat_n = np.zeros(nlab, np.int64)
    s_sum = np.zeros(nlab, np.int64)
    s_wt = np.zeros(nlab, np.int64)
    for q in range(nlab):
        for k in range(bpp):
            b = pix[q, k]
            pat_n[q] += lit_n[b]
            s_sum[q] += b
            s_wt[q] += (bpp - k) * b
    last = np.full(nlab, -(1 << 40), np.int64)  # stream offset of the last pixel of each label
    starts = np.empty(w + 1, np.int64)
    n = 0
    out[0] = 0x78  # CMF: deflate, 32 KiB window
    out[1] = 0x01  # FLG: fastest, no dictionary; (0x78 << 8 | 0x01) % 31 == 0
    n = 2
    acc = np.int64(0)
    nb = np.int64(0)
    for t in range(hdr.shape[0]):  # BFINAL = 1, BTYPE = 10 (dynamic Huffman), the code
        n, acc, nb = _put(out, n, acc, nb, hdr[t], hdr_n[t])
    s1 = np.int64(1)
    s2 = np.int64(0)
    pos = np.int64(0)
    for y in range(h):
        n, acc, nb = _put(out, n, acc, nb, lit[0], lit_n[0])  # filter type 0
        # reduced once per row: within a row of W bytes s1 < 65521 + 255 W and s2 < 65521 +
        # W (65521 + 255 W), far inside int64 for any printable width
        s1 %= _ADLER
        s2 = (s2 + s1) % _ADLER
        pos += 1
        # the row's runs: starts found without a data-dependent branch (the end of a run of
        # random length is a mispredicted jump per run otherwise)
        starts[0] = 0
        m = 1
        for x in range(1, w):
            starts[m] = x
            m += 1 if labels[y, x] != labels[y, x - 1] else 0
        starts[m] = w
        for t in range(m):
            x = starts[t]
            r = starts[t + 1] - x
            q = labels[y, x]
            if q >= nlab:
                return -1
            d = pos - last[q]
            if bpp >= 3 and d <= 32768 and ln_n[3] + ds_n[d] < pat_n[q]:
                n, acc, nb = _put(out, n, acc, nb, ln[3] | (ds[d] << ln_n[3]),
                                  ln_n[3] + ds_n[d])
            else:
                for k in range(bpp):
                    n, acc, nb = _put(out, n, acc, nb, lit[pix[q, k]], lit_n[pix[q, k]])
            rem = (r - 1) * bpp
            while rem > 258:
                take = 258 if rem - 258 >= 3 else rem - 3
                n, acc, nb = _put(out, n, acc, nb, ln[take] | (ds[bpp] << ln_n[take]),
                                  ln_n[take] + ds_n[bpp])
                rem -= take
            if rem >= 3 or rem == 0:  # one match for the rest of the run, or nothing
                some = rem > 0
                n, acc, nb = _put(out, n, acc, nb,
                                  (ln[rem] | (ds[bpp] << ln_n[rem])) if some else 0,
                                  (ln_n[rem] + ds_n[bpp]) if some else 0)
            else:  # one byte per pixel, a run of 2 or 3
                for _ in range(rem):
                    n, acc, nb = _put(out, n, acc, nb, lit[pix[q, 0]], lit_n[pix[q, 0]])
            s2 += bpp * r * s1 + s_sum[q] * (bpp * r * (r - 1) // 2) + r * s_wt[q]
            s1 += r * s_sum[q]
            pos += r * bpp
            last[q] = pos - bpp
    n, acc, nb = _put(out, n, acc, nb, lit[256], lit_n[256])  # end of block
    while nb > 0:
        out[n] = acc & 0xFF
        acc >>= 8
        nb -= 8
        n += 1
    s1 %= _ADLER
    s2 %= _ADLER
    for k in range(4):
        out[n + k] = ((s2 << 16 | s1) >> (24 - 8 * k)) & 0xFF
    return n + 4


@njit(cache=True, nogil=True)
def _zlib_stack(stack, pix, bpp, hdr, hdr_n, lit, lit_n, ln, ln_n, ds, ds_n, out, ends):
    n = 0
    for k in range(stack.shape[0]):
        m = _zlib_runs(stack[k], pix, bpp, hdr, hdr_n, lit, lit_n, ln, ln_n, ds, ds_n, out[n:])
        if m < 0:
            return -1
        n += m
        ends[k] = n
    return n


def label_zlib_stack(stack: np.ndarray, palette: np.ndarray | None,
                     n_labels: int = 256) -> list[bytes]:
    """:func:`label_zlib` of each image of ``stack`` (n, rows, cols) uint8, any strides."""
    if stack.ndim != 3 or stack.dtype != np.uint8:
        raise ValueError("labels must be uint8 images")
    if not 1 <= n_labels <= 256:
        raise ValueError(f"an 8-bit image has 1 to 256 labels, not {n_labels}")
    n, h, w = stack.shape
    if n == 0:
        return []
    if palette is None:
        pix = np.zeros((n_labels, 3), np.int64)
        pix[:, 0] = np.arange(n_labels)
        bpp = 1
    else:
        pix = np.ascontiguousarray(palette, dtype=np.int64).reshape(-1, 3)
        bpp = 3
    tables = _tables_for(tuple(sorted({int(b) for b in pix[:, :bpp].ravel()})))
    out = np.empty(n * max_zlib_size(h, w), np.uint8)
    ends = np.zeros(n, np.int64)
    total = _zlib_stack(stack, pix, bpp, *tables, out, ends)
    if total < 0:
        raise ValueError(f"a label is not below the palette's {len(pix)} entries")
    buf = out[:total].tobytes()  # the bound is ~50x what a slice takes: copy only what it took
    starts = [0, *ends[:-1].tolist()]
    return [buf[a:b] for a, b in zip(starts, ends.tolist(), strict=True)]


def label_zlib(labels: np.ndarray, palette: np.ndarray | None, n_labels: int = 256) -> bytes:
    """zlib stream of the PNG scanlines (filter 0) of ``labels`` (rows, cols) uint8, any strides.

    ``palette`` (n, 3) uint8: 24-bit RGB pixels ``palette[label]``; None: 8-bit indexed pixels
    equal to the label, which must be below ``n_labels`` (the PLTE's length).
    """
    return label_zlib_stack(labels[None], palette, n_labels)[0]
