"""A sparse VDB grid (8^3 leaf blocks, :class:`.sampling.SparseBlocks`) densified over its
leaves' bounding box and sampled one output layer at a time, with the arithmetic of
:func:`.sampling.sample_sparse` (OpenVDB's ``BoxSampler``), bit for bit.

Defines :func:`densify` (the dense copy, when it fits :data:`MAX_DENSE_VOXELS`),
:func:`index_axis` (the per-axis integer corner and weight) and :func:`leaf_grid_layer` (one
output layer's densities, compiled).

Why: the sparse sampler finds the leaf of each corner through a two-level table for every run
of printer voxels and interpolates one voxel at a time (~100 ns per voxel on the project's
2-core VM); in a dense copy the four source rows (j0, j0+1) x (k0, k0+1) an output row needs
are plain arrays, so the (y, z) interpolation of a row runs over whole source rows as vector
instructions and the x interpolation is one gather and one multiply-add per voxel.

Same bits: :func:`.sampling.sample_sparse` computes, per printer voxel, the bilinear (y, z)
values at the two bracketing index planes, ``va = (v(i0, j0, k0) (1 - wj) + v(i0, j0+1, k0) wj)
(1 - wk) + (v(i0, j0, k0+1) (1 - wj) + v(i0, j0+1, k0+1) wj) wk`` (rounded to float32) and
``vb`` at ``i0 + 1``, then ``va + (vb - va) wi``. Here the same expression, with the same types,
gives ``va`` of every source index of the row at once, and voxels in no leaf read 0 in both
(only a background of +0.0, every fog volume's, is densified).
"""

from __future__ import annotations

import math
import threading

import numpy as np
from numba import njit

from dreamprint_gui.io.volumes.base import voxel_centres
from dreamprint_gui.io.volumes.dense_sampler import rows_with_data

__all__ = ["MAX_DENSE_VOXELS", "densify", "index_axis", "leaf_grid_layer", "leaf_grid_values",
           "leaf_grid_values_where", "LeafGridPlan"]

# 64 Mi voxels (256 MB of float32) per densified grid; larger ones keep the sparse sampler.
MAX_DENSE_VOXELS = 1 << 26


@njit(cache=True, nogil=True)
def _fill(values, origins, lo, out):
    for n in range(origins.shape[0]):
        oi = origins[n, 0] - lo[0]
        oj = origins[n, 1] - lo[1]
        ok = origins[n, 2] - lo[2]
        for a in range(8):
            for b in range(8):
                for c in range(8):
                    for ch in range(values.shape[4]):
                        out[ok + c, oj + b, oi + a, ch] = values[n, a, b, c, ch]


def densify(origins: np.ndarray, values: np.ndarray, background: np.ndarray,
            channels: bool = False, limit: int = MAX_DENSE_VOXELS):
    """(dense (nk, nj, ni) float32 indexed [k, j, i] (``channels``: (nk, nj, ni, C)), its
    index of element [0, 0, 0] as (i, j, k), rows with data (nk, nj) bool) of a leaf grid
    whose background is +0.0; one voxel of 0 pads every side. None if the background is
    another value, the grid has no leaves, more than one channel (unless ``channels``), or
    more than ``limit`` values (default :data:`MAX_DENSE_VOXELS`)."""
    bg = np.asarray(background, np.float32).reshape(-1)
    nc = values.shape[-1]
    if ((nc != 1 and not channels) or len(origins) == 0 or np.any(bg != 0)
            or np.any(np.signbit(bg))):
        return None
    o = np.asarray(origins, np.int64).reshape(-1, 3)
    lo = o.min(axis=0) - 1
    hi = o.max(axis=0) + 8 + 1
    shape = tuple(int(v) for v in (hi - lo)[::-1])
    if math.prod(shape) * nc > limit:
        return None
    out = np.zeros(shape + (nc,), np.float32)
    _fill(values, o, lo, out)
    rows = rows_with_data(out)
    return (out if channels else out[..., 0]), lo, rows


