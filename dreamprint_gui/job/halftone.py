"""3D halftoning: per-voxel ink concentrations -> one material label per voxel.

Defines
-------
- :func:`blue_noise_mask`: a tileable 3D void-and-cluster threshold mask (Ulichney 1993, "The
  void-and-cluster method for dither array generation", SPIE 1913), built for the printer's
  anisotropic voxel with a Gaussian energy filter in *physical* distance, generated once and
  cached on disk (platformdirs user cache folder, keyed by shape, voxel and algorithm version).
- :func:`uniform_hash`: the counter-based generator of the paper's stochastic halftoning: a
  SplitMix64 finaliser (Steele, Lea & Flood 2014) of (seed, x, y, z), i.e. a pure function of
  the voxel's position, so the result does not depend on slab size, worker count or scheduler.
- :class:`Halftoner`: the settings of one job (method, seed, mask, background); its
  :meth:`Halftoner.layer_into` labels one layer with a numba kernel that releases the GIL.
- :func:`pick_label`: the rule for one voxel (the reference); :func:`label_rows`: the same rule
  for a run of voxels, branch-free so LLVM vectorises it; :func:`fg_threshold`,
  :func:`tile_layout`, :func:`scatter_labels`: the other per-row parts. All compiled (numba) and
  shared with the print job's fused per-layer kernel.
- :func:`fraction_variance_ratio`: the quality metric (variance of local fractions in boxes
  relative to the binomial i.i.d. variance, and the mean bias).

Label of a voxel with concentrations c (6 inks, INKS order, summing to s) and threshold
t in [0, 1): the first ink i with t * s < c_0 + ... + c_i. With t uniform on [0, 1) every ink is
drawn with probability c_i / s exactly (the paper's section 4.3 "3D stochastic halftoning" for
``random``). ``blue-noise`` uses as t the mask's rank threshold (rank + 0.5) / N at the voxel's
position: the mask tiles the job (tile grid shifted by a seed-dependent offset), and each tile
reads it toroidally shifted by its own offset, a hash of (seed, tile index) (:func:`tile_layout`).
Over a tile each threshold occurs once, so every ink's fraction equals its concentration to
within 1/N (unbiased), while neighbouring voxels get thresholds far apart (low local variance).
The per-tile shift is what keeps a rarely used ink (the lowest thresholds) from landing on the
same cell of every tile: with one shift for the whole job its voxels formed a regular lattice
at the tile period (~1 mm); with a shift per tile they fall at independent places in each tile,
and the mask being toroidal, inside a tile the pattern stays seamless blue noise
(``benchmarks/bench_halftone.py`` measures the peak at the tile period). Voxels whose density
is below the background threshold get the background label (Clear or empty) without drawing.
"""

from __future__ import annotations

import hashlib
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numba import njit

from dreamprint_gui.core.profile import INKS

__all__ = ["blue_noise_mask", "mask_shape_for_voxel", "uniform_hash", "Halftoner",
           "pick_label", "label_rows", "fg_threshold", "threshold_row", "scatter_labels",
           "scatter_counts",
           "tile_layout", "TILING", "mask_build_estimate", "MASK_BUILD_SECONDS",
           "fraction_variance_ratio", "box_for_voxel", "HALFTONE_METHODS", "MASK_VERSION"]

HALFTONE_METHODS = ("blue-noise", "random")
MASK_VERSION = 1
TILING = "per-tile toroidal shift: splitmix64(seed, tile)"
_NO_MASK = np.zeros((1, 1, 1), np.float32)
# Order of the inks along the threshold axis. The first band [0, c) of a void-and-cluster mask
# is its best blue-noise set; the last band is the complement of one (also blue); middle bands
# are differences of two. Black, the most visible speck, goes first; Clear, usually the largest
# share, last.
INK_ORDER: tuple[int, ...] = (3, 0, 1, 2, 4, 5)  # K, C, M, Y, W, Cl
_MASK_VOXELS = 32768  # 32^3: generation is O(N^2) ~ 2 s once, then cached
_SIGMA_VOXELS = 1.5   # Ulichney's filter width, in geometric-mean voxel sizes


# ----------------------------------------------------------------------------- randomness
@njit(cache=True, nogil=True, inline="always")
def _mix64(z):
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


