"""Density alignment (paper section 4.1, eqs. 11-13): Clear to lower sigma, K/W grey to raise it.

Defines
-------
- :class:`Alignment`: six-ink concentrations (INKS order) on the simplex, achieved sigma, and the
  report of voxels that could not reach their target.
- :func:`align_density`: exact alignment (vectorised root finding on the KM density of the real
  inks, Clear's small K and S included): sigma of the result equals the target to ~1e-10
  relative wherever the target is reachable.
- :func:`lookup_and_align_into`: the fused, compiled (numba, nogil, one core) lookup + alignment
  for the streaming print job; no KM at run time: it interpolates the tables' per-node sigma
  curves (sigma at Clear dilutions rho = 1 .. 1/32, log-log piecewise linear in rho; sigma with
  10 % grey, linear in the grey fraction). ``benchmarks/bench_gamut.py`` prints its speed and its
  sigma error against :func:`align_density`.
- :func:`align_rows`: that kernel's alignment of a run of voxels (branch-free, vectorised),
  which the print job's per-layer kernel calls directly; :func:`kernel_table`: the table the
  lookup reads (the packed fields padded to :data:`LANES` float32 per node, interpolated in
  float32 as whole vectors, tetrahedral, by :func:`interpolate_block`).
- :func:`lookup_runs`: the same interpolation for a block whose voxels come in runs of one
  colour, once per run and copied along it (the same bits; :func:`lookup_align_block` takes it
  when the runs average :data:`RUN_MIN` voxels or more).
- :func:`uniform_lanes`: the same lanes for every voxel of a block from one colour (a source
  of one colour: the lookup is done once per layer, and a block needs only its targets and
  :func:`align_block`, the alignment half of :func:`lookup_align_block`).
- :func:`predicted_appearance`: what a voxel will look like after lookup + alignment (GUI).

Lowering (eq. 12): ``C = rho C* + (1 - rho) Cl``. With an ideal Clear (K = S = 0) the mixture's
T(t) is C*'s T(rho t); the real Clear is included by solving sigma(C) = target for rho exactly.
Targets below pure Clear's sigma give rho = 0 and are reported as clamped low.
Raising (eq. 13): ``C = rho+ C* + (1 - rho+) X`` with X = rho_K K + (1 - rho_K) W of the target's
brightness (eq. 11, brightness table), the grey fraction ``1 - rho+ <= 0.1`` (the paper's "upper
limit of rho+ 0.1" bounds the grey). Targets beyond 10 % grey, or where the grey is not denser
than C* (bright colours: X is mostly white, whose sigma is low), are reported as clamped high.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numba as nb
import numpy as np
from numpy.typing import ArrayLike, NDArray

from dreamprint_gui.core.kernels.aligned import zeros_line_aligned
from dreamprint_gui.core.kernels.vec16 import prefetch, transpose16x13, weighted_sum16
from dreamprint_gui.core.kernels.vector_math import exp2_f32, log2_f32
from dreamprint_gui.core.profile import INKS, InkProfile, default_profile
from dreamprint_gui.gamut.forward import N_COLOUR_INKS
from dreamprint_gui.gamut.grey import grey_concentrations, rho_k_for
from dreamprint_gui.gamut.tables import (
    CLEAR_KNOTS,
    F_CONC,
    F_GREY,
    F_SIGMA,
    GREY_MAX,
    ColourTables,
    lookup,
    mixture_sigma,
)
from dreamprint_gui.physics.colorimetry import observer_for
from dreamprint_gui.physics.mixture import mixture_colour

__all__ = ["Alignment", "AlignCounts", "align_density", "lookup_and_align_into",
           "predicted_appearance", "interpolate_block", "align_rows", "clean_rgb",
           "stage_voxel", "finish_staging", "lookup_align_block", "block_buffers",
           "kernel_table", "interpolate_nodes", "count_runs", "lookup_runs", "RUN_MIN", "LANES",
           "uniform_lanes", "align_block",
           "ROW_BLOCK", "SOLID_TARGET", "ROW_STRIDE", "K_TARGET", "K_RHOK"]

_I_K = INKS.index("K")
_I_W = INKS.index("W")
_I_CL = INKS.index("Cl")


@dataclass(frozen=True)
class Alignment:
    """Result of density alignment; leading shape that of the voxels."""

    conc: NDArray[np.float64]  # (..., 6) INKS order
    sigma: NDArray[np.float64]  # (...) achieved sigma, 1/mm
    clamped: NDArray[np.int8]  # -1 below reach (too thin), +1 above reach (too dense), 0 exact
    n_clamped_low: int
    n_clamped_high: int
    max_shortfall_low: float  # 1/mm: achieved - target, worst too-thin voxel
    max_shortfall_high: float  # 1/mm: target - achieved, worst too-dense voxel

    @property
    def max_shortfall(self) -> float:
        return max(self.max_shortfall_low, self.max_shortfall_high)


@dataclass(frozen=True)
class AlignCounts:
    n_clamped_low: int
    n_clamped_high: int
    max_shortfall_low: float
    max_shortfall_high: float


def _solve_on_line(profile: InkProfile, a: NDArray, b: NDArray, sa: NDArray, sb: NDArray,
                   target: NDArray, rtol: float = 1e-11) -> tuple[NDArray, NDArray]:
    """w in [0, 1] with sigma((1 - w) a + w b) = target, sigma(a) = sa <= target <= sb = sigma(b).

    Illinois (modified regula falsi) on all rows at once: superlinear and always bracketed.
    """
    lo = np.zeros(target.shape)
    hi = np.ones(target.shape)
    flo = sa - target
    fhi = sb - target
    w = np.clip(np.where(fhi > flo, -flo / np.where(fhi > flo, fhi - flo, 1.0), 0.5), 0.0, 1.0)
    sig = np.empty(target.shape)
    todo = np.ones(target.shape, dtype=bool)
    side = np.zeros(target.shape, dtype=np.int8)
    for _ in range(100):
        idx = np.flatnonzero(todo)
        if idx.size == 0:
            break
        wi = w[idx]
        s = mixture_sigma(profile, (1.0 - wi)[:, None] * a[idx] + wi[:, None] * b[idx])
        sig[idx] = s
        f = s - target[idx]
        done = np.abs(f) <= rtol * np.maximum(target[idx], 1e-300)
        todo[idx[done]] = False
        up = f < 0
        lo_i, hi_i, flo_i, fhi_i, sd = lo[idx], hi[idx], flo[idx], fhi[idx], side[idx]
        lo_i = np.where(up, wi, lo_i)
        flo_i = np.where(up, f, flo_i)
        hi_i = np.where(up, hi_i, wi)
        fhi_i = np.where(up, fhi_i, f)
        # Illinois: halve the stale end's value when the same end moves twice
        fhi_i = np.where(up & (sd == 1), 0.5 * fhi_i, fhi_i)
        flo_i = np.where(~up & (sd == -1), 0.5 * flo_i, flo_i)
        sd = np.where(up, 1, -1).astype(np.int8)
        denom = fhi_i - flo_i
        nxt = np.where(denom > 0, lo_i - flo_i * (hi_i - lo_i) / np.where(denom > 0, denom, 1.0),
                       0.5 * (lo_i + hi_i))
        bad = ~((nxt > lo_i) & (nxt < hi_i))
        nxt = np.where(bad, 0.5 * (lo_i + hi_i), nxt)
        tiny = (hi_i - lo_i) <= 1e-15
        todo[idx[tiny]] = False
        lo[idx], hi[idx], flo[idx], fhi[idx], side[idx] = lo_i, hi_i, flo_i, fhi_i, sd
        w[idx] = np.where(done | tiny, wi, nxt)
    return w, sig


def align_density(tables: ColourTables, rgb: ArrayLike, conc5: ArrayLike,
                  sigma_target: ArrayLike, profile: InkProfile | None = None) -> Alignment:
    """Align mixtures ``conc5`` (..., 5) of colours ``rgb`` (..., 3) to ``sigma_target`` (...).

    ``profile`` must be the tables' profile (checked by fingerprint); default: the built-in one.
    """

    profile = profile or default_profile()
    if profile.fingerprint() != tables.profile_fingerprint:
        raise ValueError("the tables were built for another profile")
    rgb = np.asarray(rgb, dtype=np.float64)
    c5 = np.asarray(conc5, dtype=np.float64)
    shape = c5.shape[:-1]
    target = np.broadcast_to(np.asarray(sigma_target, dtype=np.float64), shape).ravel().copy()
    if not np.all(np.isfinite(target)) or np.any(target < 0):
        raise ValueError("target densities must be finite and >= 0")
    c5 = c5.reshape(-1, N_COLOUR_INKS)
    n = c5.shape[0]
    c_star = np.concatenate([c5, np.zeros((n, 1))], axis=1)
    clear = np.zeros((n, len(INKS)))
    clear[:, _I_CL] = 1.0
    s_star = mixture_sigma(profile, c_star)
    solid = target >= np.float32(SOLID_TARGET)  # solid content: rho = 1 (align_rows)
    target[solid] = s_star[solid]
    s_clear = np.full(n, tables.sigma_clear)
    out = c_star.copy()
    sigma = s_star.copy()
    clamped = np.zeros(n, dtype=np.int8)

    low = target < s_star
    floor = low & (target <= s_clear)  # even pure Clear is denser than the target
    out[floor] = clear[floor]
    sigma[floor] = s_clear[floor]
    clamped[floor & (target < s_clear)] = -1
    m = low & ~floor
    if m.any():
        rho, s = _solve_on_line(profile, clear[m], c_star[m], s_clear[m], s_star[m], target[m])
        out[m] = rho[:, None] * c_star[m] + (1.0 - rho)[:, None] * clear[m]
        sigma[m] = s

    high = target > s_star
    if high.any():
        idx = np.flatnonzero(high)
        grey = grey_concentrations(rho_k_for(tables.brightness_rho_k,
                                             rgb.reshape(-1, 3)[idx].mean(axis=-1)))
        full = (1.0 - GREY_MAX) * c_star[idx] + GREY_MAX * grey
        s_full = mixture_sigma(profile, full)
        reach = s_full >= target[idx]
        useless = s_full <= s_star[idx]  # the grey would not raise the density
        stop = ~reach
        pick = idx[stop & ~useless]
        out[pick] = full[stop & ~useless]
        sigma[pick] = s_full[stop & ~useless]
        clamped[idx[stop]] = 1
        sel = reach & ~useless
        if sel.any():
            i = idx[sel]
            w, s = _solve_on_line(profile, c_star[i], full[sel], s_star[i], s_full[sel],
                                  target[i])
            out[i] = (1.0 - w)[:, None] * c_star[i] + w[:, None] * full[sel]
            sigma[i] = s
    short_low = np.where(clamped == -1, sigma - target, 0.0)
    short_high = np.where(clamped == 1, target - sigma, 0.0)
    return Alignment(out.reshape(shape + (len(INKS),)), sigma.reshape(shape),
                     clamped.reshape(shape), int(np.sum(clamped == -1)),
                     int(np.sum(clamped == 1)), float(short_low.max(initial=0.0)),
                     float(short_high.max(initial=0.0)))


_LOG2_KNOTS = np.log2(np.asarray(CLEAR_KNOTS))
LANES = 16  # fields per node in the kernel's table, padded so a node is one 64-byte line
# Lanes of a kernel-table node (float32), derived once per node so the per-voxel work is the
# interpolation plus a few operations.
K_CONC = 0           # 0..4: C, M, Y, K, W normalised to sum 1 (the tables' are, to rounding)
K_SIG = 5            # 5..10: sigma (1/mm) at the Clear knots rho = 1 .. 1/32
K_GREY = K_SIG + len(CLEAR_KNOTS)  # 11: sigma with 10 % grey (1/mm)
K_RHOK = K_GREY + 1  # 12: rho_K of the K/W grey of the node's brightness (eq. 11)
# A padding lane, free in the table, carries the voxel's target to align_rows.
K_TARGET = K_RHOK + 1  # 13: the voxel's target sigma (1/mm)
# Two more, align_rows' scratch: 1 where a voxel is clamped low / high, else 0.
K_LOW = K_TARGET + 1   # 14
K_HIGH = K_LOW + 1     # 15
ROW_BLOCK = 1024       # voxels per call of align_rows
# interpolate_nodes asks for the four node lines of the voxel this many voxels ahead while it
# sums the current one: colours that change from voxel to voxel (a 1e6-Gaussian scene) miss
# the caches on most nodes of the 64 MB table, and the loads of one voxel's sum alone kept too
# few misses in flight (16-48 ahead measured alike, 8 and 96 less well, with the eight nodes of
# trilinear interpolation)
PREFETCH_AHEAD = 32
# A target at or above this (1/mm) means "solid": the node's own undiluted mixture (rho = 1,
# no Clear, no grey; job.content.SOLID_SIGMA). No medium is this dense.
SOLID_TARGET = 1e30
# Distance between the rows (one per lane) of a block's working arrays: 4096 bytes would put
# a voxel's every lane in the same L1 cache set (the interpolation's transposition measured
# 4.4 -> 0.8 ns per voxel with the padding).
ROW_STRIDE = ROW_BLOCK + 16
_PADDED: dict[int, tuple[np.ndarray, np.ndarray]] = {}
_PADDED_LOCK = threading.Lock()


def kernel_table(tables: ColourTables) -> np.ndarray:
    """The tables' ``packed`` fields as the kernel reads them: :data:`LANES` float32 per node
    (concentrations normalised, sigma at the Clear knots, grey sigma, and the rho_K of the grey
    of the node's brightness, eq. 11, interpolated between nodes like the other lanes: at
    100^3 within 4e-5 (p95; 2.4e-3 at most, next to a kink of the brightness table) of the
    rho_K of the voxel's own brightness, which moves < 2.4e-4 of the mixture between K and W),
    flattened.

    Built once per table (memoised on the identity of ``packed``). The padding lets the
    compiled tetrahedral interpolation load each node as whole vectors.
    """
    key = id(tables.packed)
    with _PADDED_LOCK:  # concurrent slab workers build it once
        hit = _PADDED.get(key)
        if hit is not None and hit[0] is tables.packed:
            return hit[1]
        p = tables.packed
        n = p.shape[0]
        nk = len(CLEAR_KNOTS)
        flat = zeros_line_aligned((n, n, n, LANES), np.float32)
        c = np.maximum(p[..., F_CONC].astype(np.float64), 0.0)
        flat[..., K_CONC:K_CONC + N_COLOUR_INKS] = c / c.sum(-1, keepdims=True)
        flat[..., K_SIG:K_SIG + nk] = p[..., F_SIGMA:F_SIGMA + nk]
        flat[..., K_GREY] = p[..., F_GREY]
        a = np.arange(n, dtype=np.float64) / (n - 1)
        bright = (a[:, None, None] + a[None, :, None] + a[None, None, :]) / 3.0
        flat[..., K_RHOK] = rho_k_for(tables.brightness_rho_k, bright)
        flat = flat.reshape(-1)
        if len(_PADDED) >= 4:
            _PADDED.clear()
        _PADDED[key] = (tables.packed, flat)
        return flat


@nb.njit(cache=True, nogil=True, error_model="numpy")
def interpolate_nodes(flat, n, rgb, m, W, off, A):
    """The interpolated kernel-table lanes of voxels ``0 .. m-1`` (clean sRGB ``rgb``, one row
    per channel) voxel-major: voxel ``k``'s :data:`LANES` lanes at ``A[k * LANES:]``. The first
    two passes of :func:`interpolate_block` (``W``, ``off`` scratch).

    Tetrahedral interpolation (the rule of ICC colour management modules for 3D tables): the
    cell of voxel ``k`` is cut into six tetrahedra along its main diagonal; with its fractions
    sorted ``a >= b >= c`` (the coordinates ``x, y, z`` reordered, each with its node stride
    ``s_a, s_b, s_c``), the lanes are

        v = (1 - a) v_000 + (a - b) v_(s_a) + (b - c) v_(s_a + s_b) + c v_111,

    four nodes instead of trilinear's eight, linear along the grey axis, continuous across
    tetrahedra and cells, and exact at the nodes. Pass 1 (vectorised across voxels) writes the
    four weights into rows 0-3 of ``W``, the first node's offset into ``off[k]`` and the
    second and third nodes' offsets from it into ``off[ROW_BLOCK + k]`` and
    ``off[2 ROW_BLOCK + k]``; pass 2 prefetches the nodes of voxel ``k +``
    :data:`PREFETCH_AHEAD` into the L2 cache while it sums voxel ``k``'s (a hint: no value
    changes). Against trilinear (``bench_label_accuracy.py --only lookup``): dE2000 to the
    direct solve p95 0.0156 -> 0.0120 over all colour sets (radiance 0.040 -> 0.025); the
    lookup of a 1e6-Gaussian scene's colours 37 -> 25 ns per voxel (half the node lines)."""
    RS = ROW_STRIDE
    top = n - 1
    one = np.float32(1.0)
    RB = ROW_BLOCK
    sk = np.int64(LANES)
    sj = np.int64(n * LANES)
    si = np.int64(n * n * LANES)
    s3 = si + sj + sk
    for k in range(m):
        cx = rgb[k] * np.float32(top)
        cy = rgb[RS + k] * np.float32(top)
        cz = rgb[2 * RS + k] * np.float32(top)
        i0 = min(np.int64(cx), top - 1)
        j0 = min(np.int64(cy), top - 1)
        k0 = min(np.int64(cz), top - 1)
        fx = cx - np.float32(i0)
        fy = cy - np.float32(j0)
        fz = cz - np.float32(k0)
        # the fractions sorted a >= b >= c, and the strides of the largest and the smallest
        # (min / max / selects: the loop stays vectorised)
        a = max(max(fx, fy), fz)
        b = max(min(fx, fy), min(max(fx, fy), fz))
        c = min(min(fx, fy), fz)
        sa = si if (fx >= fy) & (fx >= fz) else (sj if fy >= fz else sk)
        sc = sk if (fz <= fx) & (fz <= fy) else (sj if fy <= fx else si)
        W[k] = one - a
        W[RS + k] = a - b
        W[2 * RS + k] = b - c
        W[3 * RS + k] = c
        off[RB + k] = sa
        off[2 * RB + k] = s3 - sc
        off[k] = ((i0 * n + j0) * n + k0) * LANES
    u3 = np.uint64(s3)
    for k in range(m):
        kp = min(k + PREFETCH_AHEAD, m - 1)
        p0 = np.uint64(off[kp])
        prefetch(flat, p0)
        prefetch(flat, p0 + np.uint64(off[RB + kp]))
        prefetch(flat, p0 + np.uint64(off[2 * RB + kp]))
        prefetch(flat, p0 + u3)
        o0 = np.uint64(off[k])
        weighted_sum16(flat, (o0, o0 + np.uint64(off[RB + k]), o0 + np.uint64(off[2 * RB + k]),
                              o0 + u3),
                       (W[k], W[RS + k], W[2 * RS + k], W[3 * RS + k]), A, np.uint64(k * LANES))


