"""Tiled, compiled rasteriser of Gaussian splats into a slab of printer voxels.

Defines :func:`rasterise_splats` (density and density-weighted colour, the colour divide fused),
the tile sizes ``TILE_X``, ``TILE_Y``, ``TILE_Z`` and the walk's safety bounds ``Q_WALK``,
``K_WALK``.  The density model is the one derived in :mod:`.cloud`: kernel ``s exp(-q/2)``,
q the squared Mahalanobis distance, cut at ``q <= 9`` (``CUT_Q``).

The walk (most Gaussians).  On the voxel lattice ``p = (i, j, k)`` (centres ``o + (p + 1/2)
h``) q is a quadratic, so ``G(p) = exp(-q(p)/2)`` obeys exact geometric recurrences: stepping
one voxel along x multiplies G by ``Rx(p) = G(p + e_x) / G(p) = exp(-(A h_x^2 + 2 h_x (A dx +
D dy + E dz))/2)`` and Rx, Ry, Rz (the three such ratios) by constants: ``Rx(p + e_x) = Rx(p)
exp(-A h_x^2)``, ``Rx(p + e_y) = Rx(p) exp(-D h_x h_y)``, and so on for the six entries (A, B,
C, D, E, F) = (xx, yy, zz, xy, xz, yz) of the inverse covariance.  Each Gaussian is evaluated
exactly (four ``exp``, and six for the constants) at one anchor, the lowest corner of its
3-sigma box on the job's grid, and every other voxel is reached from it by multiplications
along one fixed path: up in z along the box's corner column, then in y, then in x.  A row
costs no ``exp`` (the previous rasteriser paid two per Gaussian-row: 61 % of a 1e6-Gaussian
job, a Gaussian being ~5 voxels wide in x and ~400 rows).  A tile's layers and the rows of
their marginal ellipses are walked side by side (:func:`_column`: independent recurrences, a
vectorised loop) over the box's columns (over the rows' runs in boxes wider than SCAN_X),
and every voxel is added as ``G`` where ``G >= exp(-9/2)`` (``q <= 9`` up to rounding), as
0 elsewhere: no branch to mispredict, and adding 0.0 leaves a sum's bits as they were.
Rounding: each product carries a relative error of one ulp and the ratios' errors add up
along the path, so a value n steps from the anchor is within ~n^2 eps of exp(-q/2) (n ~ 300:
1e-11), far below the float32 output's 6e-8.

Where the walk is unsafe the Gaussian is rasterised row by row exactly instead (``exp`` at
each row's first voxel, the run found by testing q): when q at a corner of its box (q is
convex: the largest value of the walk) exceeds ``Q_WALK`` (thin, tilted Gaussians: the walk
would visit values near the float64 range's end), or a step constant's exponent exceeds
``K_WALK`` in magnitude (a Gaussian much thinner than a voxel).

Tiles.  The slab is cut into tiles of TILE_Y x TILE_X voxels and at most TILE_Z layers
(:func:`tile_layers`: a 9-layer slab in tiles of 5 and 4); each Gaussian is binned
into the tiles its box overlaps, and a tile sums its Gaussians into a float64 accumulator
small enough to stay in cache (channel, column, row, layer: a column's rows and their layers
contiguous for :func:`_column`), then writes colour / density once, over each column's
touched rows, a row of every column at a time (a layer's output lines are written while in
the L1 cache: 0.2-0.6 CPU ns per voxel less than column by column).

A Gaussian walks all the tile's layers together: their corner columns' values come up the z
chain, go down the y chain a row at a time for every layer at once, and one x step serves
every row and layer, where walking layer by layer paid the y chain's serial steps, the rows'
bounds and the x loop's set-up once per layer (a 1e6-Gaussian job, 1e9 voxels,
``bench_splat_raster.py``: 11.5 -> 8.1 CPU ns per voxel; the 9k-Gaussian sample 12.8 -> 11.9;
the same values bit for bit: the same products along the same path, and rows a layer's
ellipse misses add 0.0). The source asks the job for slabs of TILE_Z layers
(``GaussianCloud.slab_layers``), which it gives within a memory cap (job/plan.py).
The Gaussians' parameters are gathered once per slab into one record each (:func:`_setup`).

Determinism: a voxel's value depends only on its position, the Gaussians whose support holds
it (each value computed along its fixed path from its fixed anchor, both defined on the whole
job's grid), summed in ascending Gaussian index; not on the slab boundaries, the tiles or the
thread that samples a slab, so results are bit-identical whatever the number of workers.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from dreamprint_gui.core.kernels.aligned import zeros_line_aligned
from dreamprint_gui.core.kernels.vec16 import prefetch
from dreamprint_gui.io.volumes.base import SlabBuffers

__all__ = ["rasterise_splats", "pack_gaussians", "tile_layers", "TILE_X", "TILE_Y", "TILE_Z",
           "CUT_Q", "Q_WALK", "K_WALK"]

# 128 columns x 64 rows x 8 layers: a 1e6-Gaussian scene's Gaussians span ~14 rows and ~30
# layers, a real scene's ~90 rows, ~30 columns and ~200 layers; smaller tiles cut them into
# several, each walking its rows and columns from the box's corner again. Layer by layer, 16
# rows: 1e9-voxel jobs rasterised at 11.2 CPU ns per voxel, 64 rows 10.0; the INRIA sample
# 13.8 -> 11.5 -> 128 columns ~10.5 -> 9.7. With the layers walked together, 64-256 columns x
# 32-128 rows measured alike. The accumulator, 2 MB, is a core's L2. A splat job's slabs have
# 8 layers at 1e9 voxels and 7 at 1e10 (the 1e6-Gaussian scene; GaussianCloud.slab_layers
# within job/plan.py's MAX_SLAB_VOXELS): one tile as tall as the slab.
TILE_X = 128
TILE_Y = 64
TILE_Z = 8
# A tile's Gaussians are scattered over the slab's records (256 bytes each, ~18 000 of them in
# a slab of a 1e6-Gaussian scene: more than the L2 cache), so the walk asks for the record of
# the Gaussian this many on while it walks one (a hint, no value changes): a 1e6-Gaussian job
# rasterised at 10.7 -> 9.6 CPU ns per voxel (bench_splat_raster.py; 2, 4 and 8 ahead alike);
# the 9k-Gaussian sample, whose records stay in the cache, unchanged.
PREFETCH_AHEAD = 4
SCAN_X = 8         # exact path: boxes at most this many voxels wide in x are scanned voxel-wise
CUT_Q = 9.0        # the support: q <= 9 (3 sigma)
Q_WALK = 1000.0    # walked Gaussians: q <= this at every point of the walk (G >= e^-500)
K_WALK = 300.0     # and each step constant's exponent within +-this (no over/underflow)
_G_CUT = math.exp(-0.5 * CUT_Q)
_CH = TILE_Z * TILE_X * TILE_Y     # one channel of the flat accumulator
# The channels' cells of one slot 512 bytes past a multiple of 4096 apart: 4096 exactly, a
# channel's load waited on the one before's store (the addresses alias in the load's check):
# 1e6 Gaussians 12.6 -> 12.0 CPU ns per voxel with the bench's overhead. With the
# accumulator and slot arrays starting on a cache line (:func:`.zeros_line_aligned`; a vector never
# straddles two lines), the loop alone 0.75 -> 0.40 ns per slot.
_CHS = _CH + 64
_CH_U = np.uint64(_CHS)
_CH_U2 = np.uint64(2 * _CHS)
_CH_U3 = np.uint64(3 * _CHS)


@njit(cache=True, nogil=True, inline='always')
def _centre(origin, pitch, i):
    """Centre of voxel ``i`` along an axis: :func:`.base.voxel_centres`' formula."""
    return origin + (i + 0.5) * pitch