@njit(cache=True, nogil=True, inline="always")
def _uniform(seed, x, y, z):
    # Coordinates are packed in 21 bits each (2,097,152 voxels per axis: far above any tray).
    key = (np.uint64(x) & np.uint64(0x1FFFFF)) | ((np.uint64(y) & np.uint64(0x1FFFFF))
                                                  << np.uint64(21)) \
        | ((np.uint64(z) & np.uint64(0x1FFFFF)) << np.uint64(42))
    h = _mix64(key + _mix64(seed + np.uint64(0x9E3779B97F4A7C15)))
    return np.float64(h >> np.uint64(11)) * (1.0 / 9007199254740992.0)  # 53 bits -> [0, 1)


@njit(cache=True, nogil=True)
def _uniform_grid(seed, x0, y0, z0, nx, ny, nz, out):
    for k in range(nz):
        for j in range(ny):
            for i in range(nx):
                out[k, j, i] = _uniform(seed, x0 + i, y0 + j, z0 + k)


def uniform_hash(seed: int, shape_zyx: tuple[int, int, int],
                 origin_xyz: tuple[int, int, int] = (0, 0, 0)) -> np.ndarray:
    """The position-keyed uniform [0, 1) numbers of a block of voxels, (z, y, x) ordered."""
    nz, ny, nx = shape_zyx
    out = np.empty((nz, ny, nx), dtype=np.float64)
    _uniform_grid(np.uint64(seed & 0xFFFFFFFFFFFFFFFF), origin_xyz[0], origin_xyz[1],
                  origin_xyz[2], nx, ny, nz, out)
    return out


# ----------------------------------------------------------------------------- blue noise
def mask_shape_for_voxel(voxel_mm: tuple[float, float, float],
                         n_voxels: int = _MASK_VOXELS) -> tuple[int, int, int]:
    """(nz, ny, nx) of a mask about physically cubic for this voxel, ~``n_voxels`` in total."""
    vx, vy, vz = voxel_mm
    inv = np.array([1 / vx, 1 / vy, 1 / vz])
    side = (n_voxels / np.prod(inv)) ** (1 / 3)
    n = np.maximum(8, np.round(side * inv)).astype(int)
    return int(n[2]), int(n[1]), int(n[0])