def index_axis(u: np.ndarray, lo: int) -> tuple[np.ndarray, np.ndarray]:
    """(corner index relative to the dense copy's element 0 (int64), weight (float32)) at
    continuous index coordinates ``u``: ``floor(u) - lo`` and ``float32(u - floor(u))``, as
    :func:`.sampling.sample_sparse` computes them."""
    f = np.floor(np.asarray(u, np.float64))
    return f.astype(np.int64) - int(lo), (u - f).astype(np.float32)


@njit(cache=True, nogil=True, error_model="numpy")
def leaf_grid_layer(dense, rows_nz, k0, wk, j0, wj, i0, wi, plane, scale, sigma, r0=0, nrows=-1):
    """One output layer's density ``max(v, 0) * scale`` (the fog volume's rule of
    :mod:`.openvdb` and :mod:`.nanovdb`) into ``sigma`` (ny * nx), ``v`` the trilinear sample of
    the densified grid ``dense`` (nk, nj, ni) at layer corner ``k0`` / weight ``wk`` (a
    scalar), rows ``j0``/``wj`` (ny,) and columns ``i0``/``wi`` (nx,) (:func:`index_axis`);
    ``plane`` (ni,) float32 scratch. The reconstruction step of sampling (paper sec. 4.1: the
    volume's extinction at each printer voxel centre). With ``nrows >= 0``, the output rows
    ``r0 .. r0 + nrows - 1`` only, into an array of those rows (a strip: the same values)."""
    nk, nj, ni = dense.shape
    nyo = j0.shape[0] if nrows < 0 else nrows
    nxo = i0.shape[0]
    zero = np.float32(0.0)
    k_ok = 0 <= k0 and k0 + 1 < nk
    for jl in range(nyo):
        jj = r0 + jl
        b = j0[jj]
        out = sigma[jl * nxo:(jl + 1) * nxo]
        if not (k_ok and 0 <= b and b + 1 < nj and (rows_nz[k0, b] or rows_nz[k0, b + 1]
                                                  or rows_nz[k0 + 1, b]
                                                  or rows_nz[k0 + 1, b + 1])):
            out[:] = zero              # every corner 0: the sparse sampler's +0.0
            continue
        wj_ = wj[jj]
        r00 = dense[k0, b]
        r10 = dense[k0, b + 1]
        r01 = dense[k0 + 1, b]
        r11 = dense[k0 + 1, b + 1]
        for i in range(ni):             # sampling.py _corner_planes, for every i at once
            y0 = r00[i] * (1 - wj_) + r10[i] * wj_
            y1 = r01[i] * (1 - wj_) + r11[i] * wj_
            plane[i] = y0 * (1 - wk) + y1 * wk
        for ii in range(nxo):
            a = i0[ii]
            v = zero
            if 0 <= a and a + 1 < ni:
                va = plane[a]
                vb = plane[a + 1]
                v = va + (vb - va) * wi[ii]
            d = v if (v >= zero or v != v) else zero      # np.maximum(v, 0): NaN, -0.0 kept
            out[ii] = d * scale