@njit(cache=True, nogil=True, inline='always')
def _axis_box(m, half, origin, pitch, n):
    """Voxels [lo, hi) of an axis whose centres lie in [m - half, m + half], within [0, n)."""
    u = (m - half - origin) / pitch - 0.5
    v = (m + half - origin) / pitch - 0.5
    lo = 0
    hi = n
    if u > 0.0:
        lo = n if u >= n else int(math.ceil(u))
    if v < n - 1:
        hi = 0 if v < 0.0 else min(int(math.floor(v)) + 1, n)
    return lo, max(hi, lo)


@njit(cache=True, nogil=True, inline='always')
def _span(lo_pos, hi_pos, origin, inv_pitch, margin, lo_bound, hi_bound):
    """Indices [lo, hi) of evenly spaced centres ``origin + i / inv_pitch`` within
    [lo_pos, hi_pos], widened by ``margin`` and clamped to [lo_bound, hi_bound) (a NaN or
    infinite bound gives the whole clamp range)."""
    u = (lo_pos - origin) * inv_pitch
    v = (hi_pos - origin) * inv_pitch
    lo = lo_bound
    hi = hi_bound
    if u > lo_bound:                             # False for NaN: keep the bound
        lo = hi_bound if u >= hi_bound else max(math.ceil(u) - margin, lo_bound)
    if v < hi_bound:
        hi = lo_bound if v < lo_bound else min(math.floor(v) + 1 + margin, hi_bound)
    return lo, max(hi, lo)