@nb.njit(cache=True, nogil=True, error_model="numpy")
def interpolate_block(flat, n, rgb, m, W, off, A, G):
    """Tetrahedral interpolation of the kernel table's node lanes for voxels ``0 .. m-1``.

    ``rgb`` (3 * ROW_STRIDE,) float32 clean sRGB (:func:`clean_rgb`), one row per channel; ``W``
    (4 * ROW_STRIDE,) float32, ``off`` (>= 3 * ROW_BLOCK,) int64 and ``A`` (ROW_BLOCK * LANES,)
    float32 are scratch; writes lanes ``0 .. K_RHOK`` of ``G`` (LANES * ROW_STRIDE,), lane ``q``
    of voxel ``k`` at ``q * ROW_STRIDE + k`` (the layout of :func:`align_rows`).

    Three passes, each in the form the CPU runs fastest: cell and weights of every voxel
    (vectorised across voxels); per voxel the weighted sum of its four nodes' 16 lanes, each node
    one 64-byte vector (:func:`..vec16.weighted_sum16`; a node is one cache line of the aligned
    table) (both :func:`interpolate_nodes`); the lanes of 16 voxels at a time turned into rows
    (:func:`..vec16.transpose16x13`).
    Per lane ``((w0 v0 + w1 v1) + w2 v2) + w3 v3`` in float32, in that order.
    """
    interpolate_nodes(flat, n, rgb, m, W, off, A)
    # whole groups of 16 (ROW_BLOCK is a multiple of 16): lanes past m are never read
    for k0 in range(0, m, 16):
        transpose16x13(A, np.int64(k0 * LANES), G, np.int64(k0), np.int64(ROW_STRIDE))


