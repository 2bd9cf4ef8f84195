"""Compiled CPU evaluation of an InstantNGP NeRF: hash encoding, density and colour MLPs.

Defines :func:`sample_rows` (one call per group of printer rows; releases the GIL) and the
activation codes :data:`ACT`.  The layout it evaluates is the one
:mod:`.ingp` reads from a snapshot; the equations, step by step (tiny-cuda-nn
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
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["ACT", "sample_rows", "encode_batch", "mlp_forward"]

# hidden/output activation codes (tiny-cuda-nn names)
ACT = {"none": 0, "relu": 1, "leakyrelu": 2, "exponential": 3, "sigmoid": 4, "tanh": 5}

BATCH = 256
HASH_P1 = np.uint32(2654435761)
HASH_P2 = np.uint32(805459861)


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
def encode_batch(u, nb, table, n_feat, offsets, scales, res, hashed, interp, enc, scratch):
    """Multiresolution hash encoding of relative positions ``u`` (3, nb) into ``enc``
    (levels * n_feat (+ zero padding), nb): step 2 of the module docstring.
    ``interp``: 0 linear, 1 smoothstep, 2 nearest.  Each level runs as simple loops over the
    batch (compiled to vector instructions): corner cells and weights; the per-axis index terms
    ``x``, ``y P1``, ``z P2`` (hashed) or ``x``, ``y r``, ``z r^2`` (dense), uint32, for both
    corners along each axis; then per corner the combined index reduced to the level's table
    and the weighted gather.  ``scratch``: (>= 16, nb) float32 work space."""
    n_levels = scales.shape[0]
    w1 = scratch[0:3]                       # weight of the upper corner per axis
    w0 = scratch[3:6]                       # weight of the lower corner
    term = scratch[6:12].view(np.uint32)    # [axis * 2 + corner] index terms
    idx = scratch[12].view(np.uint32)
    wt = scratch[13]
    one = np.uint32(1)
    for lvl in range(n_levels):
        s = scales[lvl]
        r = np.uint32(res[lvl])
        size_i = offsets[lvl + 1] - offsets[lvl]
        size = np.uint32(size_i)
        pow2 = (size_i & (size_i - 1)) == 0
        mask = np.uint32(size_i - 1)
        tab = table[offsets[lvl]:offsets[lvl + 1]]
        hsh = hashed[lvl] != 0
        row = lvl * n_feat
        if hsh:
            mult = (np.uint32(1), HASH_P1, HASH_P2)
        else:
            mult = (np.uint32(1), r, np.uint32(r * r))
        for d in range(3):
            ud = u[d]
            a1 = w1[d]
            a0 = w0[d]
            t0 = term[2 * d]
            t1 = term[2 * d + 1]
            m = mult[d]
            for b in range(nb):
                p = s * ud[b] + np.float32(0.5)
                fl = np.floor(p)
                v = p - fl
                if interp == 1:
                    v = v * v * (np.float32(3.0) - np.float32(2.0) * v)
                a1[b] = v
                a0[b] = np.float32(1.0) - v
                gi = np.uint32(np.int32(fl))
                t0[b] = np.uint32(gi * m)
                t1[b] = np.uint32((gi + one) * m)
        for f in range(n_feat):
            ef = enc[row + f]
            for b in range(nb):
                ef[b] = 0.0
        n_corners = 1 if interp == 2 else 8
        for c in range(n_corners):
            tx = term[c & 1]
            ty = term[2 + ((c >> 1) & 1)]
            tz = term[4 + ((c >> 2) & 1)]
            if hsh and pow2:
                for b in range(nb):
                    idx[b] = (tx[b] ^ ty[b] ^ tz[b]) & mask
            elif hsh:
                for b in range(nb):
                    idx[b] = np.uint32((tx[b] ^ ty[b] ^ tz[b]) % size)
            else:
                for b in range(nb):
                    h = np.uint32(tx[b] + ty[b] + tz[b])
                    idx[b] = h if h < size else np.uint32(h % size)
            if interp == 2:
                for b in range(nb):
                    wt[b] = 1.0
            else:
                wx = w1[0] if c & 1 else w0[0]
                wy = w1[1] if (c >> 1) & 1 else w0[1]
                wz = w1[2] if (c >> 2) & 1 else w0[2]
                for b in range(nb):
                    wt[b] = wx[b] * wy[b] * wz[b]
            if n_feat == 2:
                e0 = enc[row]
                e1 = enc[row + 1]
                for b in range(nb):
                    k = idx[b]
                    e0[b] += wt[b] * tab[k, 0]
                    e1[b] += wt[b] * tab[k, 1]
            else:
                for f in range(n_feat):
                    ef = enc[row + f]
                    for b in range(nb):
                        ef[b] += wt[b] * tab[idx[b], f]


@njit(cache=True, nogil=True, inline="always")
def _occupied(q, occ, max_cascade):
    """Step 1's occupancy test (instant-ngp ``mip_from_pos`` and ``cascaded_grid_idx_at``)."""
    m = 0.0
    for d in range(3):
        a = abs(q[d] - 0.5)
        if a > m:
            m = a
    # mip = clamp(e + 1, 0, max_cascade) with m = f 2^e, f in [0.5, 1) (frexp; e = 0 for m = 0)
    mip = 0
    if m == 0.0:
        mip = min(1, max_cascade)
    else:
        lim = 0.5
        while mip < max_cascade and m >= lim:
            mip += 1
            lim *= 2.0
    sc = 1.0 / (1 << mip)
    n = occ.shape[1]
    ix = int(((q[0] - 0.5) * sc + 0.5) * n)
    iy = int(((q[1] - 0.5) * sc + 0.5) * n)
    iz = int(((q[2] - 0.5) * sc + 0.5) * n)
    if ix < 0 or iy < 0 or iz < 0 or ix >= n or iy >= n or iz >= n:
        return False
    return occ[mip, iz, iy, ix] != 0