@njit(cache=True, nogil=True, inline='always')
def _q(xi, mx, a, lin, qyz):
    dx = xi - mx
    return a * dx * dx + lin * dx + qyz


@njit(cache=True, nogil=True, inline='always')
def _q3(dx, dy, dz, ic):
    return (ic[0] * dx * dx + ic[1] * dy * dy + ic[2] * dz * dz
            + 2.0 * (ic[3] * dx * dy + ic[4] * dx * dz + ic[5] * dy * dz))


@njit(cache=True, nogil=True, inline='always')
def _marginal(ic):
    """The (y, z) marginal ellipse of ``q <= 9`` (where the minimum of q over x is <= 9;
    Schur complement S of the inverse covariance's xx entry) as ``y = my - gamma dz +- sqrt(
    alpha dz^2 + beta)``: (gamma, alpha, beta, S_yy > 0)."""
    a, b, c, d, e, f = ic[0], ic[1], ic[2], ic[3], ic[4], ic[5]
    s_yy = b - d * d / a
    sy_z = f - d * e / a
    s_zz = c - e * e / a
    return sy_z / s_yy, (sy_z * sy_z - s_yy * s_zz) / (s_yy * s_yy), CUT_Q / s_yy, s_yy > 0.0


@njit(cache=True, nogil=True, inline='always')
def _rows(my, gamma, alpha, beta, ok, dz, ys0, inv_hy, by0, by1):
    """Rows [ja, jb) of a layer ``dz`` from the centre within the marginal ellipse
    (:func:`_marginal`), one spare row each side for rounding (the voxels themselves are
    tested), clamped to [by0, by1); all of them if the ellipse is degenerate."""
    if not ok:
        return by0, by1
    cy = my - gamma * dz
    h2 = alpha * dz * dz + beta
    hw = math.sqrt(h2) if h2 > 0.0 else 0.0
    return _span(cy - hw, cy + hw, ys0, inv_hy, 1, by0, by1)