@njit(cache=True, nogil=True)
def _add_energy(energy, kernel, shape, idx, sign):
    nz, ny, nx = shape
    z0 = idx // (ny * nx)
    y0 = (idx // nx) % ny
    x0 = idx % nx
    p = 0
    for z in range(nz):
        dz = (z - z0) % nz
        for y in range(ny):
            dy = (y - y0) % ny
            for x in range(nx):
                energy[p] += sign * kernel[dz, dy, (x - x0) % nx]
                p += 1


@njit(cache=True, nogil=True)
def _tightest_cluster(ones, energy):
    best, bi = -1e300, -1
    for i in range(ones.size):
        if ones[i] and energy[i] > best:
            best, bi = energy[i], i
    return bi


@njit(cache=True, nogil=True)
def _largest_void(ones, energy):
    best, bi = 1e300, -1
    for i in range(ones.size):
        if not ones[i] and energy[i] < best:
            best, bi = energy[i], i
    return bi


@njit(cache=True, nogil=True)
def _void_and_cluster(shape, kernel, initial):
    nz, ny, nx = shape
    n = nz * ny * nx
    ones = initial.copy()
    energy = np.zeros(n)
    for i in range(n):
        if ones[i]:
            _add_energy(energy, kernel, shape, i, 1.0)
    # Phase 0: relax the initial random pattern into a homogeneous one.
    for _ in range(10 * n):
        c = _tightest_cluster(ones, energy)
        ones[c] = False
        _add_energy(energy, kernel, shape, c, -1.0)
        v = _largest_void(ones, energy)
        ones[v] = True
        _add_energy(energy, kernel, shape, v, 1.0)
        if v == c:
            break
    prototype = ones.copy()
    n_ones = 0
    for i in range(n):
        if prototype[i]:
            n_ones += 1
    rank = np.empty(n, dtype=np.int64)
    # Phase 1: rank the prototype's points by removing tightest clusters.
    r = n_ones - 1
    while r >= 0:
        c = _tightest_cluster(ones, energy)
        ones[c] = False
        _add_energy(energy, kernel, shape, c, -1.0)
        rank[c] = r
        r -= 1
    # Restore the prototype, then phases 2-3: fill the largest voids. Because the filter's sum
    # is constant, the largest void of the ones is the tightest cluster of the zeros, so one rule
    # covers both halves of Ulichney's procedure.
    energy[:] = 0.0
    for i in range(n):
        ones[i] = prototype[i]
        if ones[i]:
            _add_energy(energy, kernel, shape, i, 1.0)
    for r in range(n_ones, n):
        v = _largest_void(ones, energy)
        ones[v] = True
        _add_energy(energy, kernel, shape, v, 1.0)
        rank[v] = r
    return rank


def _cache_dir() -> Path:
    from platformdirs import user_cache_dir

    env = os.environ.get("DREAMPRINT_CACHE")
    return Path(env) if env else Path(user_cache_dir("dreamprint")) / "halftone"


def _generate_mask(shape_zyx: tuple[int, int, int],
                   voxel_mm: tuple[float, float, float]) -> np.ndarray:
    nz, ny, nx = shape_zyx
    vx, vy, vz = voxel_mm
    sigma = _SIGMA_VOXELS * (vx * vy * vz) ** (1 / 3)

    def d(nn, v):  # toroidal distance in mm
        k = np.arange(nn)
        return np.minimum(k, nn - k) * v

    dz, dy, dx = np.meshgrid(d(nz, vz), d(ny, vy), d(nx, vx), indexing="ij")
    kernel = np.exp(-(dx**2 + dy**2 + dz**2) / (2 * sigma**2))
    rng = np.random.default_rng(20240611)
    n = nz * ny * nx
    initial = np.zeros(n, dtype=np.bool_)
    initial[rng.choice(n, size=max(1, n // 10), replace=False)] = True
    rank = _void_and_cluster((nz, ny, nx), kernel, initial)
    return ((rank.reshape(nz, ny, nx) + 0.5) / n).astype(np.float32)


# Wall seconds of a mask build (void and cluster, O(N^2), the same N for every voxel) on the
# 2-core development machine, its kernel compiled (a first run's compile is the conversion
# kernels' notice): bench_preflight.py --samples --modes cold, 2026-12-02, the builds beyond
# set-up in an idle machine's seconds (divided by the slowdown probe, load 5-8): 1.5, 2.3 and
# 5.5 s (metaimage, vox, demo); 15 s until then, which counted a compile
MASK_BUILD_SECONDS = 3.0


def _mask_path(voxel_mm: tuple[float, float, float], shape: tuple[int, int, int]) -> Path:
    key = hashlib.sha256(repr((MASK_VERSION, tuple(shape), tuple(round(v, 9) for v in voxel_mm),
                               _SIGMA_VOXELS)).encode()).hexdigest()[:16]
    return _cache_dir() / f"void-and-cluster-{key}.npy"


def mask_build_estimate(voxel_mm: tuple[float, float, float]) -> float | None:
    """Estimated seconds :func:`blue_noise_mask` will spend building this voxel's mask, or None
    when the cache holds it."""
    if _mask_path(voxel_mm, mask_shape_for_voxel(voxel_mm)).is_file():
        return None
    return MASK_BUILD_SECONDS


def blue_noise_mask(voxel_mm: tuple[float, float, float],
                    shape_zyx: tuple[int, int, int] | None = None) -> np.ndarray:
    """Threshold mask (nz, ny, nx) float32 with values (rank + 0.5) / N, cached on disk."""
    shape = shape_zyx or mask_shape_for_voxel(voxel_mm)
    path = _mask_path(voxel_mm, tuple(shape))
    try:
        m = np.load(path)
        if m.shape == tuple(shape) and m.dtype == np.float32:
            return m
    except (OSError, ValueError):
        pass
    m = _generate_mask(tuple(shape), voxel_mm)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        with open(tmp, "wb") as f:
            np.save(f, m)
        os.replace(tmp, path)  # atomic: concurrent workers never read a half-written mask
    except OSError:
        pass  # a read-only cache only costs the regeneration next time
    return m


# ----------------------------------------------------------------------------- kernel
@njit(cache=True, nogil=True, inline="always")
def pick_label(c, t, order, bg_label):
    """Label of a voxel with concentrations ``c`` (6, INKS order) and threshold ``t`` in [0, 1):
    the first ink (in ``order``) whose cumulative concentration exceeds ``t`` times the total."""
    s = 0.0
    for m in range(6):
        s += c[m]
    t = t * s
    # The first q with t < acc_q (acc_q = c_order[0] + ... + c_order[q]) is the number of q
    # for which t < max(acc_0..acc_q) fails: counted without a data-dependent branch, which the
    # blue-noise thresholds would mispredict about once per voxel. The running maximum keeps
    # this exact even for a negative concentration; the maximum skips a NaN sum, so a NaN (in t,
    # or in acc from some q on) gives the same answer as the early-exit search.
    acc = 0.0
    hi = -math.inf
    n = 0
    for q in range(6):
        acc += c[order[q]]
        hi = acc if acc > hi else hi
        n += 0 if t < hi else 1
    if n < 6:
        return order[n]
    # t*s rounded onto the total: take the last ink with a non-zero share
    for q in range(5, -1, -1):
        if c[order[q]] > 0.0:
            return order[q]
    return bg_label  # all-zero concentrations cannot come from the tables; be safe


@njit(cache=True, nogil=True, inline="always")
def _tile_shift(seed, tx, ty, tz):
    # 63 bits of the tile's hash, independent of _uniform's (other salt).
    key = (np.uint64(tx) & np.uint64(0x1FFFFF)) | ((np.uint64(ty) & np.uint64(0x1FFFFF))
                                                   << np.uint64(21)) \
        | ((np.uint64(tz) & np.uint64(0x1FFFFF)) << np.uint64(42))
    return _mix64(key + _mix64(seed + np.uint64(0xD1B54A32D192ED03)))


@njit(cache=True, nogil=True)
def tile_layout(x0, nx, y0, ny, z, ox, oy, oz, mz, my, mx, seed):
    """Where each voxel of layer ``z`` (columns ``x0 ..``, rows ``y0 ..``) reads the mask.

    The mask tiles the job with its seed offset (``ox, oy, oz``); tile (Tx, Ty, Tz) reads it
    toroidally shifted by (sx, sy, sz), a hash of (seed, Tx, Ty, Tz). Returns ``cols`` (2, nx):
    per column its x inside its tile and its tile's index from the first; ``rows`` (2, ny) the
    same for rows; ``tiles`` (nty, ntx, 3): per tile of the layer the mask plane it reads
    (``(z + oz + sz) mod mz``), sy and sx. :func:`fg_threshold` combines them.
    """
    cols = np.empty((2, nx), np.int64)
    rows = np.empty((2, ny), np.int64)
    tx0 = (x0 + ox) // mx
    ty0 = (y0 + oy) // my
    for i in range(nx):
        a = x0 + i + ox
        cols[0, i] = a % mx
        cols[1, i] = a // mx - tx0
    for j in range(ny):
        a = y0 + j + oy
        rows[0, j] = a % my
        rows[1, j] = a // my - ty0
    ntx = (x0 + nx - 1 + ox) // mx - tx0 + 1 if nx > 0 else 0
    nty = (y0 + ny - 1 + oy) // my - ty0 + 1 if ny > 0 else 0
    zz = z + oz
    tz = zz // mz
    tiles = np.empty((max(nty, 1), max(ntx, 1), 3), np.int64)
    for b in range(nty):
        for a in range(ntx):
            h = _tile_shift(seed, tx0 + a, ty0 + b, tz)
            tiles[b, a, 0] = (zz % mz + np.int64(h % np.uint64(mz))) % mz
            tiles[b, a, 1] = np.int64((h >> np.uint64(21)) % np.uint64(my))
            tiles[b, a, 2] = np.int64((h >> np.uint64(42)) % np.uint64(mx))
    return cols, rows, tiles


@njit(cache=True, nogil=True, inline="always")
def fg_threshold(method, mask, tiles, cols, rows, seed, i, j, x, y, z):
    """Threshold of the voxel in column ``i``, row ``j`` at position (x, y, z): the blue-noise
    mask's (method 0; read through :func:`tile_layout`'s ``tiles, cols, rows``: the tile's
    shifted mask) or the position hash's (1)."""
    if method == 0:
        my = mask.shape[1]
        mx = mask.shape[2]
        t = tiles[rows[1, j], cols[1, i]]
        yy = rows[0, j] + t[1]
        yy -= my if yy >= my else 0
        xx = cols[0, i] + t[2]
        xx -= mx if xx >= mx else 0
        return np.float64(mask[t[0], yy, xx])
    return _uniform(seed, x, y, z)


@njit(cache=True, nogil=True, error_model="numpy")
def threshold_row(method, mask, tiles, cols, rows, seed, j, x0, y, z, i0, i1, out):
    """:func:`fg_threshold` of columns ``i0 <= i < i1`` of row ``j`` (position ``(x0 + i, y,
    z)``) into ``out[i]`` (float64), the same values. Blue noise: per tile along the row, its
    mask row (``tiles[rows[1, j], a]``), rotated by the tile's x shift, copied as two runs;
    random: the position hash of each voxel."""
    if method != 0:
        for i in range(i0, i1):
            out[i] = _uniform(seed, x0 + i, y, z)
        return
    my = mask.shape[1]
    mx = mask.shape[2]
    b = rows[1, j]
    ry = rows[0, j]
    i = i0
    while i < i1:
        a = cols[1, i]
        c0 = cols[0, i]
        e = min(i1, i + mx - c0)  # the tile's last column + 1: cols[0] runs c0 .. mx - 1
        yy = ry + tiles[b, a, 1]
        yy -= my if yy >= my else 0
        mrow = mask[tiles[b, a, 0], yy]
        xx = c0 + tiles[b, a, 2]
        xx -= mx if xx >= mx else 0
        n1 = min(e - i, mx - xx)
        for q in range(n1):
            out[i + q] = np.float64(mrow[xx + q])
        for q in range(n1, e - i):
            out[i + q] = np.float64(mrow[q - n1])
        i = e


@njit(cache=True, nogil=True, error_model="numpy")
def label_rows(C, tt, m, order, bg_label, lab):
    """:func:`pick_label` of voxels ``0 .. m-1``, 8-16 at a time (branch-free, vectorised).

    ``C`` (6, >= m) float32 concentrations, INKS order, one row per ink; ``tt`` (>= m,) float64
    thresholds in [0, 1); ``order`` (6,) ink order -> ``lab`` (>= m,) uint8. Gives exactly
    :func:`pick_label`'s answers, NaN and negative concentrations included.
    """
    o0 = order[0]
    o1 = order[1]
    o2 = order[2]
    o3 = order[3]
    o4 = order[4]
    o5 = order[5]
    bg = np.uint8(bg_label)
    for k in range(m):
        s = 0.0
        s += C[0, k]
        s += C[1, k]
        s += C[2, k]
        s += C[3, k]
        s += C[4, k]
        s += C[5, k]
        t = tt[k] * s
        c0 = C[o0, k]
        c1 = C[o1, k]
        c2 = C[o2, k]
        c3 = C[o3, k]
        c4 = C[o4, k]
        c5 = C[o5, k]
        acc = 0.0
        hi = -math.inf
        n = 0
        acc += c0
        hi = acc if acc > hi else hi
        n += 0 if t < hi else 1
        acc += c1
        hi = acc if acc > hi else hi
        n += 0 if t < hi else 1
        acc += c2
        hi = acc if acc > hi else hi
        n += 0 if t < hi else 1
        acc += c3
        hi = acc if acc > hi else hi
        n += 0 if t < hi else 1
        acc += c4
        hi = acc if acc > hi else hi
        n += 0 if t < hi else 1
        acc += c5
        hi = acc if acc > hi else hi
        n += 0 if t < hi else 1
        # n == 6 (t * s rounded onto the total): the last ink with a non-zero share
        fb = bg
        fb = np.uint8(o0) if c0 > 0.0 else fb
        fb = np.uint8(o1) if c1 > 0.0 else fb
        fb = np.uint8(o2) if c2 > 0.0 else fb
        fb = np.uint8(o3) if c3 > 0.0 else fb
        fb = np.uint8(o4) if c4 > 0.0 else fb
        fb = np.uint8(o5) if c5 > 0.0 else fb
        r = fb
        r = np.uint8(o5) if n == 5 else r
        r = np.uint8(o4) if n == 4 else r
        r = np.uint8(o3) if n == 3 else r
        r = np.uint8(o2) if n == 2 else r
        r = np.uint8(o1) if n == 1 else r
        r = np.uint8(o0) if n == 0 else r
        lab[k] = r


@njit(cache=True, nogil=True, error_model="numpy")
def _halftone_layer(conc, density, threshold, bg_label, z, method, mask, ox, oy, oz, seed,
                    order, x0, y0, out, counts, conc_sums):
    ny, nx = out.shape
    mz, my, mx = mask.shape
    cols, rows, tiles = tile_layout(x0, nx, y0, ny, z, ox, oy, oz, mz, my, mx, seed)
    idx = np.empty(nx, np.int64)
    C = np.empty((6, nx), np.float32)
    tt = np.empty(nx)
    lab = np.empty(nx, np.uint8)
    for j in range(ny):
        m = 0
        for i in range(nx):
            idx[m] = i
            m += 1 if density[j * nx + i] >= threshold else 0  # NaN is background
        for k in range(m):
            i = idx[k]
            for q in range(6):
                C[q, k] = conc[j * nx + i, q]
            tt[k] = fg_threshold(method, mask, tiles, cols, rows, seed, i, j, x0 + i, y0 + j, z)
        label_rows(C, tt, m, order, bg_label, lab)
        row = out[j]
        for i in range(nx):
            row[i] = bg_label
        counts[bg_label] += nx - m
        conc_sums[bg_label] += nx - m
        scatter_labels(row, idx, 0, lab, C, m, counts, conc_sums)


@njit(cache=True, nogil=True, inline="always")
def scatter_counts(row, idx, k0, lab, m, counts):
    """Put labels ``lab[0 .. m-1]`` of foreground voxels ``idx[k0 ..]`` into ``row`` and add
    their label counts to ``counts``.

    The tallies run in two local integers of four 16-bit fields each (labels 0-3, 4-6), over
    runs of at most 65535 voxels so that no field overflows: one shifted addition per voxel,
    vectorised (seven counters cost seven comparisons and additions per voxel: 0.98 -> 0.23 ns
    per voxel). Kept in arrays, every voxel would wait for the previous voxel's store to the
    same counter."""
    for k in range(m):
        row[idx[k0 + k]] = lab[k]
    for a in range(0, m, 65535):
        lo = np.int64(0)
        hi = np.int64(0)
        for k in range(a, min(m, a + 65535)):  # this loop vectorises
            v = np.int64(lab[k])
            lo += np.int64(1) << (np.int64(16) * v) if v < 4 else np.int64(0)
            hi += np.int64(1) << (np.int64(16) * (v - 4)) if v >= 4 else np.int64(0)
        for q in range(4):
            counts[q] += (lo >> np.int64(16 * q)) & np.int64(0xFFFF)
        for q in range(3):
            counts[4 + q] += (hi >> np.int64(16 * q)) & np.int64(0xFFFF)


@njit(cache=True, nogil=True, inline="always")
def scatter_labels(row, idx, k0, lab, C, m, counts, conc_sums):
    """:func:`scatter_counts`, and the intended concentrations ``C`` (6+, >= m), one row per
    ink, added to ``conc_sums`` one voxel at a time."""
    scatter_counts(row, idx, k0, lab, m, counts)
    s0 = s1 = s2 = s3 = s4 = s5 = 0.0
    for k in range(m):
        s0 += C[0, k]
        s1 += C[1, k]
        s2 += C[2, k]
        s3 += C[3, k]
        s4 += C[4, k]
        s5 += C[5, k]
    conc_sums[0] += s0
    conc_sums[1] += s1
    conc_sums[2] += s2
    conc_sums[3] += s3
    conc_sums[4] += s4
    conc_sums[5] += s5


@dataclass(frozen=True)
class Halftoner:
    """Halftoning settings of a job; picklable (the mask travels to process/cluster workers)."""

    method: str
    seed: int
    voxel_mm: tuple[float, float, float]
    threshold: float = 0.0   # density (1/mm) below which a voxel is background
    bg_label: int = 5        # 5 = Clear, 6 = empty
    mask: np.ndarray | None = None
    order: tuple[int, ...] = INK_ORDER
    offset_xyz: tuple[int, int, int] = (0, 0, 0)

    @classmethod
    def create(cls, method: str, seed: int, voxel_mm: tuple[float, float, float],
               threshold: float = 0.0, bg_label: int = 5) -> Halftoner:
        if method not in HALFTONE_METHODS:
            raise ValueError(f"unknown halftoning {method!r} (use {', '.join(HALFTONE_METHODS)})")
        mask = blue_noise_mask(voxel_mm) if method == "blue-noise" else None
        off = (0, 0, 0)
        if mask is not None:  # seed-dependent toroidal offset of the mask
            mz, my, mx = mask.shape
            u = uniform_hash(int(seed), (1, 1, 3), (0, 0, 2**20))[0, 0]
            off = (int(u[0] * mx), int(u[1] * my), int(u[2] * mz))
        return cls(method, int(seed), tuple(voxel_mm), float(threshold), int(bg_label), mask,
                   INK_ORDER, off)

    def describe(self) -> dict:
        d = {"method": self.method, "seed": self.seed}
        if self.mask is not None:
            d.update(mask="void-and-cluster", mask_shape_zyx=list(self.mask.shape),
                     mask_version=MASK_VERSION,
                     mask_sha256=hashlib.sha256(self.mask.tobytes()).hexdigest()[:16],
                     mask_sigma_voxels=_SIGMA_VOXELS, tiling=TILING)
        else:
            d.update(generator="splitmix64(seed, x, y, z)")
        d["ink_order"] = [INKS[i] for i in self.order]
        return d

    def layer_into(self, conc: np.ndarray, density: np.ndarray, z: int, out: np.ndarray,
                   counts: np.ndarray, conc_sums: np.ndarray, x0: int = 0, y0: int = 0) -> None:
        """Label layer ``z``: ``conc`` (ny*nx, 6) float32, ``density`` (ny*nx,) -> ``out``.

        ``counts`` (7,) int64 and ``conc_sums`` (7,) float64 are accumulated (labels and
        intended concentrations, background voxels counting 1 for the background label).
        """
        _halftone_layer(conc, density, np.float32(self.threshold), self.bg_label, z,
                        *self.kernel_args(), x0, y0, out, counts, conc_sums)

    def kernel_args(self) -> tuple:
        """(method code, mask, ox, oy, oz, seed, order) as the compiled kernels take them
        (:func:`fg_threshold`, :func:`label_rows`)."""
        mask = self.mask if self.mask is not None else _NO_MASK
        ox, oy, oz = self.offset_xyz
        return (0 if self.method == "blue-noise" else 1, mask, ox, oy, oz,
                np.uint64(self.seed & 0xFFFFFFFFFFFFFFFF), np.asarray(self.order, dtype=np.int64))

    def block(self, conc: np.ndarray, origin_xyz: tuple[int, int, int] = (0, 0, 0)) -> np.ndarray:
        """Labels of a (nz, ny, nx, 6) concentration block (no background) - for tests/metrics."""
        nz, ny, nx, _ = conc.shape
        out = np.empty((nz, ny, nx), dtype=np.uint8)
        counts = np.zeros(7, np.int64)
        sums = np.zeros(7, np.float64)
        dens = np.ones(ny * nx, np.float32)
        for k in range(nz):
            c = np.ascontiguousarray(conc[k].reshape(ny * nx, 6), dtype=np.float32)
            self.layer_into(c, dens, origin_xyz[2] + k, out[k], counts, sums,
                            origin_xyz[0], origin_xyz[1])
        return out


def fraction_variance_ratio(labels: np.ndarray, conc6: np.ndarray,
                            box_zyx: tuple[int, int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Quality of a halftone of a constant-concentration block.

    Splits ``labels`` (nz, ny, nx) into non-overlapping boxes of ``box_zyx`` voxels; per ink,
    returns (variance of the boxes' fractions / binomial variance c(1-c)/n of i.i.d. sampling,
    mean fraction - c). i.i.d. sampling gives a ratio of 1; lower is smoother.
    """
    bz, by, bx = box_zyx
    nz, ny, nx = (s - s % b for s, b in zip(labels.shape, box_zyx, strict=True))
    lab = labels[:nz, :ny, :nx]
    n = bz * by * bx
    ratios = np.full(6, np.nan)
    bias = np.zeros(6)
    for m in range(6):
        c = float(conc6[m])
        f = (lab == m).reshape(nz // bz, bz, ny // by, by, nx // bx, bx).sum(axis=(1, 3, 5)) / n
        bias[m] = f.mean() - c
        if 0 < c < 1:
            ratios[m] = f.var() / (c * (1 - c) / n)
    return ratios, bias


def box_for_voxel(voxel_mm: tuple[float, float, float], width_mm: float = 0.25
                  ) -> tuple[int, int, int]:
    """(z, y, x) voxels of a box about ``width_mm`` wide on this voxel grid."""
    return tuple(max(1, math.floor(width_mm / v + 0.5)) for v in voxel_mm[::-1])