@njit(cache=True, nogil=True, fastmath=True)
def _eval_batch(nb, u, where, enc, scratch, buf_a, buf_b, dens, pre, h1, acc,
                table, n_feat, offsets, scales, res, hashed, interp,
                d_mats, d_shapes, d_act, d_out_act,
                r_mats, r_shapes, r_act, r_out_act, r_first_a, dir_consts,
                rgb_act, sigma_factor, fs, fr):
    """Steps 2-4 of the module docstring for the ``nb`` positions in ``u``; results written to
    the flat outputs at ``where``."""
    n_d_out = d_shapes[d_shapes.shape[0] - 1, 0]
    r_w = r_shapes[0, 0]
    n_r = r_shapes.shape[0]
    n_dirs = dir_consts.shape[0]
    encode_batch(u, nb, table, n_feat, offsets, scales, res, hashed, interp, enc, scratch)
    out = mlp_forward(d_mats, d_shapes, d_act, d_out_act, n_d_out, enc, buf_a, buf_b, nb)
    for o in range(n_d_out):
        for b in range(nb):
            dens[o, b] = out[o, b]
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
        flat = where[b]
        fs[flat] = np.float32(math.exp(dens[0, b]) * sigma_factor)
        fr[flat, 0] = acc[0, b] * inv_dirs
        fr[flat, 1] = acc[1, b] * inv_dirs
        fr[flat, 2] = acc[2, b] * inv_dirs