@njit(cache=True, nogil=True)
def _setup(idx, gs, origin, pitch, shape, z0, z1, walk, box, state):
    """Per Gaussian ``t``: its box of voxels on the job's grid (``box[t]``: x, y, z lo/hi, z
    clipped to the slab; x lo == hi: nothing in the slab), its marginal ellipse
    (``state[t, 10:14]``, :func:`_marginal`), its mean, inverse covariance and weights
    s (1, r, g, b) (``state[t, 14:27]``: what the tiles read, gathered once per slab into one
    record in the slab's order) and, when it is walked (``state[t, 0] > 0``;
    module docstring), G, Rx, Ry, Rz at the box's corner column (x lo, y lo) in the slab's
    first layer of the box, reached from the anchor by z steps, then the six step constants
    exp(-A hx^2), exp(-B hy^2), exp(-C hz^2), exp(-D hx hy), exp(-E hx hz), exp(-F hy hz)."""
    hx, hy, hz = pitch[0], pitch[1], pitch[2]
    cst = np.empty(6)
    for t in range(idx.shape[0]):
        g = idx[t]
        mx, my, mz = gs[g, 0], gs[g, 1], gs[g, 2]
        bx0, bx1 = _axis_box(mx, gs[g, 9], origin[0], hx, shape[0])
        by0, by1 = _axis_box(my, gs[g, 10], origin[1], hy, shape[1])
        bz0, bz1 = _axis_box(mz, gs[g, 11], origin[2], hz, shape[2])
        kz0 = max(bz0, z0)
        kz1 = min(bz1, z1)
        box[t, 0] = bx0
        box[t, 1] = bx1
        box[t, 2] = by0
        box[t, 3] = by1
        box[t, 4] = kz0
        box[t, 5] = kz1
        state[t, 0] = 0.0
        if bx0 >= bx1 or by0 >= by1 or kz0 >= kz1:
            box[t, 0] = box[t, 1]               # marks an empty box
            continue
        ic = gs[g, 3:9]
        for u in range(3):
            state[t, 14 + u] = gs[g, u]
            state[t, 24 + u] = gs[g, 12] * gs[g, 13 + u]
        for u in range(6):
            state[t, 17 + u] = ic[u]
        state[t, 23] = gs[g, 12]
        gamma, alpha, beta, ok = _marginal(ic)
        state[t, 10] = gamma
        state[t, 11] = alpha
        state[t, 12] = beta
        state[t, 13] = 1.0 if ok else 0.0
        if not walk:
            continue
        cst[0] = ic[0] * hx * hx
        cst[1] = ic[1] * hy * hy
        cst[2] = ic[2] * hz * hz
        cst[3] = ic[3] * hx * hy
        cst[4] = ic[4] * hx * hz
        cst[5] = ic[5] * hy * hz
        ok = True
        for u in range(6):
            ok &= abs(cst[u]) <= K_WALK         # False for NaN
        # q is convex: its largest value over the walk's points (the box and one voxel past
        # its high ends) is at a corner
        for corner in range(8):
            ci = bx1 if corner & 1 else bx0
            cj = by1 if corner & 2 else by0
            ck = bz1 if corner & 4 else bz0
            qc = _q3(_centre(origin[0], hx, ci) - mx, _centre(origin[1], hy, cj) - my,
                     _centre(origin[2], hz, ck) - mz, ic)
            ok &= qc <= Q_WALK
        if not ok:
            continue
        dx = _centre(origin[0], hx, bx0) - mx
        dy = _centre(origin[1], hy, by0) - my
        dz = _centre(origin[2], hz, bz0) - mz
        gv = math.exp(-0.5 * _q3(dx, dy, dz, ic))
        rx = math.exp(-0.5 * cst[0] - hx * (ic[0] * dx + ic[3] * dy + ic[4] * dz))
        ry = math.exp(-0.5 * cst[1] - hy * (ic[3] * dx + ic[1] * dy + ic[5] * dz))
        rz = math.exp(-0.5 * cst[2] - hz * (ic[4] * dx + ic[5] * dy + ic[2] * dz))
        k_xz = math.exp(-cst[4])
        k_yz = math.exp(-cst[5])
        k_zz = math.exp(-cst[2])
        for _ in range(bz0, kz0):               # the anchor's column, up to the slab
            gv *= rz
            rx *= k_xz
            ry *= k_yz
            rz *= k_zz
        state[t, 0] = gv
        state[t, 1] = rx
        state[t, 2] = ry
        state[t, 3] = rz
        state[t, 4] = math.exp(-cst[0])
        state[t, 5] = math.exp(-cst[1])
        state[t, 6] = k_zz
        state[t, 7] = math.exp(-cst[3])
        state[t, 8] = k_xz
        state[t, 9] = k_yz


@njit(cache=True, nogil=True, inline='always')
def _column(flat, base, gcol, rcol, n, w0, w1, w2, w3, k_xx):
    """One column of a tile's rows, each row's ``nl`` layers side by side (slot s: G and its
    x ratio ``gcol[s]``, ``rcol[s]``): add ``G`` (0 below the cut: no branch) times the four
    weights to the accumulator (channel c, slot s at ``flat[base + c _CHS + s]``), then step
    every slot one voxel along x. The slots' recurrences are independent and their
    accumulator cells contiguous, so the loop is vectorised (indices unsigned: no
    negative-index wrap)."""
    b = np.uint64(base)
    for s in range(n):
        g = gcol[s]
        v = g if g >= _G_CUT else 0.0
        u = b + np.uint64(s)
        flat[u] += v * w0
        flat[u + _CH_U] += v * w1
        flat[u + _CH_U2] += v * w2
        flat[u + _CH_U3] += v * w3
        gcol[s] = g * rcol[s]
        rcol[s] *= k_xx


@njit(cache=True, nogil=True, inline='always')
def _chunk_columns(st, j0, n, dz, origin, pitch, xa, xb):
    """Columns [c0, c1) within [xa, xb) holding the runs ``q <= 9`` of rows j0 .. j0 + n - 1
    of a layer ``dz`` from the centre (each row's interval in closed form, their union, one
    spare column each side for rounding: the voxels themselves are tested)."""
    a, b, c, d, e, f = st[17], st[18], st[19], st[20], st[21], st[22]
    mx, my = st[14], st[15]
    lo = np.inf
    hi = -np.inf
    for j in range(j0, j0 + n):
        dy = _centre(origin[1], pitch[1], j) - my
        lin = 2.0 * (d * dy + e * dz)
        disc = lin * lin - 4.0 * a * (b * dy * dy + 2.0 * f * dy * dz + c * dz * dz - CUT_Q)
        if disc >= 0.0:
            centre = mx - lin * (0.5 / a)
            hw = math.sqrt(disc) * (0.5 / a)
            lo = min(lo, centre - hw)
            hi = max(hi, centre + hw)
    if lo > hi:
        return xa, xa
    return _span(lo, hi, _centre(origin[0], pitch[0], 0), 1.0 / pitch[0], 1, xa, xb)


