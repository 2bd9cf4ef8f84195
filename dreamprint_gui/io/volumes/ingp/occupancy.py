"""Which voxels of a printer row an InstantNGP snapshot evaluates: box tests and occupancy grid.

Defines :func:`occupied` (instant-ngp's test for one point), :func:`row_span` (the row's voxels
inside the training ``aabb`` and the render box) and :func:`row_voxels` (the voxels of that
span whose occupancy-grid cell is marked, empty space skipped a block of voxels at a time).
Step 1 of :mod:`.kernels`' docstring, for rows along which one instant-ngp axis varies
(``q = q_row + a x`` with ``a`` having a single non-zero component, as every placement of
:meth:`.snapshot.IngpModel.to_ngp` gives) and whose voxel centres ``x`` increase.

Exactness.  Each per-voxel test is the per-voxel formula in float64, and every one of them is
monotone in ``x`` along such a row: ``q_d = q_row,d + a_d x`` and the box test's ``R q`` are
monotone under rounding, so each half-space test passes on an interval of voxels (found from
a float64 estimate corrected by the exact test at its ends); the occupancy cell index
``trunc(((q - 0.5) 2^-m + 0.5) 128)`` is monotone in ``q`` for a fixed mip ``m``, and the mip
(``max|q - 0.5|``, the other axes fixed) is monotone on each side of ``q_ax = 0.5``.  So a
block whose first and last voxels lie on one side of 0.5 with the same mip covers exactly the
cells between theirs: all empty, the block is skipped; all marked, all its voxels are
evaluated; otherwise its voxels are tested one by one.  The voxels kept are those of the
per-voxel test, bit for bit (``tests/io/volumes/test_ingp_rows.py``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["occupied", "row_span", "row_voxels", "OCC_BLOCK"]

OCC_BLOCK = 16          # voxels per block of the coarse occupancy test


@njit(cache=True, nogil=True, inline="always")
def _mip(m, max_cascade):
    """mip = clamp(e + 1, 0, max_cascade) with m = f 2^e, f in [0.5, 1) (frexp; e = 0 for m
    = 0): instant-ngp ``mip_from_pos``."""
    mip = 0
    if m == 0.0:
        mip = min(1, max_cascade)
    else:
        lim = 0.5
        while mip < max_cascade and m >= lim:
            mip += 1
            lim *= 2.0
    return mip


@njit(cache=True, nogil=True, inline="always")
def _cell(qd, mip, n):
    """Cell index along one axis at ``mip`` (C++ float -> int truncation)."""
    sc = 1.0 / (1 << mip)
    return int(((qd - 0.5) * sc + 0.5) * n)


@njit(cache=True, nogil=True, inline="always")
def occupied(q, occ, max_cascade):
    """Step 1's occupancy test (instant-ngp ``mip_from_pos`` and ``cascaded_grid_idx_at``)."""
    m = 0.0
    for d in range(3):
        a = abs(q[d] - 0.5)
        if a > m:
            m = a
    mip = _mip(m, max_cascade)
    n = occ.shape[1]
    ix = _cell(q[0], mip, n)
    iy = _cell(q[1], mip, n)
    iz = _cell(q[2], mip, n)
    if ix < 0 or iy < 0 or iz < 0 or ix >= n or iy >= n or iz >= n:
        return False
    return occ[mip, iz, iy, ix] != 0


@njit(cache=True, nogil=True, inline="always")
def _inside(x, qrow, a, brow, bx, aabb_lo, aabb_hi, box_lo, box_hi):
    """The per-voxel box test: ``q`` in the aabb and ``R q`` in the render box."""
    for d in range(3):
        qd = qrow[d] + a[d] * x
        if qd < aabb_lo[d] or qd > aabb_hi[d]:
            return False
        v = brow[d] + bx[d] * x
        if v < box_lo[d] or v > box_hi[d]:
            return False
    return True