@njit(cache=True, nogil=True)
def sample_rows(r0, r1, xs, ys, zs, A, t, aabb_lo, aabb_hi, box_R, box_lo, box_hi,
                occ, use_occ, max_cascade,
                table, n_feat, offsets, scales, res, hashed, interp, enc_width,
                d_mats, d_shapes, d_act, d_out_act,
                r_mats, r_shapes, r_act, r_out_act, r_first_a, dir_consts,
                rgb_act, sigma_factor, sigma, rgb):
    """Evaluate rows ``r0..r1-1`` of a slab (row r = layer r // ny, y r % ny) into ``sigma``
    (nz, ny, nx) and ``rgb`` (nz, ny, nx, 3): steps 1-4 of the module docstring; voxels left
    out by step 1 get density 0 and colour 0.  ``sigma_factor`` turns instant-ngp's density
    (per its unit) into the caller's units; ``rgb_act``: 0 sigmoid, 1 exp(clamp(., -10, 10))."""
    ny = ys.shape[0]
    nx = xs.shape[0]
    d_w = d_shapes[0, 0]
    n_d_out = d_shapes[d_shapes.shape[0] - 1, 0]
    r_w = r_shapes[0, 0]
    width = max(max(d_w, r_w), max(n_d_out, enc_width))
    enc = np.zeros((enc_width, BATCH), np.float32)
    scratch = np.zeros((16, BATCH), np.float32)
    buf_a = np.empty((width, BATCH), np.float32)
    buf_b = np.empty((width, BATCH), np.float32)
    dens = np.empty((n_d_out, BATCH), np.float32)
    pre = np.empty((r_w, BATCH), np.float32)
    h1 = np.empty((r_w, BATCH), np.float32)
    acc = np.empty((3, BATCH), np.float32)
    u = np.empty((3, BATCH), np.float32)
    where = np.empty(BATCH, np.int64)
    q = np.empty(3, np.float64)
    qrow = np.empty(3, np.float64)
    brow = np.empty(3, np.float64)
    bx = np.empty(3, np.float64)
    inv_ext = 1.0 / (aabb_hi - aabb_lo)
    # the box test R q = R (qrow + A[:, 0] x): per-row base plus a per-voxel step
    for d in range(3):
        bx[d] = box_R[d, 0] * A[0, 0] + box_R[d, 1] * A[1, 0] + box_R[d, 2] * A[2, 0]
    fs = sigma.reshape(-1)
    fr = rgb.reshape(-1, 3)
    fr3 = rgb.reshape(-1)
    nb = 0
    for row in range(r0, r1):
        lz = row // ny
        j = row % ny
        base = row * nx
        for d in range(3):
            qrow[d] = A[d, 1] * ys[j] + A[d, 2] * zs[lz] + t[d]
        for d in range(3):
            brow[d] = box_R[d, 0] * qrow[0] + box_R[d, 1] * qrow[1] + box_R[d, 2] * qrow[2]
        for i in range(nx):
            fs[base + i] = 0.0
        for i in range(3 * base, 3 * (base + nx)):
            fr3[i] = 0.0
        for i in range(nx):
            flat = base + i
            x = xs[i]
            inside = True
            for d in range(3):
                q[d] = qrow[d] + A[d, 0] * x
                if q[d] < aabb_lo[d] or q[d] > aabb_hi[d]:
                    inside = False
                v = brow[d] + bx[d] * x
                if v < box_lo[d] or v > box_hi[d]:
                    inside = False
            if not inside:
                continue
            if use_occ and not _occupied(q, occ, max_cascade):
                continue
            for d in range(3):
                u[d, nb] = np.float32((q[d] - aabb_lo[d]) * inv_ext[d])
            where[nb] = flat
            nb += 1
            if nb == BATCH:
                _eval_batch(nb, u, where, enc, scratch, buf_a, buf_b, dens, pre, h1, acc,
                            table, n_feat, offsets, scales, res, hashed, interp,
                            d_mats, d_shapes, d_act, d_out_act,
                            r_mats, r_shapes, r_act, r_out_act, r_first_a, dir_consts,
                            rgb_act, sigma_factor, fs, fr)
                nb = 0
    if nb:
        _eval_batch(nb, u, where, enc, scratch, buf_a, buf_b, dens, pre, h1, acc,
                    table, n_feat, offsets, scales, res, hashed, interp,
                    d_mats, d_shapes, d_act, d_out_act,
                    r_mats, r_shapes, r_act, r_out_act, r_first_a, dir_consts,
                    rgb_act, sigma_factor, fs, fr)