@nb.njit(cache=True, nogil=True, inline="always")
def clean_rgb(v):
    """A colour channel clamped to [0, 1]; NaN -> 0 (a damaged voxel never indexes outside)."""
    return min(max(v, np.float32(0.0)), np.float32(1.0)) if v == v else np.float32(0.0)


_NK = len(CLEAR_KNOTS)
_LK = np.asarray(_LOG2_KNOTS, dtype=np.float64)
_LK32 = tuple(np.float32(v) for v in _LOG2_KNOTS)


@nb.njit(cache=True, nogil=True, inline="always")
def _bracket(go, t, s_next, sa, sb, la, lb, l_next):
    """One step of the knot search: move to the next bracket while the target stays below."""
    go = go & (t < sb)
    return go, (sb if go else sa), (s_next if go else sb), (lb if go else la), \
        (l_next if go else lb)


@nb.njit(cache=True, nogil=True, error_model="numpy")
def align_rows(F, m, sigma_clear, out):
    """Density alignment (eqs. 12-13) of voxels ``0 .. m-1`` of a block from their node fields.

    ``F`` (LANES * ROW_STRIDE,) float32, lane ``q`` of voxel ``k`` at ``q * ROW_STRIDE + k``: the
    kernel-table lanes (:func:`interpolate_block`; the rho_K of the voxel's grey in lane
    :data:`K_RHOK`) and the target sigma (1/mm; NaN or negative -> 0) in lane
    :data:`K_TARGET`; lanes :data:`K_LOW` and :data:`K_HIGH` are overwritten (scratch). Writes
    ``out`` (8 * ROW_STRIDE,) float32 the same way: rows 0-5 the concentrations (INKS order),
    rows 6 and 7 the shortfall (1/mm) of a voxel clamped low / high, else 0.
    ``m <= ROW_BLOCK``. Returns the numbers of voxels clamped low and high.

    Written for LLVM's loop vectoriser, which then runs 8 voxels per instruction (16 where it
    takes 512-bit vectors; no 64-bit value in the loop, or it would run 4): one row
    per lane with constant strides (so it can rule out overlaps with a single check), every
    voxel through both branches with selects keeping one (no data-dependent jumps or loads),
    the knot search unrolled by hand, log2 / exp2 from :mod:`..vector_math`, all in float32
    (twice the voxels per instruction of float64, which took 1.5-2 ns more per voxel for
    concentrations that agree to ~1e-7). Each voxel's result depends on its own inputs only.
    """
    zero = np.float32(0.0)
    one = np.float32(1.0)
    gmax = np.float32(GREY_MAX)
    sc = np.float32(sigma_clear)
    rl = np.float32(2.0 ** _LK[_NK - 1])
    solid = np.float32(SOLID_TARGET)
    RS = ROW_STRIDE
    for k in range(m):
        s0 = F[(K_SIG + 0) * RS + k]
        t = F[K_TARGET * RS + k]
        t = t if t >= zero else zero
        t = s0 if t >= solid else t  # solid content: the colour's undiluted mixture, rho = 1
        s1 = F[(K_SIG + 1) * RS + k]
        s2 = F[(K_SIG + 2) * RS + k]
        s3 = F[(K_SIG + 3) * RS + k]
        s4 = F[(K_SIG + 4) * RS + k]
        s5 = F[(K_SIG + 5) * RS + k]
        # eq. 12: C = rho C* + (1 - rho) Cl. Below the last knot: linear to pure Clear.
        span = s5 - sc
        span = span if span > np.float32(1e-30) else np.float32(1e-30)
        rho_lin = rl * (t - sc) / span
        # Between knots a and b = a + 1, the first b whose sigma the target reaches: log-log
        # linear, rho = rho_b (rho_a / rho_b)^u, u = log(t / s_b) / log(s_a / s_b).
        go = True
        sa, sb, la, lb = s0, s1, _LK32[0], _LK32[1]
        go, sa, sb, la, lb = _bracket(go, t, s2, sa, sb, la, lb, _LK32[2])
        go, sa, sb, la, lb = _bracket(go, t, s3, sa, sb, la, lb, _LK32[3])
        go, sa, sb, la, lb = _bracket(go, t, s4, sa, sb, la, lb, _LK32[4])
        go, sa, sb, la, lb = _bracket(go, t, s5, sa, sb, la, lb, _LK32[5])
        u = log2_f32(t / sb) / log2_f32(sa / sb)
        u = u if sa > sb else one
        u = u if u > zero else zero  # NaN -> 0
        u = u if u < one else one
        rho_log = exp2_f32(lb + u * (la - lb))
        rho = rho_lin if t < s5 else rho_log
        rho = rho if t > sc else zero
        rho = rho if rho > zero else zero
        rho = rho if rho < one else one
        # eq. 13: C = (1 - g) C* + g X, g <= 0.1 (the paper's "upper limit of rho+ 0.1" bounds
        # the grey), X the K/W grey of the voxel's brightness (eq. 11).
        sg = F[K_GREY * RS + k]
        useless = sg <= s0  # the grey would not raise the density
        graw = gmax * (t - s0) / (sg - s0)
        over = graw > gmax
        gfrac = gmax if over else graw
        gfrac = zero if useless else gfrac
        rk = F[K_RHOK * RS + k]
        clear = t <= s0
        a = rho if clear else one - gfrac  # weight of C*
        gk = zero if clear else gfrac * rk
        gw = zero if clear else gfrac * (one - rk)
        out[0 * RS + k] = a * F[(K_CONC + 0) * RS + k]
        out[1 * RS + k] = a * F[(K_CONC + 1) * RS + k]
        out[2 * RS + k] = a * F[(K_CONC + 2) * RS + k]
        out[_I_K * RS + k] = a * F[(K_CONC + _I_K) * RS + k] + gk
        out[_I_W * RS + k] = a * F[(K_CONC + _I_W) * RS + k] + gw
        out[_I_CL * RS + k] = one - rho if clear else zero
        lo = clear & (t < sc)
        hi = (not clear) & (useless | over)
        out[6 * RS + k] = sc - t if lo else zero
        out[7 * RS + k] = (t - (s0 if useless else sg)) if hi else zero
        F[K_LOW * RS + k] = one if lo else zero
        F[K_HIGH * RS + k] = one if hi else zero
    # Counted apart, from flags in F's scratch lanes: a 64-bit counter in the loop above (numba
    # widens integer sums to 64 bits) makes LLVM vectorise all of it 4 voxels wide instead of 8
    # (the widest type sets the width): 6.5 -> 3.9 ns per voxel with exp2_f32's 32-bit
    # exponent. (The shortfalls cannot say it: a voxel whose target equals sg can be clamped
    # high, graw rounding just above gmax, with a shortfall of 0.)
    n_low = 0
    n_high = 0
    for k in range(m):
        n_low += 1 if F[K_LOW * RS + k] != zero else 0
        n_high += 1 if F[K_HIGH * RS + k] != zero else 0
    return n_low, n_high