@njit(cache=True, nogil=True, inline='always')
def _walk_tile(flat, clo, chi, gcol, rcol, lane, nl, st, bx0, by0, kz0, xa, xb, ya, yb, ka, kb,
               x0, y0, z0t, origin, pitch):
    """Add one walked Gaussian (its record ``st``, :func:`_setup`) to the tile's
    accumulator over x [xa, xb), y [ya, yb), layers [ka, kb) (module docstring). The tile's
    ``nl`` layers are walked together: G, Rx, Ry of each layer's corner column (x lo,
    y lo of the box) come up the z chain into ``lane`` (0 in layers the Gaussian misses), go
    down the y chain, all layers at once, over the rows of the layers' marginal ellipses
    into ``gcol``, ``rcol`` (row r, layer l at r nl + l), and are walked along x side by
    side (:func:`_column`) over the box's width (over the rows' runs, :func:`_chunk_columns`,
    in a box wider than SCAN_X): every layer walks the rows of all, and a row beyond a layer's
    ellipse (G below the cut there) adds 0.0. ``clo``, ``chi``: each column's touched rows."""
    gz, rxz, ryz, rzz = st[0], st[1], st[2], st[3]
    k_xx, k_yy, k_zz, k_xy, k_xz, k_yz = st[4], st[5], st[6], st[7], st[8], st[9]
    gamma, alpha, beta, ok = st[10], st[11], st[12], st[13] > 0.0
    for _ in range(kz0, ka):
        gz *= rzz
        rxz *= k_xz
        ryz *= k_yz
        rzz *= k_zz
    ys0 = _centre(origin[1], pitch[1], 0)
    inv_hy = 1.0 / pitch[1]
    my, mz = st[15], st[16]
    w0, w1, w2, w3 = st[23], st[24], st[25], st[26]
    lane[:] = 0.0
    ja = yb
    jb = ya
    wide = xb - xa > SCAN_X
    c0, c1 = (xb, xa) if wide else (xa, xb)
    for k in range(ka, kb):
        kk = k - z0t
        lane[kk] = gz
        lane[TILE_Z + kk] = rxz
        lane[2 * TILE_Z + kk] = ryz
        dz = _centre(origin[2], pitch[2], k) - mz
        ra, rb = _rows(my, gamma, alpha, beta, ok, dz, ys0, inv_hy, ya, yb)
        if rb > ra:
            ja = min(ja, ra)
            jb = max(jb, rb)
            if wide:
                u0, u1 = _chunk_columns(st, ra, rb - ra, dz, origin, pitch, xa, xb)
                if u1 > u0:
                    c0 = min(c0, u0)
                    c1 = max(c1, u1)
        gz *= rzz
        rxz *= k_xz
        ryz *= k_yz
        rzz *= k_zz
    if jb <= ja or c1 <= c0:
        return
    for _ in range(by0, ja):
        for lz in range(nl):
            g, rx, ry = lane[lz], lane[TILE_Z + lz], lane[2 * TILE_Z + lz]
            lane[lz] = g * ry
            lane[TILE_Z + lz] = rx * k_xy
            lane[2 * TILE_Z + lz] = ry * k_yy
    nr = jb - ja
    for r in range(nr):
        for lz in range(nl):
            g, rx, ry = lane[lz], lane[TILE_Z + lz], lane[2 * TILE_Z + lz]
            gcol[r * nl + lz] = g
            rcol[r * nl + lz] = rx
            lane[lz] = g * ry
            lane[TILE_Z + lz] = rx * k_xy
            lane[2 * TILE_Z + lz] = ry * k_yy
    n = nr * nl
    for _ in range(bx0, c0):
        for s in range(n):
            gcol[s] *= rcol[s]
            rcol[s] *= k_xx
    for i in range(c0 - x0, c1 - x0):
        _column(flat, ((i * TILE_Y) + ja - y0) * nl, gcol, rcol, n, w0, w1, w2, w3, k_xx)
        clo[i] = min(clo[i], ja - y0)
        chi[i] = max(chi[i], jb - y0)


