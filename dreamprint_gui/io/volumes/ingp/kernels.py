"""Compiled CPU evaluation of an InstantNGP NeRF: hash encoding, density and colour MLPs.

Defines :func:`sample_rows` (one call per group of printer rows; releases the GIL) and the
activation codes :data:`ACT`.  The layout it evaluates is the one
:mod:`.snapshot` reads from a snapshot; the equations, step by step (tiny-cuda-nn
``encodings/grid.h`` and ``common_device.h``, instant-ngp ``nerf_network.h`` and
``nerf_device.cuh``):

1. Position.  A printer voxel centre ``p`` (source units) goes to instant-ngp's space,
   ``q = A p + t`` (the dataset's ``scale``/``offset`` and axis cycle), is kept only inside
   the training ``aabb`` and the render box (``R q`` in ``render_aabb``), and only where the
   occupancy grid marks its cell: mip ``m = clamp(e + 1, 0, max_cascade)`` with
   ``max|q - 0.5| = f 2^e``, ``f`` in [0.5, 1); cell ``floor(((q - 0.5) 2^-m + 0.5) 128)``;
   occupied when its density exceeds ``min(0.01, mean of the mip-0 densities)``.
2. Encoding.  ``u = (q - aabb.min) / (aabb.max - aabb.min)``; level ``l`` has
   ``s_l = 2^(l log2 b) N_min - 1``, resolution ``ceil(s_l) + 1``; ``x = s_l u + 0.5``,
   corner ``floor(x)``, weight ``w = x - floor(x)`` (smoothstep ``w^2 (3 - 2 w)`` if asked);
   a corner's entry is ``x + y r + z r^2`` (dense levels) or
   ``x * 1 ^ y * 2654435761 ^ z * 805459861`` (uint32, hashed levels), modulo the level's
   table size; the level's ``F`` features are the trilinear blend of its 8 corners.
3. Density MLP (no biases): ``h_1 = g(W_0 e)``, ..., ``o = g_out(W_L h_L)`` (16 outputs);
   ``sigma = exp(o_0)`` (instant-ngp's density activation).
4. Colour MLP: input ``[o, SH_4(d)]`` (16 + 16); its first layer is split as
   ``W_0 [o; SH(d)] = W_0a o + c_d`` with ``c_d = W_0b SH(d)`` precomputed per direction;
   ``rgb = sigmoid(out_0..2)`` (LDR) or ``exp(clamp(out, -10, 10))`` (HDR), averaged over the
   chosen directions.
All in float32 (instant-ngp runs the networks in float16: expect ~1e-3 relative differences).

Where the time goes (issue 25).  Along a printer row only one instant-ngp coordinate varies
(every placement the reader makes), so step 1 takes the row's voxels inside the boxes as one
interval and the occupancy grid a block of voxels at a time (:mod:`.occupancy`; the
same voxels as the per-voxel test), and step 2 blends the coarse levels a row at a time
(:mod:`.encode`).  The networks (steps 3-4, ~8400 multiply-adds per voxel) run near the
float32 FMA peak of an AVX2 core (~37 of ~42 per ns); the colour network runs only where a
print job reads colour (``colour_cut``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from dreamprint_gui.io.volumes.ingp.encode import encode_batch, row_form_levels
from dreamprint_gui.io.volumes.ingp.occupancy import occupied, row_span, row_voxels

_occupied = occupied            # the per-point test, as tests and older callers name it

__all__ = ["ACT", "sample_rows", "mlp_forward"]

# hidden/output activation codes (tiny-cuda-nn names)
ACT = {"none": 0, "relu": 1, "leakyrelu": 2, "exponential": 3, "sigmoid": 4, "tanh": 5}

BATCH = 256


@njit(cache=True, nogil=True, inline="always")
def _act(v, code):
    if code == 1:
        return v if v > 0.0 else np.float32(0.0)
    if code == 0:
        return v
    if code == 2:
        return v if v > 0.0 else np.float32(0.01) * v
    if code == 3:
        return np.float32(math.exp(v))
    if code == 4:
        return np.float32(1.0 / (1.0 + math.exp(-v)))
    return np.float32(math.tanh(v))


@njit(cache=True, nogil=True, fastmath=True)
def _matmul_row(w, x, yo, o, n_in, nb):
    """One output row of :func:`_matmul`, eight inputs per pass."""
    n8 = n_in - n_in % 8
    for b in range(nb):
        yo[b] = 0.0
    for i in range(0, n8, 8):
        a0 = w[o, i]
        a1 = w[o, i + 1]
        a2 = w[o, i + 2]
        a3 = w[o, i + 3]
        a4 = w[o, i + 4]
        a5 = w[o, i + 5]
        a6 = w[o, i + 6]
        a7 = w[o, i + 7]
        x0 = x[i]
        x1 = x[i + 1]
        x2 = x[i + 2]
        x3 = x[i + 3]
        x4 = x[i + 4]
        x5 = x[i + 5]
        x6 = x[i + 6]
        x7 = x[i + 7]
        for b in range(nb):
            yo[b] += (a0 * x0[b] + a1 * x1[b] + a2 * x2[b] + a3 * x3[b]
                      + a4 * x4[b] + a5 * x5[b] + a6 * x6[b] + a7 * x7[b])
    for i in range(n8, n_in):
        a0 = w[o, i]
        x0 = x[i]
        for b in range(nb):
            yo[b] += a0 * x0[b]


@njit(cache=True, nogil=True, fastmath=True)
def _matmul(w, x, y, n_out, n_in, nb):
    """``y[o, :nb] = sum_i w[o, i] x[i, :nb]`` for ``o < n_out`` (w is (out, in) row-major, as
    tiny-cuda-nn stores its layers; the batch runs along the contiguous last axis).  Two output
    rows and eight inputs per pass: each element loaded from ``x`` feeds two multiply-adds and
    each pass over ``y`` does eight per element. Measured against the plain triple loop that
    numba vectorises on its own (``benchmarks/bench_ingp.py``, one thread, quiet machine): 101
    vs 132 ns per voxel, so the unrolled form pays for itself."""
    n8 = n_in - n_in % 8
    for o in range(0, n_out - 1, 2):
        ya = y[o]
        yb = y[o + 1]
        for b in range(nb):
            ya[b] = 0.0
            yb[b] = 0.0
        for i in range(0, n8, 8):
            a0 = w[o, i]
            a1 = w[o, i + 1]
            a2 = w[o, i + 2]
            a3 = w[o, i + 3]
            a4 = w[o, i + 4]
            a5 = w[o, i + 5]
            a6 = w[o, i + 6]
            a7 = w[o, i + 7]
            c0 = w[o + 1, i]
            c1 = w[o + 1, i + 1]
            c2 = w[o + 1, i + 2]
            c3 = w[o + 1, i + 3]
            c4 = w[o + 1, i + 4]
            c5 = w[o + 1, i + 5]
            c6 = w[o + 1, i + 6]
            c7 = w[o + 1, i + 7]
            x0 = x[i]
            x1 = x[i + 1]
            x2 = x[i + 2]
            x3 = x[i + 3]
            x4 = x[i + 4]
            x5 = x[i + 5]
            x6 = x[i + 6]
            x7 = x[i + 7]
            for b in range(nb):
                v0 = x0[b]
                v1 = x1[b]
                v2 = x2[b]
                v3 = x3[b]
                v4 = x4[b]
                v5 = x5[b]
                v6 = x6[b]
                v7 = x7[b]
                ya[b] += (a0 * v0 + a1 * v1 + a2 * v2 + a3 * v3
                          + a4 * v4 + a5 * v5 + a6 * v6 + a7 * v7)
                yb[b] += (c0 * v0 + c1 * v1 + c2 * v2 + c3 * v3
                          + c4 * v4 + c5 * v5 + c6 * v6 + c7 * v7)
        for i in range(n8, n_in):
            a0 = w[o, i]
            c0 = w[o + 1, i]
            x0 = x[i]
            for b in range(nb):
                ya[b] += a0 * x0[b]
                yb[b] += c0 * x0[b]
    if n_out % 2:
        _matmul_row(w, x, y[n_out - 1], n_out - 1, n_in, nb)


@njit(cache=True, nogil=True, fastmath=True)
def _activate(y, n_rows, nb, code):
    if code == 0:
        return
    if code == 1:                           # ReLU, the common case: a plain vector loop
        for o in range(n_rows):
            yo = y[o]
            for b in range(nb):
                yo[b] = max(yo[b], np.float32(0.0))
        return
    for o in range(n_rows):
        yo = y[o]
        for b in range(nb):
            yo[b] = _act(yo[b], code)


@njit(cache=True, nogil=True)
def mlp_forward(mats, shapes, act_hidden, act_out, n_out_used, x, buf_a, buf_b, nb):
    """Run an MLP given as ``mats`` (flat float32) with layer ``shapes`` ((n_layers, 2) out, in)
    on ``x`` (in, nb); returns the buffer holding the output rows (first ``n_out_used``)."""
    n_layers = shapes.shape[0]
    src = x
    off = 0
    for k in range(n_layers):
        n_o = shapes[k, 0]
        n_i = shapes[k, 1]
        w = mats[off:off + n_o * n_i].reshape((n_o, n_i))
        off += n_o * n_i
        dst = buf_a if k % 2 == 0 else buf_b
        last = k == n_layers - 1
        rows = n_out_used if last else n_o
        _matmul(w, src, dst, rows, n_i, nb)
        _activate(dst, rows, nb, act_out if last else act_hidden)
        src = dst
    return src


@njit(cache=True, nogil=True, fastmath=True)
def _eval_batch(nb, where, enc, buf_a, buf_b, dens, pre, h1, acc, sel,
                d_mats, d_shapes, d_act, d_out_act,
                r_mats, r_shapes, r_act, r_out_act, r_first_a, dir_consts,
                rgb_act, sigma_factor, colour_cut, fs, fr):
    """Steps 3-4 of the module docstring for the ``nb`` encoded voxels in ``enc`` (columns);
    results written to the flat outputs at ``where``.  The colour network runs only for the
    voxels whose density (float32, the caller's units) reaches ``colour_cut`` when it is
    positive (the others keep colour 0); ``sel`` (batch) int64 work space."""
    n_d_out = d_shapes[d_shapes.shape[0] - 1, 0]
    r_w = r_shapes[0, 0]
    n_r = r_shapes.shape[0]
    n_dirs = dir_consts.shape[0]
    out = mlp_forward(d_mats, d_shapes, d_act, d_out_act, n_d_out, enc, buf_a, buf_b, nb)
    n_c = 0
    for b in range(nb):
        sg = np.float32(math.exp(out[0, b]) * sigma_factor)
        fs[where[b]] = sg
        if colour_cut <= 0.0 or sg >= colour_cut:
            sel[n_c] = b
            n_c += 1
    if n_c == 0:
        return
    for o in range(n_d_out):
        for j in range(n_c):
            dens[o, j] = out[o, sel[j]]
    nb = n_c
    _matmul(r_first_a, dens, pre, r_w, n_d_out, nb)
    for c in range(3):
        for b in range(nb):
            acc[c, b] = 0.0
    r_rest = r_mats[r_shapes[0, 0] * r_shapes[0, 1]:]
    r_rest_shapes = r_shapes[1:]
    for kd in range(n_dirs):
        for o in range(r_w):
            cst = dir_consts[kd, o]
            po = pre[o]
            ho = h1[o]
            for b in range(nb):
                ho[b] = po[b] + cst
        if n_r > 1:
            _activate(h1, r_w, nb, r_act)
            res_out = mlp_forward(r_rest, r_rest_shapes, r_act, r_out_act, 3, h1,
                                  buf_a, buf_b, nb)
        else:
            _activate(h1, 3, nb, r_out_act)
            res_out = h1
        for c in range(3):
            for b in range(nb):
                v = res_out[c, b]
                if rgb_act == 0:
                    v = np.float32(1.0 / (1.0 + math.exp(-v)))
                else:
                    v = np.float32(math.exp(min(max(v, -10.0), 10.0)))
                acc[c, b] += v
    inv_dirs = np.float32(1.0 / n_dirs)
    for b in range(nb):
        flat = where[sel[b]]
        fr[flat, 0] = acc[0, b] * inv_dirs
        fr[flat, 1] = acc[1, b] * inv_dirs
        fr[flat, 2] = acc[2, b] * inv_dirs


@njit(cache=True, nogil=True)
def _row_axis(A, xs, la=0):
    """The one instant-ngp axis that varies along a printer line along source axis ``la``
    (``A[:, la]`` has a single non-zero), if the line's voxel centres ``xs`` also increase;
    else -1 (the general path)."""
    ax = -1
    for d in range(3):
        if A[d, la] != 0.0:
            if ax >= 0:
                return -1
            ax = d
    for i in range(1, xs.shape[0]):
        if not xs[i] > xs[i - 1]:
            return -1
    return ax


@njit(cache=True, nogil=True)
def sample_rows(r0, r1, la, xs, ys, zs, A, t, aabb_lo, aabb_hi, box_R, box_lo, box_hi,
                occ, use_occ, max_cascade,
                table, n_feat, offsets, scales, res, hashed, interp, enc_width,
                d_mats, d_shapes, d_act, d_out_act,
                r_mats, r_shapes, r_act, r_out_act, r_first_a, dir_consts,
                rgb_act, sigma_factor, colour_cut, sigma, rgb):
    """Evaluate lines ``r0..r1-1`` of a slab into ``sigma`` (nz, ny, nx) and ``rgb``
    (nz, ny, nx, 3), lines along source x (``la`` 0: rows, line r = layer r // ny, y r % ny)
    or along source y (``la`` 1: columns, line r = layer r // nx, x r % nx; the outputs must
    then be zero beforehand: a column's voxels lie a row apart): steps 1-4 of the
    module docstring; voxels left out by step 1 get density 0 and colour 0.  ``sigma_factor``
    turns instant-ngp's density (per its unit) into the caller's units; ``rgb_act``: 0
    sigmoid, 1 exp(clamp(., -10, 10));
    ``colour_cut`` (float32, > 0): colour only where the density reaches it (a print job's
    background threshold: it reads no colour below), the rest colour 0.

    Rows along which one instant-ngp axis varies (every placement the reader makes) take the
    row path: the voxels inside the boxes as one interval and the occupancy grid tested a block
    of voxels at a time (:mod:`.occupancy`), the coarse levels of the encoding a row at a
    time (:mod:`.encode`); other rows are tested and encoded voxel by voxel.  Either way
    a row's voxels fill the columns of batches of :data:`BATCH` for the networks."""
    ny = ys.shape[0]
    nx = xs.shape[0]
    # the line's coordinates, the layer's other coordinate, and where a line's voxels lie
    lc = xs if la == 0 else ys
    oc = ys if la == 0 else xs
    ob = 1 if la == 0 else 0
    n_line = lc.shape[0]
    n_oth = oc.shape[0]
    stride = 1 if la == 0 else nx
    n_levels = scales.shape[0]
    d_w = d_shapes[0, 0]
    n_d_out = d_shapes[d_shapes.shape[0] - 1, 0]
    r_w = r_shapes[0, 0]
    width = max(max(d_w, r_w), max(n_d_out, enc_width))
    enc = np.zeros((enc_width, BATCH), np.float32)
    buf_a = np.empty((width, BATCH), np.float32)
    buf_b = np.empty((width, BATCH), np.float32)
    dens = np.empty((n_d_out, BATCH), np.float32)
    pre = np.empty((r_w, BATCH), np.float32)
    h1 = np.empty((r_w, BATCH), np.float32)
    acc = np.empty((3, BATCH), np.float32)
    sel = np.empty(BATCH, np.int64)
    u = np.empty((3, BATCH), np.float32)
    where = np.empty(BATCH, np.int64)
    line = np.empty((n_feat, n_line + 4), np.float32)
    gcol = np.empty(BATCH, np.int32)
    wcol = np.empty(BATCH, np.float32)
    vox = np.empty(n_line, np.int64)
    row_form = np.zeros(n_levels, np.bool_)
    seg_c0 = np.empty(BATCH, np.int64)
    seg_c1 = np.empty(BATCH, np.int64)
    seg_ufix = np.empty((BATCH, 3), np.float32)
    q = np.empty(3, np.float64)
    qrow = np.empty(3, np.float64)
    brow = np.empty(3, np.float64)
    bx = np.empty(3, np.float64)
    a = np.empty(3, np.float64)
    inv_ext = 1.0 / (aabb_hi - aabb_lo)
    # the box test R q = R (qrow + A[:, la] x): per-line base plus a per-voxel step
    for d in range(3):
        a[d] = A[d, la]
        bx[d] = box_R[d, 0] * A[0, la] + box_R[d, 1] * A[1, la] + box_R[d, 2] * A[2, la]
    ax = _row_axis(A, lc, la)
    if ax >= 0:
        # the largest step between neighbouring voxels: a line never outgrows its voxels
        step = 0.0
        for i in range(1, n_line):
            step = max(step, lc[i] - lc[i - 1])
        du = abs(A[ax, la]) * step * inv_ext[ax]
        row_form_levels(scales, interp, du, row_form)
    n_seg = 0
    fs = sigma.reshape(-1)
    fr = rgb.reshape(-1, 3)
    fr3 = rgb.reshape(-1)
    nb = 0
    for row in range(r0, r1):
        lz = row // n_oth
        j = row % n_oth
        base = lz * ny * nx + (j * nx if la == 0 else j)
        for d in range(3):
            qrow[d] = A[d, ob] * oc[j] + A[d, 2] * zs[lz] + t[d]
        for d in range(3):
            brow[d] = box_R[d, 0] * qrow[0] + box_R[d, 1] * qrow[1] + box_R[d, 2] * qrow[2]
        if la == 0:                         # (columns: the caller zeroes the outputs at once)
            for i in range(nx):
                fs[base + i] = 0.0
            for i in range(3 * base, 3 * (base + nx)):
                fr3[i] = 0.0
        # step 1: the row's voxels to evaluate
        if ax >= 0:
            i0, i1 = row_span(lc, qrow, a, brow, bx, aabb_lo, aabb_hi, box_lo, box_hi)
            k = row_voxels(lc, i0, i1, qrow, a, ax, occ, use_occ, max_cascade, q, vox)
        else:
            k = 0
            for i in range(n_line):
                x = lc[i]
                inside = True
                for d in range(3):
                    q[d] = qrow[d] + A[d, la] * x
                    if q[d] < aabb_lo[d] or q[d] > aabb_hi[d]:
                        inside = False
                    v = brow[d] + bx[d] * x
                    if v < box_lo[d] or v > box_hi[d]:
                        inside = False
                if inside and (not use_occ or occupied(q, occ, max_cascade)):
                    vox[k] = i
                    k += 1
        if k == 0:
            continue
        # the row's voxels into batch columns, a piece (segment) at a time
        j0 = 0
        while j0 < k:
            m = min(k - j0, BATCH - nb)
            for jj in range(m):
                i = vox[j0 + jj]
                x = lc[i]
                for d in range(3):
                    u[d, nb + jj] = np.float32((qrow[d] + A[d, la] * x - aabb_lo[d]) * inv_ext[d])
                where[nb + jj] = base + i * stride
            for d in range(3):
                seg_ufix[n_seg, d] = np.float32((qrow[d] - aabb_lo[d]) * inv_ext[d])
            seg_c0[n_seg] = nb
            seg_c1[n_seg] = nb + m
            n_seg += 1
            nb += m
            j0 += m
            if nb == BATCH:
                encode_batch(u, nb, ax, row_form, seg_c0, seg_c1, seg_ufix, n_seg, table,
                             n_feat, offsets, scales, res, hashed, interp, enc, line, gcol,
                             wcol)
                _eval_batch(nb, where, enc, buf_a, buf_b, dens, pre, h1, acc, sel,
                            d_mats, d_shapes, d_act, d_out_act,
                            r_mats, r_shapes, r_act, r_out_act, r_first_a, dir_consts,
                            rgb_act, sigma_factor, colour_cut, fs, fr)
                nb = 0
                n_seg = 0
    if nb:
        encode_batch(u, nb, ax, row_form, seg_c0, seg_c1, seg_ufix, n_seg, table, n_feat,
                     offsets, scales, res, hashed, interp, enc, line, gcol, wcol)
        _eval_batch(nb, where, enc, buf_a, buf_b, dens, pre, h1, acc, sel,
                    d_mats, d_shapes, d_act, d_out_act,
                    r_mats, r_shapes, r_act, r_out_act, r_first_a, dir_consts,
                    rgb_act, sigma_factor, colour_cut, fs, fr)