@nb.njit(cache=True, nogil=True, inline="always")
def stage_voxel(col, G, k, r, g, b, t):
    """Voxel ``k`` of a block: its colour as read into ``col`` and its target (1/mm) into ``G``
    (:func:`lookup_align_block` cleans the colours)."""
    RS = ROW_STRIDE
    col[k] = r
    col[RS + k] = g
    col[2 * RS + k] = b
    G[K_TARGET * RS + k] = np.float32(t)


@nb.njit(cache=True, nogil=True, error_model="numpy")
def finish_staging(col, m):
    """:func:`clean_rgb` of the staged colours of voxels ``0 .. m-1`` and on to the next
    multiple of 16, whatever those lanes held, so that every lane a 16-wide step reads indexes
    inside the tables. Returns that multiple of 16."""
    RS = ROW_STRIDE
    m16 = (m + 15) // 16 * 16  # ROW_BLOCK is a multiple of 16
    for k in range(m16):
        col[k] = clean_rgb(col[k])
        col[RS + k] = clean_rgb(col[RS + k])
        col[2 * RS + k] = clean_rgb(col[2 * RS + k])
    return m16


# A block whose voxels come in runs of one colour (a source of uniform colour, a colour map of
# few entries, a voxel model) of at least this many voxels on average looks each colour up once
# (:func:`lookup_runs`).
RUN_MIN = 4