@njit(cache=True, nogil=True)
def row_span(xs, qrow, a, brow, bx, aabb_lo, aabb_hi, box_lo, box_hi):
    """``(i0, i1)``: the voxels ``i0 <= i < i1`` of a row (``xs`` increasing) that pass
    :func:`_inside` (an interval: each of its six tests is monotone in ``x``)."""
    nx = xs.shape[0]
    lo = -np.inf
    hi = np.inf
    for d in range(6):
        if d < 3:
            c0, c1, bl, bh = qrow[d], a[d], aabb_lo[d], aabb_hi[d]
        else:
            c0, c1, bl, bh = brow[d - 3], bx[d - 3], box_lo[d - 3], box_hi[d - 3]
        if c1 == 0.0:
            if c0 < bl or c0 > bh:
                return 0, 0
            continue
        t0 = (bl - c0) / c1
        t1 = (bh - c0) / c1
        if t0 > t1:
            t0, t1 = t1, t0
        lo = max(lo, t0)
        hi = min(hi, t1)
    # widen by far more than the float64 error of either form, then let the exact test decide
    eps = 1e-9 * (1.0 + max(abs(xs[0]), abs(xs[nx - 1])))
    if not lo - eps <= hi + eps:            # empty (or NaN from a degenerate placement)
        return 0, 0
    i0 = np.searchsorted(xs, lo - eps)
    i1 = max(np.searchsorted(xs, hi + eps, side="right"), i0)
    while i0 < i1 and not _inside(xs[i0], qrow, a, brow, bx, aabb_lo, aabb_hi, box_lo, box_hi):
        i0 += 1
    while i1 > i0 and not _inside(xs[i1 - 1], qrow, a, brow, bx, aabb_lo, aabb_hi, box_lo,
                                  box_hi):
        i1 -= 1
    return i0, i1


@njit(cache=True, nogil=True)
def row_voxels(xs, i0, i1, qrow, a, ax, occ, use_occ, max_cascade, q, out):
    """The voxels ``i0 <= i < i1`` of a row whose occupancy cell is marked (all of them without
    ``use_occ``), in order, into ``out``; returns their number.  Only ``q[ax]`` varies along
    the row (``a`` zero elsewhere); ``q`` (3,) float64 scratch.  Blocks of :data:`OCC_BLOCK`
    voxels are decided from their end voxels where the module docstring allows it."""
    k = 0
    if not use_occ:
        for i in range(i0, i1):
            out[k] = i
            k += 1
        return k
    n = occ.shape[1]
    for d in range(3):
        q[d] = qrow[d]
    # the fixed axes' contribution to max|q - 0.5|
    m_fix = 0.0
    for d in range(3):
        if d != ax:
            m_fix = max(m_fix, abs(qrow[d] - 0.5))
    b0 = i0
    while b0 < i1:
        b1 = min(b0 + OCC_BLOCK, i1)
        qa = qrow[ax] + a[ax] * xs[b0]
        qb = qrow[ax] + a[ax] * xs[b1 - 1]
        decided = False
        if (qa - 0.5 > 0.0 and qb - 0.5 > 0.0) or (qa - 0.5 < 0.0 and qb - 0.5 < 0.0):
            mip = _mip(max(m_fix, abs(qa - 0.5)), max_cascade)
            if mip == _mip(max(m_fix, abs(qb - 0.5)), max_cascade):
                cz = cy = cx = 0
                inside = True
                for d in range(3):
                    if d != ax:
                        c = _cell(qrow[d], mip, n)
                        if c < 0 or c >= n:
                            inside = False
                        if d == 0:
                            cx = c
                        elif d == 1:
                            cy = c
                        else:
                            cz = c
                if not inside:
                    decided = True              # the fixed axes leave the grid: all empty
                else:
                    ca = _cell(qa, mip, n)
                    cb = _cell(qb, mip, n)
                    if ca > cb:
                        ca, cb = cb, ca
                    n_set = 0
                    n_cells = cb - ca + 1
                    for c in range(max(ca, 0), min(cb, n - 1) + 1):
                        if ax == 0:
                            cx = c
                        elif ax == 1:
                            cy = c
                        else:
                            cz = c
                        n_set += 1 if occ[mip, cz, cy, cx] != 0 else 0
                    if n_set == 0:
                        decided = True
                    elif n_set == n_cells:
                        for i in range(b0, b1):
                            out[k] = i
                            k += 1
                        decided = True
        if not decided:
            for i in range(b0, b1):
                q[ax] = qrow[ax] + a[ax] * xs[i]
                if occupied(q, occ, max_cascade):
                    out[k] = i
                    k += 1
        b0 = b1
    return k