@njit(cache=True, nogil=True, error_model="numpy")
def leaf_grid_values(dense, rows_nz, k0, wk, j0, wj, i0, wi, plane, out):
    """Trilinear samples (L, ny, nx, C) of a densified multi-channel grid ``dense`` (nk, nj,
    ni, C) into ``out``, corners and weights as :func:`leaf_grid_layer` (``k0``, ``wk`` per
    layer), ``plane`` (C, ni) scratch: :func:`.sampling.sample_sparse`'s values, bit for bit
    (e.g. an OpenVDB colour grid; the reconstruction step of sampling, paper sec. 4.1)."""
    nk, nj, ni, nc = dense.shape
    zero = np.float32(0.0)
    for kk in range(k0.shape[0]):
        k = k0[kk]
        wk_ = wk[kk]
        k_ok = 0 <= k and k + 1 < nk
        for jj in range(j0.shape[0]):
            b = j0[jj]
            o = out[kk, jj]
            if not (k_ok and 0 <= b and b + 1 < nj and (rows_nz[k, b] or rows_nz[k, b + 1]
                                                     or rows_nz[k + 1, b]
                                                     or rows_nz[k + 1, b + 1])):
                o[:, :] = zero
                continue
            wj_ = wj[jj]
            for c in range(nc):
                r00 = dense[k, b, :, c]
                r10 = dense[k, b + 1, :, c]
                r01 = dense[k + 1, b, :, c]
                r11 = dense[k + 1, b + 1, :, c]
                p = plane[c]
                for i in range(ni):
                    y0 = r00[i] * (1 - wj_) + r10[i] * wj_
                    y1 = r01[i] * (1 - wj_) + r11[i] * wj_
                    p[i] = y0 * (1 - wk_) + y1 * wk_
            for ii in range(i0.shape[0]):
                a = i0[ii]
                if 0 <= a and a + 1 < ni:
                    for c in range(nc):
                        va = plane[c, a]
                        vb = plane[c, a + 1]
                        o[ii, c] = va + (vb - va) * wi[ii]
                else:
                    for c in range(nc):
                        o[ii, c] = zero


@njit(cache=True, nogil=True, inline="always")
def _x_lerp3(plane, a_lo, ni, ia, wa, o):
    """The x interpolation of :func:`leaf_grid_values_where` for three channels, unrolled."""
    zero = np.float32(0.0)
    for ii in range(ia.shape[0]):
        a = ia[ii]
        w = wa[ii]
        if 0 <= a and a + 1 < ni:
            q = (a - a_lo) * 3
            va = plane[q]
            vb = plane[q + 3]
            o[3 * ii] = va + (vb - va) * w
            va = plane[q + 1]
            vb = plane[q + 4]
            o[3 * ii + 1] = va + (vb - va) * w
            va = plane[q + 2]
            vb = plane[q + 5]
            o[3 * ii + 2] = va + (vb - va) * w
        else:
            o[3 * ii] = zero
            o[3 * ii + 1] = zero
            o[3 * ii + 2] = zero