@njit(cache=True, nogil=True, inline='always')
def _exact_tile(flat, clo, chi, nl, st, xa, xb, ya, yb, ka, kb, x0, y0, z0t,
                origin, pitch):
    """Add one Gaussian to the tile's accumulator row by row: q tested voxel by voxel (boxes
    up to SCAN_X wide) or the row's run solved in closed form and its ends checked; ``exp`` at
    the run's first voxel and its ratio, then the x recurrence along the run."""
    a, b, c, d, e, f = st[17], st[18], st[19], st[20], st[21], st[22]
    mx, my, mz = st[14], st[15], st[16]
    gamma, alpha, beta, ok = st[10], st[11], st[12], st[13] > 0.0
    hx = pitch[0]
    inv_h = 1.0 / hx
    xs0 = _centre(origin[0], hx, 0)
    ys0 = _centre(origin[1], pitch[1], 0)
    inv_hy = 1.0 / pitch[1]
    step = math.exp(-a * hx * hx)
    inv_2a = 0.5 / a
    for k in range(ka, kb):
        dz = _centre(origin[2], pitch[2], k) - mz
        ja, jb = _rows(my, gamma, alpha, beta, ok, dz, ys0, inv_hy, ya, yb)
        for j in range(ja, jb):
            dy = _centre(origin[1], pitch[1], j) - my
            qyz = b * dy * dy + 2.0 * f * dy * dz + c * dz * dz
            lin = 2.0 * (d * dy + e * dz)
            if xb - xa <= SCAN_X:
                lo = xa
                while lo < xb and _q(_centre(origin[0], hx, lo), mx, a, lin, qyz) > CUT_Q:
                    lo += 1
                hi = lo
                while hi < xb and _q(_centre(origin[0], hx, hi), mx, a, lin, qyz) <= CUT_Q:
                    hi += 1
            else:
                centre = mx - lin * inv_2a
                disc = lin * lin - 4.0 * a * (qyz - CUT_Q)
                hw = math.sqrt(disc) * inv_2a if disc > 0.0 else 0.0
                lo, hi = _span(centre - hw, centre + hw, xs0, inv_h, 0, xa, xb)
                while lo < hi and _q(_centre(origin[0], hx, lo), mx, a, lin, qyz) > CUT_Q:
                    lo += 1
                while hi > lo and _q(_centre(origin[0], hx, hi - 1), mx, a, lin,
                                     qyz) > CUT_Q:
                    hi -= 1
                while lo > xa and _q(_centre(origin[0], hx, lo - 1), mx, a, lin,
                                     qyz) <= CUT_Q:
                    lo -= 1
                while hi < xb and _q(_centre(origin[0], hx, hi), mx, a, lin, qyz) <= CUT_Q:
                    hi += 1
            if lo >= hi:
                continue
            q0 = _q(_centre(origin[0], hx, lo), mx, a, lin, qyz)
            w = math.exp(-0.5 * q0)
            r = 1.0
            if hi - lo > 1:
                r = math.exp(-0.5 * (_q(_centre(origin[0], hx, lo + 1), mx, a, lin, qyz) - q0))
            kk = k - z0t
            jj = j - y0
            for i in range(lo - x0, hi - x0):
                o = ((i * TILE_Y) + jj) * nl + kk
                flat[o] += w * st[23]
                flat[o + _CHS] += w * st[24]
                flat[o + 2 * _CHS] += w * st[25]
                flat[o + 3 * _CHS] += w * st[26]
                clo[i] = min(clo[i], jj)
                chi[i] = max(chi[i], jj + 1)
                w *= r
                r *= step


@njit(cache=True, nogil=True)
def tile_layers(nz: int) -> int:
    """Layers of a tile in a slab of ``nz`` layers: ``ceil(nz / n)`` for the fewest tiles n of
    at most TILE_Z layers; the last tile holds the rest (9 -> 5 + 4, 25 -> 7 + 7 + 7 + 4,
    57 -> 7 x 8 + 1)."""
    n_tiles = (nz + TILE_Z - 1) // TILE_Z
    return (nz + n_tiles - 1) // n_tiles