@nb.njit(cache=True, nogil=True, error_model="numpy")
def count_runs(col, m):
    """Number of runs of one colour among the clean staged colours of voxels ``0 .. m-1``
    (colours compared bit for bit)."""
    RS = ROW_STRIDE
    ci = col.view(np.int32)
    runs = 1 if m > 0 else 0
    for k in range(1, m):  # vectorised
        same = (ci[k] == ci[k - 1]) & (ci[RS + k] == ci[RS + k - 1]) \
            & (ci[2 * RS + k] == ci[2 * RS + k - 1])
        runs += 0 if same else 1
    return runs


@nb.njit(cache=True, nogil=True, error_model="numpy")
def lookup_runs(flat, n, col, m, W, off, A, G):
    """What :func:`interpolate_block` writes into ``G`` (lanes ``0 .. K_RHOK`` of voxels
    ``0 .. m-1``; clean colours), computed once per run of voxels of one colour (bit for bit)
    and copied along the run: the lanes are functions of the colour alone, so the values are
    those of interpolating every voxel. The clean colours ``col`` are compacted in place (one
    per run); ``off`` (4 * ROW_BLOCK + 1,) int64, ``W``, ``A`` scratch."""
    RS = ROW_STRIDE
    ci = col.view(np.int32)
    start = off[3 * ROW_BLOCK:]
    nu = 0
    pr = pg = pb = np.int32(0)
    for k in range(m):
        r = ci[k]
        g = ci[RS + k]
        b = ci[2 * RS + k]
        if k == 0 or r != pr or g != pg or b != pb:
            ci[nu] = r
            ci[RS + nu] = g
            ci[2 * RS + nu] = b
            start[nu] = k
            nu += 1
            pr, pg, pb = r, g, b
    start[nu] = m
    interpolate_nodes(flat, n, col, nu, W, off, A)
    for u in range(nu):
        a = start[u]
        e = start[u + 1]
        # filled through views counted from 0: indexed G[q * RS + k], the loop stays scalar
        # (measured 5.5 -> 0.5 ns per voxel)
        for q in range(K_RHOK + 1):
            v = A[u * LANES + q]
            row = G[q * RS + a:q * RS + e]
            for k in range(e - a):
                row[k] = v


