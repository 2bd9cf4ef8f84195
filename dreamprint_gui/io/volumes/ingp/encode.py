"""The multiresolution hash encoding of InstantNGP (step 2 of :mod:`.kernels`' docstring)
for a batch of voxels, per level either voxel by voxel or a printer row at a time.

Defines :func:`level_direct` (one level for columns ``c0 .. c1 - 1`` of a batch: 8 corners
per voxel) and :func:`level_row` (one level for voxels of one printer row along which only
one coordinate, axis ``ax``, varies).

Row form.  Along such a row the corner cells and weights of the two other axes are the same
for every voxel, so the trilinear blend factors:
``e(u) = (1 - w_ax) L[g] + w_ax L[g + 1]``, with the row's line of the level
``L[n] = sum over the 4 corners (c1, c2) of the fixed axes  w_c1 w_c2 T[index(n, c1, c2)]``,
``g = floor(s u_ax + 1/2)``.  The line is gathered once for the lattice points ``n`` the row's
voxels span (4 table reads each) instead of 8 reads per voxel: the coarse levels, many voxels
to a lattice cell, cost two reads of a short line per voxel.  The sum is the same trilinear
blend in another order (float32 rounding apart).  Which form a (row, level) takes is decided
per level for every row alike (:func:`row_form_levels`), never by how rows fall into batches:
a voxel's encoding does not depend on the thread that evaluates it.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["level_direct", "level_row", "row_form_levels", "encode_batch", "corner_index"]

HASH_P1 = np.uint32(2654435761)
HASH_P2 = np.uint32(805459861)


@njit(cache=True, nogil=True, inline="always")
def _mults(hsh, r):
    if hsh:
        return np.uint32(1), HASH_P1, HASH_P2
    return np.uint32(1), np.uint32(r), np.uint32(r * r)


@njit(cache=True, nogil=True, inline="always")
def _level_table(lvl, table, n_feat, offsets, hashed):
    """Level ``lvl``'s table slice and its indexing: (slice, size, size is a power of two,
    size - 1, hashed, the level's first row of ``enc``)."""
    size_i = offsets[lvl + 1] - offsets[lvl]
    return (table[offsets[lvl]:offsets[lvl + 1]], np.uint32(size_i),
            (size_i & (size_i - 1)) == 0, np.uint32(size_i - 1), hashed[lvl] != 0,
            lvl * n_feat)


@njit(cache=True, nogil=True, inline="always")
def corner_index(tx, ty, tz, hsh, pow2, mask, size):
    """A corner's table entry from its per-axis index terms (module docstring of
    :mod:`.kernels`, step 2): hashed ``x ^ y P1 ^ z P2``, dense ``x + y r + z r^2``,
    modulo the level's table size."""
    if hsh and pow2:
        return (tx ^ ty ^ tz) & mask
    if hsh:
        return np.uint32((tx ^ ty ^ tz) % size)
    h = np.uint32(tx + ty + tz)
    return h if h < size else np.uint32(h % size)


@njit(cache=True, nogil=True, inline="always")
def _weight(v, interp):
    if interp == 1:
        return v * v * (np.float32(3.0) - np.float32(2.0) * v)
    return v