@njit(cache=True, nogil=True)
def _splat_kernel(idx, gs, origin, pitch, shape, z0, z1, walk, scale, flat, gcol, rcol,
                  rgb_out, sigma_out):
    """Density and colour of Gaussians ``gs[idx]`` in layers [z0, z1) (module docstring):
    set-up (:func:`_setup`), binning into tiles (each tile's list in ascending ``idx`` order),
    then per tile the sum of its Gaussians in the accumulator ``flat`` (walked,
    :func:`_walk_tile`, or exact, :func:`_exact_tile`) and its output: density ``sum s G``
    times ``scale`` and colour ``sum s G rgb / sum s G`` clipped to [0, 1] where the density
    is > 0. ``flat`` (zeros), ``gcol``, ``rcol``: cache-line aligned scratch
    (:func:`rasterise_splats`); ``flat`` is zero again on return."""
    nx, ny = shape[0], shape[1]
    nz = z1 - z0
    n = idx.shape[0]
    box = np.empty((n, 6), np.int64)
    state = np.empty((n, 32))                    # 27 used, rows of 256 bytes
    _setup(idx, gs, origin, pitch, shape, z0, z1, walk, box, state)
    ntx = (nx + TILE_X - 1) // TILE_X
    nty = (ny + TILE_Y - 1) // TILE_Y
    nl = tile_layers(nz)
    ntz = (nz + nl - 1) // nl
    n_tiles = ntx * nty * ntz
    start = np.zeros(n_tiles + 1, np.int64)
    for t in range(n):
        if box[t, 0] >= box[t, 1]:
            continue
        for tz in range((box[t, 4] - z0) // nl, (box[t, 5] - 1 - z0) // nl + 1):
            for ty in range(box[t, 2] // TILE_Y, (box[t, 3] - 1) // TILE_Y + 1):
                for tx in range(box[t, 0] // TILE_X, (box[t, 1] - 1) // TILE_X + 1):
                    start[(tz * nty + ty) * ntx + tx + 1] += 1
    for i in range(n_tiles):
        start[i + 1] += start[i]
    fill = start[:-1].copy()
    members = np.empty(start[n_tiles], np.int64)
    for t in range(n):                           # ascending t: each tile's list stays sorted
        if box[t, 0] >= box[t, 1]:
            continue
        for tz in range((box[t, 4] - z0) // nl, (box[t, 5] - 1 - z0) // nl + 1):
            for ty in range(box[t, 2] // TILE_Y, (box[t, 3] - 1) // TILE_Y + 1):
                for tx in range(box[t, 0] // TILE_X, (box[t, 1] - 1) // TILE_X + 1):
                    tile = (tz * nty + ty) * ntx + tx
                    members[fill[tile]] = t
                    fill[tile] += 1

    records = state.reshape(-1)
    boxes = box.reshape(-1)
    n_rec = state.shape[1]
    n_box = box.shape[1]
    clo = np.full(TILE_X, TILE_Y, np.int64)     # touched rows of each column
    chi = np.zeros(TILE_X, np.int64)
    lane = np.empty(3 * TILE_Z)                  # G, Rx, Ry of the layers' corner column
    for tz in range(ntz):
        z0t = z0 + tz * nl                       # global layers
        z1t = min(z0t + nl, z1)
        for ty in range(nty):
            y0 = ty * TILE_Y
            y1 = min(y0 + TILE_Y, ny)
            for tx in range(ntx):
                tile = (tz * nty + ty) * ntx + tx
                if start[tile] == start[tile + 1]:
                    continue                     # outside every support: stays 0
                x0 = tx * TILE_X
                x1 = min(x0 + TILE_X, nx)
                m_end = start[tile + 1]
                for m in range(start[tile], m_end):
                    t = members[m]
                    # the record of the Gaussian PREFETCH_AHEAD on into the L2 cache while
                    # this one is walked: a tile's Gaussians lie all over the slab's records
                    tn = members[min(m + PREFETCH_AHEAD, m_end - 1)]
                    for u in range(0, n_rec, 8):          # a cache line: 8 float64
                        prefetch(records, np.uint64(tn * n_rec + u))
                    prefetch(boxes, np.uint64(tn * n_box))
                    xa = max(box[t, 0], x0)
                    xb = min(box[t, 1], x1)
                    ya = max(box[t, 2], y0)
                    yb = min(box[t, 3], y1)
                    ka = max(box[t, 4], z0t)
                    kb = min(box[t, 5], z1t)
                    if state[t, 0] > 0.0:
                        _walk_tile(flat, clo, chi, gcol, rcol, lane, nl, state[t], box[t, 0],
                                   box[t, 2], box[t, 4], xa, xb, ya, yb, ka, kb, x0, y0, z0t,
                                   origin, pitch)
                    else:
                        _exact_tile(flat, clo, chi, nl, state[t], xa, xb, ya, yb, ka, kb, x0,
                                    y0, z0t, origin, pitch)
                nzt = z1t - z0t
                ylo = TILE_Y
                yhi = 0
                for i in range(x1 - x0):
                    ylo = min(ylo, clo[i])
                    yhi = max(yhi, chi[i])
                for jj in range(ylo, yhi):               # a row of every layer at a time
                    for i in range(x1 - x0):
                        if jj < clo[i] or jj >= chi[i]:
                            continue
                        o = (i * TILE_Y + jj) * nl
                        for kk in range(nzt):
                            dd = flat[o + kk]
                            if dd > 0.0:
                                sigma_out[z0t - z0 + kk, y0 + jj, x0 + i] = np.float32(
                                    dd * scale)
                                inv = 1.0 / dd
                                for ch in range(3):
                                    v = flat[o + kk + (ch + 1) * _CHS] * inv
                                    rgb_out[z0t - z0 + kk, y0 + jj, x0 + i, ch] = np.float32(
                                        min(max(v, 0.0), 1.0))
                for i in range(x1 - x0):
                    lo = clo[i]
                    hi = chi[i]
                    if lo >= hi:
                        continue
                    o = (i * TILE_Y + lo) * nl
                    for ch in range(4):
                        flat[o + ch * _CHS: o + ch * _CHS + (hi - lo) * nl] = 0.0
                    clo[i] = TILE_Y
                    chi[i] = 0


def rasterise_splats(idx: np.ndarray, gaussians: np.ndarray, origin, pitch, shape_xyz, z0: int,
                     z1: int, scale: float, out: SlabBuffers | None = None, *,
                     walk: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Colour and density of the Gaussians ``gaussians[idx]`` in layers ``[z0, z1)`` of a
    grid of ``shape_xyz`` voxels whose centres are ``origin + (index + 1/2) * pitch`` per axis
    (source units, as :func:`.base.voxel_centres`); each voxel sums them in the order of
    ``idx``.

    ``gaussians`` (N, 16) float64, one row per Gaussian (:func:`pack_gaussians`): mean (3),
    inverse covariance (xx, yy, zz, xy, xz, yz), 3-sigma half-extent per axis (3), centre
    density, colour (3). Returns (colour (nz, ny, nx, 3) =
    density-weighted mean of ``rgb`` clipped to [0, 1], 0 where no Gaussian reaches; density *
    ``scale`` (nz, ny, nx)), both float32, nz = z1 - z0. ``out``: a worker's
    :class:`.base.SlabBuffers` to write into instead of new arrays (a fresh slab's page faults
    cost as much as a tenth of the rasteriser); with ``out.colour_where_dense`` the colour
    where no Gaussian reaches is left as it was. ``walk=False`` rasterises every Gaussian by
    the exact row-by-row path (tests, benchmarks).
    """
    nx, ny, _ = (int(v) for v in shape_xyz)
    shape = (int(z1) - int(z0), ny, nx)
    if out is None:
        rgb_out = np.zeros(shape + (3,), np.float32)
        sigma_out = np.zeros(shape, np.float32)
    else:
        rgb_out, sigma_out = out.take(shape)
        sigma_out.fill(0.0)
        if not out.colour_where_dense:
            rgb_out.fill(0.0)
    if len(idx) and all(shape):
        flat = zeros_line_aligned(4 * _CHS)         # channel, column, row, layer
        gcol = zeros_line_aligned(TILE_Y * TILE_Z)  # a column's rows x layers, walked together
        rcol = zeros_line_aligned(TILE_Y * TILE_Z)
        _splat_kernel(np.ascontiguousarray(idx, np.int64), gaussians,
                      np.asarray(origin, np.float64), np.asarray(pitch, np.float64),
                      np.asarray(shape_xyz, np.int64), int(z0), int(z1), bool(walk),
                      float(scale), flat, gcol, rcol, rgb_out, sigma_out)
    return rgb_out, sigma_out


def pack_gaussians(mean: np.ndarray, inv_cov: np.ndarray, half: np.ndarray, peak: np.ndarray,
                   rgb: np.ndarray, order: np.ndarray | None = None) -> np.ndarray:
    """The (N, 16) rows :func:`rasterise_splats` reads (mean, inverse covariance, half-extent,
    centre density, colour), in ``order`` if given: one record per Gaussian, so that a slab's
    Gaussians are read together."""
    g = np.column_stack([mean, inv_cov, half, peak, rgb]).astype(np.float64)
    return np.ascontiguousarray(g if order is None else g[order])