@nb.njit(cache=True, nogil=True, error_model="numpy")
def uniform_lanes(flat, n, r, g, b, col, W, off, A, G):
    """Lanes ``0 .. K_RHOK`` of ``G`` for all :data:`ROW_BLOCK` voxels of a block whose every
    voxel has the colour ``(r, g, b)`` as read (cleaned here, :func:`clean_rgb`): what
    :func:`lookup_runs` and :func:`interpolate_block` write for such voxels (lanes are functions
    of the clean colour alone), written once. :func:`align_rows` does not write them, so they
    serve every block of a layer: a block then needs only its targets (lane :data:`K_TARGET`)
    and :func:`align_block`. ``col``, ``W``, ``off``, ``A``: scratch
    (:func:`block_buffers`)."""
    RS = ROW_STRIDE
    col[0] = clean_rgb(np.float32(r))
    col[RS] = clean_rgb(np.float32(g))
    col[2 * RS] = clean_rgb(np.float32(b))
    interpolate_nodes(flat, n, col, 1, W, off, A)
    for q in range(K_RHOK + 1):
        v = A[q]
        row = G[q * RS:q * RS + ROW_BLOCK]
        for k in range(ROW_BLOCK):
            row[k] = v


@nb.njit(cache=True, nogil=True)
def align_block(sigma_clear, m, G, C, stats):
    """:func:`align_rows` of ``m`` voxels whose lanes are in ``G`` (concentrations into
    ``C``); adds their clamp report to ``stats`` (clamped low, clamped high, worst low
    shortfall, worst high shortfall)."""
    lo, hi = align_rows(G, m, sigma_clear, C)
    stats[0] += lo
    stats[1] += hi
    # a block with no clamped voxel has only zeros there
    if lo > 0:
        stats[2] = max(stats[2], np.float64(_row_max(C, 6 * ROW_STRIDE, m)))
    if hi > 0:
        stats[3] = max(stats[3], np.float64(_row_max(C, 7 * ROW_STRIDE, m)))