@njit(cache=True, nogil=True, fastmath=True)
def level_direct(u, c0, c1, lvl, table, n_feat, offsets, scales, res, hashed, interp, enc):
    """Level ``lvl`` of the encoding of positions ``u[:, c0:c1]`` (3, batch) into
    ``enc[lvl F .. lvl F + F - 1, c0:c1]``, voxel by voxel: per axis the lower lattice index
    and weight, the index terms ``x``, ``y P1``, ``z P2`` (hashed) or ``x``, ``y r``,
    ``z r^2`` (dense), then the 8 corners (x the lowest bit) blended.  ``interp``: 0 linear,
    1 smoothstep, 2 nearest (the lower corner alone).  A plain loop: the per-corner vector
    loops it replaces did not vectorise with a batch length known only at run time (~35 ns
    per level and voxel against ~19 here, ~10 for the row form's voxel-by-voxel levels)."""
    s = scales[lvl]
    tab, size, pow2, mask, hsh, row = _level_table(lvl, table, n_feat, offsets, hashed)
    mx, my, mz = _mults(hsh, res[lvl])
    one = np.uint32(1)
    f1 = np.float32(1.0)
    for b in range(c0, c1):
        gx, vx = _cell(s, u[0, b])
        gy, vy = _cell(s, u[1, b])
        gz, vz = _cell(s, u[2, b])
        vx = _weight(vx, interp)
        vy = _weight(vy, interp)
        vz = _weight(vz, interp)
        x0 = np.uint32(np.uint32(gx) * mx)
        y0 = np.uint32(np.uint32(gy) * my)
        z0 = np.uint32(np.uint32(gz) * mz)
        if interp == 2:
            i = corner_index(x0, y0, z0, hsh, pow2, mask, size)
            for f in range(n_feat):
                enc[row + f, b] = tab[i, f]
            continue
        x1 = np.uint32((np.uint32(gx) + one) * mx)
        y1 = np.uint32((np.uint32(gy) + one) * my)
        z1 = np.uint32((np.uint32(gz) + one) * mz)
        for f in range(n_feat):
            e = np.float32(0.0)              # (a local sum: one store per feature)
            for c in range(8):
                tx = x1 if c & 1 else x0
                ty = y1 if c & 2 else y0
                tz = z1 if c & 4 else z0
                wt = ((vx if c & 1 else f1 - vx) * (vy if c & 2 else f1 - vy)
                      * (vz if c & 4 else f1 - vz))
                e += wt * tab[corner_index(tx, ty, tz, hsh, pow2, mask, size), f]
            enc[row + f, b] = e


@njit(cache=True, nogil=True, inline="always")
def _cell(s, ud):
    """(lower lattice index, upper-corner weight before smoothstep) of one coordinate."""
    p = s * ud + np.float32(0.5)
    fl = np.floor(p)
    return np.int32(fl), p - fl


@njit(cache=True, nogil=True)
def row_form_levels(scales, interp, du, out):
    """Which levels take the row form, ``out`` (levels,) bool, for rows whose varying
    coordinate advances ``du`` per voxel: those whose lattice advances at most one cell per
    voxel (the row's line of the level is then no longer than its voxels, 4 reads per lattice
    point against 8 per voxel).  The same for every row of a call: a voxel's encoding never
    depends on how rows fall into batches or threads.  Nearest interpolation: none."""
    for lvl in range(scales.shape[0]):
        out[lvl] = interp != 2 and scales[lvl] * du <= 1.0


@njit(cache=True, nogil=True)
def encode_batch(u, nb, ax, row_form, seg_c0, seg_c1, seg_ufix, n_seg, table, n_feat, offsets,
                 scales, res, hashed, interp, enc, line, gcol, wcol):
    """All levels of the encoding of the ``nb`` columns of a batch into ``enc``: levels with
    ``row_form`` a row segment at a time (:func:`level_row`; segment ``k`` is columns
    ``seg_c0[k] .. seg_c1[k] - 1`` of one row, fixed coordinates ``seg_ufix[k]``), the others
    over the whole batch (:func:`level_direct`)."""
    for lvl in range(scales.shape[0]):
        if ax >= 0 and interp != 2:
            for k in range(n_seg):
                level_row(u, seg_c0[k], seg_c1[k], ax, seg_ufix[k], lvl, row_form[lvl], table,
                          n_feat, offsets, scales, res, hashed, interp, enc, line, gcol, wcol)
        else:
            level_direct(u, 0, nb, lvl, table, n_feat, offsets, scales, res, hashed, interp,
                         enc)