@njit(cache=True, nogil=True, error_model="numpy")
def leaf_grid_values_where(dense, rows_nz, k, wk_, j0, wj, i0, wi, plane, out, dens, threshold,
                           r0=0, nrows=-1):
    """:func:`leaf_grid_values` of one output layer (corner ``k``, weight ``wk_``) into ``out``
    (ny * nx * C, voxel-major), at the voxels whose ``dens`` (ny * nx,) reaches ``threshold``
    (NaN does not): a layer's colour for a consumer that reads it at those voxels only
    (:func:`...job.sample_label.layer_kernel.layer_labels`). Written: each row's span from its
    first to its last such voxel, with :func:`leaf_grid_values`' values bit for bit (the same
    expressions and types); the rest of ``out`` keeps what it held. ``plane`` (>= ni * C,)
    float32 scratch.

    Per output row: the span [lo, hi] of its foreground voxels; no work for a row without one
    (the benchmark's smoke cloud: 41 % of the voxels lie in such rows); else the (y, z)
    interpolated source row over the source columns that span reads, all channels in one
    contiguous pass (the channel-interleaved row as one vector loop; one channel at a time read
    every third value), then the x interpolation over the span. A cloud's row holds its
    foreground in one run (spans: 35.8 % of that cloud's voxels, foreground 35.6 %), so the
    span is not compacted further. With ``nrows >= 0``, the output rows ``r0 .. r0 + nrows -
    1`` only, ``out`` and ``dens`` holding those rows (a strip)."""
    nk, nj, ni, nc = dense.shape
    nyo = j0.shape[0] if nrows < 0 else nrows
    nxo = i0.shape[0]
    zero = np.float32(0.0)
    k_ok = 0 <= k and k + 1 < nk
    for jl in range(nyo):
        jj = r0 + jl
        base = jl * nxo
        lo = nxo
        hi = -1
        for ii in range(nxo):           # vectorised: the row's foreground span
            f = dens[base + ii] >= threshold
            lo = min(lo, ii if f else nxo)
            hi = max(hi, ii if f else -1)
        if hi < 0:
            continue
        o = out[nc * (base + lo):nc * (base + hi + 1)]
        b = j0[jj]
        if not (k_ok and 0 <= b and b + 1 < nj and (rows_nz[k, b] or rows_nz[k, b + 1]
                                                 or rows_nz[k + 1, b]
                                                 or rows_nz[k + 1, b + 1])):
            o[:] = zero
            continue
        # the source columns the span reads: a and a + 1 of every in-grid corner a
        a_lo = ni
        a_hi = -1
        for ii in range(lo, hi + 1):
            a = i0[ii]
            ok = 0 <= a and a + 1 < ni
            a_lo = min(a_lo, a if ok else ni)
            a_hi = max(a_hi, a + 1 if ok else -1)
        if a_hi >= 0:
            wj_ = wj[jj]
            r00 = dense[k, b].reshape(-1)[a_lo * nc:(a_hi + 1) * nc]
            r10 = dense[k, b + 1].reshape(-1)[a_lo * nc:(a_hi + 1) * nc]
            r01 = dense[k + 1, b].reshape(-1)[a_lo * nc:(a_hi + 1) * nc]
            r11 = dense[k + 1, b + 1].reshape(-1)[a_lo * nc:(a_hi + 1) * nc]
            p = plane[:(a_hi + 1 - a_lo) * nc]
            for t in range(p.shape[0]):    # leaf_grid_values' plane, every channel at once
                y0 = r00[t] * (1 - wj_) + r10[t] * wj_
                y1 = r01[t] * (1 - wj_) + r11[t] * wj_
                p[t] = y0 * (1 - wk_) + y1 * wk_
        if nc == 3:
            _x_lerp3(plane, a_lo, ni, i0[lo:hi + 1], wi[lo:hi + 1], o)
            continue
        for ii in range(hi + 1 - lo):
            a = i0[lo + ii]
            w = wi[lo + ii]
            if 0 <= a and a + 1 < ni:
                q = (a - a_lo) * nc
                for c in range(nc):
                    va = plane[q + c]
                    vb = plane[q + nc + c]
                    o[ii * nc + c] = va + (vb - va) * w
            else:
                for c in range(nc):
                    o[ii * nc + c] = zero


class LeafGridPlan:
    """A fog volume's densified copy, made on first use and kept (:func:`densify`; ``None``
    when it does not apply), and the per-slab arguments of
    :func:`...job.sample_label.leaf_grid_job.leaf_grid_slab_labels`."""

    def __init__(self, blocks, origin: np.ndarray, scale: np.ndarray):
        self._blocks = blocks
        self.origin = np.asarray(origin, float)
        self.scale = np.asarray(scale, float)
        self._dense = None
        self._tried = False
        self._lock = threading.Lock()     # worker threads share the source: one copy

    def dense(self):
        with self._lock:
            if not self._tried:
                b = self._blocks
                self._dense = densify(b.origins, b.values, b.background)
                self._tried = True
        return self._dense

    def args(self, grid, z0: int, z1: int, density_scale: float, uniform) -> tuple | None:
        """The plan of layers z0..z1-1 of ``grid`` (a :class:`.base.PrintGrid`), or None."""

        d = self.dense()
        if d is None:
            return None
        dense, lo, rows = d
        # the index coordinates of the sparse sampler (openvdb._Grid.sample, nanovdb)
        u = [(voxel_centres(grid, a, *((z0, z1) if a == 2 else (0, None))) - self.origin[a])
             / self.scale[a] for a in range(3)]
        k0, wk = index_axis(u[2], lo[2])
        j0, wj = index_axis(u[1], lo[1])
        i0, wi = index_axis(u[0], lo[0])
        return (dense, rows, k0, wk, j0, wj, i0, wi, np.empty(dense.shape[2], np.float32),
                np.float32(density_scale / grid.mm_per_unit), np.asarray(uniform, np.float32))