@nb.njit(cache=True, nogil=True, inline="always")
def _row_max(C, base, m):
    """The largest of ``C[base:base + m]`` (non-negative float32, no NaN), 0 if none: 16
    running maxima, one per lane of a vector (a single running maximum waits for the last
    comparison at every voxel: 1.1 -> 0.2 ns per voxel). Most blocks have a voxel clamped low
    (3-16 % of the foreground of the sample kinds), so this runs for most blocks."""
    acc = np.zeros(16, np.float32)
    m16 = m - m % 16
    for k0 in range(0, m16, 16):
        for j in range(16):
            v = C[base + k0 + j]
            acc[j] = v if v > acc[j] else acc[j]
    w = np.float32(0.0)
    for j in range(16):
        w = acc[j] if acc[j] > w else w
    for k in range(m16, m):
        v = C[base + k]
        w = v if v > w else w
    return w


@nb.njit(cache=True, nogil=True)
def lookup_align_block(flat, n, sigma_clear, col, m, W, off, A, G, C, stats):
    """:func:`finish_staging`, :func:`interpolate_block` (or, for a block of long runs of one
    colour, :func:`lookup_runs`: the same values) then :func:`align_block` for ``m`` staged
    voxels (concentrations into ``C``; clamp report added to ``stats``)."""
    finish_staging(col, m)
    if count_runs(col, m) * RUN_MIN <= m:
        lookup_runs(flat, n, col, m, W, off, A, G)
    else:
        interpolate_block(flat, n, col, m, W, off, A, G)
    align_block(sigma_clear, m, G, C, stats)