@njit(cache=True, nogil=True, fastmath=True)
def level_row(u, c0, c1, ax, u_fix, lvl, use_line, table, n_feat, offsets, scales, res, hashed,
              interp, enc, line, gcol, wcol):
    """Level ``lvl`` for columns ``c0 .. c1 - 1`` of a batch that belong to one row, along
    which only coordinate ``ax`` varies (``u[ax, c]``; the others are ``u_fix`` (3,)), into
    ``enc`` as :func:`level_direct`: the row form of the module docstring.  ``line``
    (>= F, lattice points spanned + 1) float32, ``gcol`` int32 and ``wcol`` float32 (batch)
    are work space."""
    s = scales[lvl]
    tab, size, pow2, mask, hsh, row = _level_table(lvl, table, n_feat, offsets, hashed)
    mult = _mults(hsh, res[lvl])
    one = np.uint32(1)
    # the varying axis: lattice cell and weight per voxel, and the span of cells
    ua = u[ax]
    g_lo = np.int32(2147483647)
    g_hi = np.int32(-2147483647)
    for b in range(c0, c1):
        g, v = _cell(s, ua[b])
        gcol[b] = g
        wcol[b] = v
        g_lo = min(g_lo, g)
        g_hi = max(g_hi, g)
    if interp == 1:
        for b in range(c0, c1):
            v = wcol[b]
            wcol[b] = v * v * (np.float32(3.0) - np.float32(2.0) * v)
    n_pts = g_hi - g_lo + 2
    # the fixed axes d1 < d2: their two corners' index terms and weights (corner_index is
    # symmetric in its three terms, so the order of the axes does not matter)
    d1 = 1 if ax == 0 else 0
    d2 = 1 if ax == 2 else 2
    g1, v1 = _cell(s, np.float32(u_fix[d1]))
    g2, v2 = _cell(s, np.float32(u_fix[d2]))
    v1 = _weight(v1, interp)
    v2 = _weight(v2, interp)
    m1 = mult[d1]
    m2 = mult[d2]
    t10 = np.uint32(np.uint32(g1) * m1)
    t11 = np.uint32((np.uint32(g1) + one) * m1)
    t20 = np.uint32(np.uint32(g2) * m2)
    t21 = np.uint32((np.uint32(g2) + one) * m2)
    m_ax = mult[ax]
    if not use_line:
        # voxel by voxel: the 8 corners, the fixed axes' 4 from the row
        w00 = (np.float32(1.0) - v1) * (np.float32(1.0) - v2)
        w10 = v1 * (np.float32(1.0) - v2)
        w01 = (np.float32(1.0) - v1) * v2
        w11 = v1 * v2
        for b in range(c0, c1):
            gi = np.uint32(gcol[b])
            w = wcol[b]
            wl = np.float32(1.0) - w
            tn0 = np.uint32(gi * m_ax)
            tn1 = np.uint32((gi + one) * m_ax)
            i0 = corner_index(tn0, t10, t20, hsh, pow2, mask, size)
            j0 = corner_index(tn1, t10, t20, hsh, pow2, mask, size)
            i1 = corner_index(tn0, t11, t20, hsh, pow2, mask, size)
            j1 = corner_index(tn1, t11, t20, hsh, pow2, mask, size)
            i2 = corner_index(tn0, t10, t21, hsh, pow2, mask, size)
            j2 = corner_index(tn1, t10, t21, hsh, pow2, mask, size)
            i3 = corner_index(tn0, t11, t21, hsh, pow2, mask, size)
            j3 = corner_index(tn1, t11, t21, hsh, pow2, mask, size)
            for f in range(n_feat):
                enc[row + f, b] = (w00 * (wl * tab[i0, f] + w * tab[j0, f])
                                   + w10 * (wl * tab[i1, f] + w * tab[j1, f])
                                   + w01 * (wl * tab[i2, f] + w * tab[j2, f])
                                   + w11 * (wl * tab[i3, f] + w * tab[j3, f]))
        return
    for f in range(n_feat):
        lf = line[f]
        for n in range(n_pts):
            lf[n] = 0.0
    for c in range(4):
        ta = t11 if c & 1 else t10
        tb = t21 if c & 2 else t20
        wc = (v1 if c & 1 else np.float32(1.0) - v1) * (v2 if c & 2 else np.float32(1.0) - v2)
        for n in range(n_pts):
            tn = np.uint32(np.uint32(g_lo + n) * m_ax)
            i = corner_index(tn, ta, tb, hsh, pow2, mask, size)
            if n_feat == 2:
                line[0, n] += wc * tab[i, 0]
                line[1, n] += wc * tab[i, 1]
            else:
                for f in range(n_feat):
                    line[f, n] += wc * tab[i, f]
    for f in range(n_feat):
        lf = line[f]
        ef = enc[row + f]
        for b in range(c0, c1):
            j = gcol[b] - g_lo
            v = wcol[b]
            ef[b] = (np.float32(1.0) - v) * lf[j] + v * lf[j + 1]