@nb.njit(cache=True, nogil=True)
def block_buffers():
    """Working arrays of one block for :func:`stage_voxel` and :func:`lookup_align_block`:
    (col, W, off, A, G, C)."""
    RB = ROW_BLOCK
    RS = ROW_STRIDE
    return (np.empty(3 * RS, np.float32), np.empty(4 * RS, np.float32),
            np.empty(4 * RB + 1, np.int64),
            np.empty(RB * LANES, np.float32), np.empty(LANES * RS, np.float32),
            np.empty(8 * RS, np.float32))


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _align_kernel(flat, n, rgb, target, sigma_clear, out, stats):
    RB = ROW_BLOCK
    col, W, off, A, G, c = block_buffers()
    for v0 in range(0, rgb.shape[0], RB):
        m = min(RB, rgb.shape[0] - v0)
        for k in range(m):
            stage_voxel(col, G, k, rgb[v0 + k, 0], rgb[v0 + k, 1], rgb[v0 + k, 2],
                        target[v0 + k])
        lookup_align_block(flat, n, sigma_clear, col, m, W, off, A, G, c, stats)
        for k in range(m):
            for i in range(6):
                out[v0 + k, i] = c[i * ROW_STRIDE + k]


def lookup_and_align_into(tables: ColourTables, rgb: NDArray, sigma_target: NDArray,
                          out_conc6: NDArray) -> AlignCounts:
    """Fused lookup + density alignment for the streaming job (compiled, releases the GIL).

    ``rgb`` (N, 3) and ``sigma_target`` (N,) float32 (any float accepted), encoded sRGB in
    [0, 1] and 1/mm; writes C, M, Y, K, W, Cl into ``out_conc6`` (N, 6). Runs on the calling
    thread (call it from several threads on separate slabs to use several cores). Each voxel's
    result is a pure function of its inputs (:func:`interpolate_block` then :func:`align_rows`,
    as in the print job's fused per-layer kernel).
    """
    rgb = np.ascontiguousarray(rgb, dtype=np.float32)
    target = np.ascontiguousarray(sigma_target).reshape(-1)
    if rgb.ndim != 2 or rgb.shape[1] != 3 or target.shape[0] != rgb.shape[0]:
        raise ValueError("rgb must be (N, 3) and sigma_target (N,)")
    if out_conc6.shape != (rgb.shape[0], len(INKS)):
        raise ValueError("out_conc6 must be (N, 6)")
    stats = np.zeros(4)
    _align_kernel(kernel_table(tables), tables.packed.shape[0], rgb, target,
                  float(tables.sigma_clear), out_conc6, stats)
    return AlignCounts(int(stats[0]), int(stats[1]), float(stats[2]), float(stats[3]))


APPEARANCE_CHUNK = 1 << 16   # voxels per evaluation of the spectral model (predicted_appearance)


def predicted_appearance(tables: ColourTables, profile: InkProfile, rgb: ArrayLike,
                         sigma_target: ArrayLike) -> tuple[NDArray, NDArray]:
    """(sRGB (..., 3), sigma (...)) of what the print job will deposit per voxel.

    Runs the same fused kernel as the job, then evaluates the resulting six-ink mixtures with
    the full model (colour at the reference thickness, eq. 7; sigma, eq. 9), in chunks of
    :data:`APPEARANCE_CHUNK` voxels (the spectral model holds a few float64 arrays of voxels x
    wavelengths: the proof's 1.9e6 cells at once took 4 GB).
    """
    rgb = np.asarray(rgb, dtype=np.float32)
    shape = rgb.shape[:-1]
    flat = rgb.reshape(-1, 3)
    target = np.broadcast_to(np.asarray(sigma_target, dtype=np.float32), shape).reshape(-1)
    conc = np.empty((flat.shape[0], len(INKS)), dtype=np.float32)
    lookup_and_align_into(tables, flat, target, conc)
    obs = observer_for(profile.wavelengths_nm)
    srgb = np.empty((flat.shape[0], 3), np.float64)
    sigma = np.empty(flat.shape[0], np.float64)
    for a in range(0, flat.shape[0], APPEARANCE_CHUNK):
        c = conc[a:a + APPEARANCE_CHUNK].astype(np.float64)
        srgb[a:a + APPEARANCE_CHUNK] = obs.XYZ_to_sRGB(mixture_colour(profile, c, observer=obs))
        sigma[a:a + APPEARANCE_CHUNK] = mixture_sigma(profile, c)
    return srgb.reshape(shape + (3,)), sigma.reshape(shape)


__all__ += ["lookup"]
