"""Compiled samplers that fill a slab of printer voxels from a source's own storage.

Defines :func:`axis_map` (per-axis trilinear indices/weights), :func:`sample_dense`
(trilinear on a regular grid), :func:`sample_dense_density` (the same, straight to density and
un-premultiplied colour), :class:`SparseBlocks` / :func:`sample_sparse` (trilinear on
8^3 leaf blocks, the OpenVDB layout, with a two-level lookup table) and
:func:`rasterise_gaussians` (density-weighted Gaussian kernels with 3-sigma support).

Trilinear interpolation is separable for an axis-aligned grid, so each axis is mapped once per
slab (numpy, O(n)) and only the 3D loop is compiled.  The dense kernel also evaluates it
separably, x first: each source row the slab needs is interpolated at the output columns once
per slab (the two rows bracketing the current output row are kept, for every source layer of
the slab, while consecutive output rows share them); each output row is then one contiguous
pass of z and y lerps over its columns (vectorised), and rows whose source rows hold no density
are skipped.  Interpolating source rows first (z, then y, then x per voxel) did the same
arithmetic per voxel but whole source rows per output row: 1.5-2x slower when the print grid is
not much finer than the source.  Kernels are ``nogil`` so Dask threads sample different slabs
concurrently; they allocate only their output and row-sized buffers.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ...errors import DreamPrintError

__all__ = ["axis_map", "sample_dense", "sample_dense_density", "rows_with_data", "SparseBlocks",
           "sample_sparse", "rasterise_gaussians"]


def axis_map(u: np.ndarray, n: int, pad: float):
    """Trilinear lookup along one axis at continuous sample indices ``u``.

    Samples sit at integer indices 0..n-1.  Positions within ``[-pad, n-1+pad]`` are valid
    (clamped to the end samples beyond them: pad=.5 for cell-centred voxels, whose bounds reach
    half a voxel past the outer samples; 0 for point samples); others give 0.
    Returns ``(i0, i1, w, valid)`` with value = (1-w) * v[i0] + w * v[i1].
    """
    valid = (u >= -pad - 1e-9) & (u <= n - 1 + pad + 1e-9)
    uc = np.clip(u, 0.0, max(n - 1, 0))
    i0 = np.minimum(np.floor(uc).astype(np.int64), max(n - 2, 0))
    w = (uc - i0).astype(np.float32)
    i1 = np.minimum(i0 + 1, n - 1)
    if n == 1:
        w[:] = 0.0
    return i0, i1, w, valid


@njit(cache=True, nogil=True)
def rows_with_data(vol):
    """(nz, ny) bool: whether row (z, y) of a (nz, ny, nx, C) grid holds any value but +0.0
    (NaN and -0.0 count as values: skipping changes no bit). The sampler skips the others:
    clouds leave most rows empty (the demo: 52 %)."""
    nz, ny, nx, nc = vol.shape
    out = np.zeros((nz, ny), np.bool_)
    for z in range(nz):
        for y in range(ny):
            row = vol[z, y]
            for x in range(nx):
                hit = False
                for c in range(nc):
                    v = row[x, c]
                    hit |= (v != 0) | (math.copysign(1.0, v) < 0.0)
                if hit:
                    out[z, y] = True
                    break
    return out


@njit(cache=True, nogil=True, error_model="numpy")
def _x_rows(vol, rows_nz, layers, b, ix0, ix1, wx, vx, xr, nz):
    """Source row ``b`` of source layers ``layers`` interpolated in x at the output columns into
    ``xr[s]`` for ``layers[s]`` (nxo * C, 0 at invalid columns); ``nz[s]``: any value non-zero.
    A row without data (``rows_nz``, :func:`rows_with_data`) is zeros without interpolating."""
    nc = vol.shape[3]
    zero = np.float32(0.0)
    one = np.float32(1.0)
    for s in range(layers.shape[0]):
        x = xr[s]
        if not rows_nz[layers[s], b]:
            x[:] = zero
            nz[s] = False
            continue
        v = vol[layers[s], b]
        hit = 0
        for i in range(ix0.shape[0]):
            fx = wx[i]
            gx = one - fx
            for c in range(nc):
                t = v[ix0[i], c] * gx + v[ix1[i], c] * fx
                t = t if vx[i] else zero
                x[i * nc + c] = t
                hit |= t != zero
        nz[s] = hit != 0


@njit(cache=True, nogil=True)
def _zero_row(sigma, rgb, k, j, mode):
    sigma[k, j, :] = 0.0
    if mode == 2:  # mode 3 leaves the colour of rows without density as it was
        rgb[k, j, :, :] = 0.0


@njit(cache=True, nogil=True)
def _zero_layer(sigma, rgb, k, mode):
    for j in range(sigma.shape[1]):
        _zero_row(sigma, rgb, k, j, mode)


@njit(cache=True, nogil=True, error_model="numpy")
def _dense_rows(vol, rows_nz, iz0, iz1, wz, vz, iy0, iy1, wy, vy, ix0, ix1, wx, vx, out, rgb,
                sigma, mode, scale):
    """Trilinear samples of a slab: mode 0 all channels into ``out``; mode 1 density into
    ``sigma``; mode 2 also colour (channels 1-3 / channel 0) into ``rgb``; mode 3 as 2 but
    without zeroing the colour of rows (and layers) that hold no density. Modes 1 and 2 write
    every element, mode 3 every density and the colour of every row with density."""
    nc = vol.shape[3]
    nzo = iz0.shape[0]
    nxo = ix0.shape[0]
    w = nxo * nc
    zero = np.float32(0.0)
    one = np.float32(1.0)
    a_lo = vol.shape[0]
    a_hi = -1
    for k in range(nzo):
        if vz[k]:
            a_lo = min(a_lo, iz0[k])
            a_hi = max(a_hi, iz1[k])
    if mode != 0:
        for k in range(nzo):
            if not vz[k]:
                _zero_layer(sigma, rgb, k, mode)
    if a_hi < 0:
        return
    # x first: the source rows a slab uses, interpolated at the output columns once per slab
    # (two source rows, for every source layer the slab's layers read, are all that is kept),
    # then per output row the z and y interpolation is one contiguous pass over its columns.
    slot = np.full(a_hi - a_lo + 1, -1, np.int64)
    for k in range(nzo):
        if vz[k]:
            slot[iz0[k] - a_lo] = 0
            slot[iz1[k] - a_lo] = 0
    na = 0
    for a in range(slot.shape[0]):  # only the layers read: a source finer in z skips the rest
        if slot[a] == 0:
            slot[a] = na
            na += 1
    layers = np.empty(na, np.int64)
    for a in range(slot.shape[0]):
        if slot[a] >= 0:
            layers[slot[a]] = a_lo + a
    xr0 = np.empty((na, w), np.float32)
    xr1 = np.empty((na, w), np.float32)
    nz0 = np.zeros(na, np.bool_)
    nz1 = np.zeros(na, np.bool_)
    row = np.empty(w, np.float32)
    cb0 = -1
    cb1 = -1
    for j in range(iy0.shape[0]):
        if not vy[j]:
            if mode != 0:
                for k in range(nzo):
                    _zero_row(sigma, rgb, k, j, mode)
            continue
        b0 = iy0[j]
        b1 = iy1[j]
        if b0 != cb0:  # consecutive output rows share source rows
            if b0 == cb1:
                xr0, xr1 = xr1, xr0
                nz0, nz1 = nz1, nz0
                cb1 = -1
            else:
                _x_rows(vol, rows_nz, layers, b0, ix0, ix1, wx, vx, xr0, nz0)
            cb0 = b0
        if b1 != cb1:
            _x_rows(vol, rows_nz, layers, b1, ix0, ix1, wx, vx, xr1, nz1)
            cb1 = b1
        fy = wy[j]
        gy = one - fy
        for k in range(nzo):
            if not vz[k]:
                continue
            p = slot[iz0[k] - a_lo]
            q = slot[iz1[k] - a_lo]
            if mode != 0 and not (nz0[p] or nz0[q] or nz1[p] or nz1[q]):
                _zero_row(sigma, rgb, k, j, mode)  # no density anywhere along this row
                continue
            fz = wz[k]
            gz = one - fz
            r00 = xr0[p]
            r01 = xr0[q]
            r10 = xr1[p]
            r11 = xr1[q]
            for t in range(w):
                row[t] = (r00[t] * gz + r01[t] * fz) * gy + (r10[t] * gz + r11[t] * fz) * fy
            if mode == 0:
                for i in range(nxo):
                    for c in range(nc):
                        out[k, j, i, c] = row[i * nc + c]
                continue
            srow = sigma[k, j]
            for i in range(nxo):
                srow[i] = max(row[i * nc] * scale, zero)
            if mode >= 2:
                crow = rgb[k, j]
                for i in range(nxo):
                    d = row[i * nc]
                    ok = d > zero
                    for c in range(3):
                        v = row[i * nc + c + 1] / d
                        crow[i, c] = min(max(v, zero), one) if ok else zero


def _dense_maps(vol, uz, uy, ux, pad):
    nz, ny, nx, _ = vol.shape
    return (*axis_map(uz, nz, pad), *axis_map(uy, ny, pad), *axis_map(ux, nx, pad))


def sample_dense(vol: np.ndarray, uz: np.ndarray, uy: np.ndarray, ux: np.ndarray,
                 pad: float, rows_nz: np.ndarray | None = None) -> np.ndarray:
    """Trilinear samples of ``vol`` (nz, ny, nx, C) at continuous indices on a separable grid.

    Returns float32 (len(uz), len(uy), len(ux), C); 0 outside the valid range (see axis_map).
    ``rows_nz``: :func:`rows_with_data` of ``vol`` if the caller keeps it (else computed).
    """
    out = np.zeros((len(uz), len(uy), len(ux), vol.shape[3]), np.float32)
    rows = rows_with_data(vol) if rows_nz is None else rows_nz
    _dense_rows(vol, rows, *_dense_maps(vol, uz, uy, ux, pad), out, _NO_RGB, _NO_SIGMA, 0,
                np.float32(1.0))
    return out


def sample_dense_density(vol: np.ndarray, uz: np.ndarray, uy: np.ndarray, ux: np.ndarray,
                         pad: float, scale: float, out=None, rows_nz: np.ndarray | None = None
                         ) -> tuple[np.ndarray | None, np.ndarray]:
    """Density and colour of a (nz, ny, nx, 1 or 4) grid whose channel 0 is density and
    channels 1-3 (if it has 4) colour premultiplied by density, in one compiled pass.

    Returns (colour (Z, Y, X, 3) = interpolated premultiplied colour / density clipped to [0, 1],
    0 where the density is not positive; None unless the grid has 4 channels) and ``max(density *
    scale, 0)`` (Z, Y, X), both float32. ``out``: a :class:`.base.SlabBuffers` to write into
    (every element is written, except colour where ``out.colour_where_dense`` allows it:
    see :class:`.base.SlabBuffers`) instead of new arrays. ``rows_nz``: as for
    :func:`sample_dense`.
    """
    shape = (len(uz), len(uy), len(ux))
    if out is not None:
        rgb_buf, sigma = out.take(shape)
    else:
        rgb_buf, sigma = None, np.empty(shape, np.float32)
    if vol.shape[3] == 4:
        rgb = rgb_buf if rgb_buf is not None else np.empty(shape + (3,), np.float32)
        mode = 3 if out is not None and out.colour_where_dense else 2
    else:
        rgb = None
        mode = 1
    rows = rows_with_data(vol) if rows_nz is None else rows_nz
    _dense_rows(vol, rows, *_dense_maps(vol, uz, uy, ux, pad), _NO_OUT,
                _NO_RGB if rgb is None else rgb, sigma, mode, np.float32(scale))
    return rgb, sigma


_NO_OUT = np.zeros((1, 1, 1, 1), np.float32)
_NO_RGB = np.zeros((1, 1, 1, 3), np.float32)
_NO_SIGMA = np.zeros((1, 1, 1), np.float32)


# ---------------------------------------------------------------------------- sparse leaf blocks

NODE_LOG2 = 4          # 16^3 leaves (128^3 voxels) per lookup node, as an OpenVDB lower node
MAX_TOP_ENTRIES = 1 << 26


class SparseBlocks:
    """8^3 value blocks at leaf origins (index space) with O(1) lookup.

    ``origins`` (L, 3) int (i, j, k) multiples of 8; ``values`` (L, 8, 8, 8, C) float32 indexed
    [leaf, i%8, j%8, k%8, channel] (may be a read-only memory map); ``background`` is the value
    of voxels in no block.  Lookup: a dense top table over 128^3-voxel nodes (bounded by
    MAX_TOP_ENTRIES) -> per-node 16^3 table of leaf numbers.
    """

    def __init__(self, origins: np.ndarray, values: np.ndarray, background, name: str = ""):
        origins = np.asarray(origins, np.int64).reshape(-1, 3)
        self.values = values
        self.nc = values.shape[-1]
        self.background = np.broadcast_to(np.asarray(background, np.float32), (self.nc,)).copy()
        self.n_leaves = len(origins)
        if self.n_leaves == 0:
            self.node_min = np.zeros(3, np.int64)
            self.top = -np.ones((1, 1, 1), np.int32)
            self.nodes = -np.ones((1, 16, 16, 16), np.int32)
            return
        if np.any(origins % 8):
            raise DreamPrintError(f"grid {name!r}: leaf origins are not multiples of 8")
        leaf = origins >> 3
        node = leaf >> NODE_LOG2
        self.node_min = node.min(axis=0)
        dims = node.max(axis=0) - self.node_min + 1
        if math.prod(int(d) for d in dims) > MAX_TOP_ENTRIES:
            raise DreamPrintError(f"grid {name!r}: active voxels spread over {dims * 128} voxels; "
                                  "too sparse to sample")
        rel = node - self.node_min
        key = (rel[:, 0] * dims[1] + rel[:, 1]) * dims[2] + rel[:, 2]
        uniq, inv = np.unique(key, return_inverse=True)
        self.top = -np.ones(tuple(int(d) for d in dims), np.int32)
        self.top.reshape(-1)[uniq] = np.arange(len(uniq), dtype=np.int32)
        self.nodes = -np.ones((len(uniq), 16, 16, 16), np.int32)
        lr = leaf & 15
        self.nodes[inv, lr[:, 0], lr[:, 1], lr[:, 2]] = np.arange(self.n_leaves, dtype=np.int32)


@njit(cache=True, nogil=True)
def _leaf_of(i, j, k, node_min, top, nodes):
    li = i >> 3
    lj = j >> 3
    lk = k >> 3
    ni = (li >> 4) - node_min[0]
    nj = (lj >> 4) - node_min[1]
    nk = (lk >> 4) - node_min[2]
    if ni < 0 or nj < 0 or nk < 0 or ni >= top.shape[0] or nj >= top.shape[1] \
            or nk >= top.shape[2]:
        return -1
    n = top[ni, nj, nk]
    if n < 0:
        return -1
    return nodes[n, li & 15, lj & 15, lk & 15]


@njit(cache=True, nogil=True)
def _voxel(values, bg, leaf, i, j, k, c):
    if leaf < 0:
        return bg[c]
    return values[leaf, i & 7, j & 7, k & 7, c]


@njit(cache=True, nogil=True)
def _corner_planes(values, bg, node_min, top, nodes, i0, j0, k0, wj, wk, va, vb):
    """Bilinear (y, z) values at index planes i0 and i0+1 into ``va``, ``vb``."""
    nc = values.shape[4]
    if (i0 & 7) != 7 and (j0 & 7) != 7 and (k0 & 7) != 7:
        lf = _leaf_of(i0, j0, k0, node_min, top, nodes)       # all corners in one leaf
        if lf < 0:
            for c in range(nc):
                va[c] = bg[c]
                vb[c] = bg[c]
            return
        a = i0 & 7
        b = j0 & 7
        d = k0 & 7
        for c in range(nc):
            y0 = values[lf, a, b, d, c] * (1 - wj) + values[lf, a, b + 1, d, c] * wj
            y1 = values[lf, a, b, d + 1, c] * (1 - wj) + values[lf, a, b + 1, d + 1, c] * wj
            va[c] = y0 * (1 - wk) + y1 * wk
            y0 = values[lf, a + 1, b, d, c] * (1 - wj) + values[lf, a + 1, b + 1, d, c] * wj
            y1 = (values[lf, a + 1, b, d + 1, c] * (1 - wj)
                  + values[lf, a + 1, b + 1, d + 1, c] * wj)
            vb[c] = y0 * (1 - wk) + y1 * wk
        return
    for s in range(2):
        i = i0 + s
        l00 = _leaf_of(i, j0, k0, node_min, top, nodes)
        l10 = _leaf_of(i, j0 + 1, k0, node_min, top, nodes)
        l01 = _leaf_of(i, j0, k0 + 1, node_min, top, nodes)
        l11 = _leaf_of(i, j0 + 1, k0 + 1, node_min, top, nodes)
        for c in range(nc):
            y0 = (_voxel(values, bg, l00, i, j0, k0, c) * (1 - wj)
                  + _voxel(values, bg, l10, i, j0 + 1, k0, c) * wj)
            y1 = (_voxel(values, bg, l01, i, j0, k0 + 1, c) * (1 - wj)
                  + _voxel(values, bg, l11, i, j0 + 1, k0 + 1, c) * wj)
            v = y0 * (1 - wk) + y1 * wk
            if s == 0:
                va[c] = v
            else:
                vb[c] = v


@njit(cache=True, nogil=True)
def _sparse_kernel(values, bg, node_min, top, nodes, uz, uy, ux, out):
    nc = values.shape[4]
    va = np.empty(nc, np.float32)
    vb = np.empty(nc, np.float32)
    for kk in range(uz.shape[0]):
        fk = np.floor(uz[kk])
        k0 = np.int64(fk)
        wk = np.float32(uz[kk] - fk)
        for jj in range(uy.shape[0]):
            fj = np.floor(uy[jj])
            j0 = np.int64(fj)
            wj = np.float32(uy[jj] - fj)
            last = np.int64(-(1 << 62))
            for ii in range(ux.shape[0]):
                fi = np.floor(ux[ii])
                i0 = np.int64(fi)
                wi = np.float32(ux[ii] - fi)
                if i0 != last:
                    # printer voxels are finer than source voxels: the (y, z) interpolation at
                    # the two bracketing index planes is shared by a run of x samples
                    _corner_planes(values, bg, node_min, top, nodes, i0, j0, k0, wj, wk, va, vb)
                    last = i0
                for c in range(nc):
                    out[kk, jj, ii, c] = va[c] + (vb[c] - va[c]) * wi


def sample_sparse(blocks: SparseBlocks, uk: np.ndarray, uj: np.ndarray,
                  ui: np.ndarray) -> np.ndarray:
    """Trilinear samples (OpenVDB BoxSampler: voxel values at integer index coordinates) at the
    separable continuous index coordinates ``uk`` (z/k), ``uj`` (y/j), ``ui`` (x/i).

    Returns float32 (len(uk), len(uj), len(ui), C); voxels in no block read as background.
    """
    out = np.empty((len(uk), len(uj), len(ui), blocks.nc), np.float32)
    if blocks.n_leaves == 0:
        out[...] = blocks.background
        return out
    _sparse_kernel(blocks.values, blocks.background, blocks.node_min, blocks.top, blocks.nodes,
                   np.ascontiguousarray(uk, np.float64), np.ascontiguousarray(uj, np.float64),
                   np.ascontiguousarray(ui, np.float64), out)
    return out


# ------------------------------------------------------------------------------ Gaussian kernels

@njit(cache=True, nogil=True)
def _gauss_kernel(idx, mean, inv_cov, peak, rgb, half, xs, ys, zs, dens, col):
    nz = zs.shape[0]
    ny = ys.shape[0]
    nx = xs.shape[0]
    for t in range(idx.shape[0]):
        g = idx[t]
        mx = mean[g, 0]
        my = mean[g, 1]
        mz = mean[g, 2]
        a = inv_cov[g, 0]
        b = inv_cov[g, 1]
        c = inv_cov[g, 2]
        d = inv_cov[g, 3]
        e = inv_cov[g, 4]
        f = inv_cov[g, 5]
        s = peak[g]
        r = rgb[g, 0]
        gg = rgb[g, 1]
        bb = rgb[g, 2]
        # index ranges of voxel centres inside the 3-sigma box (centres are sorted ascending)
        k0 = np.searchsorted(zs, mz - half[g, 2])
        k1 = np.searchsorted(zs, mz + half[g, 2], side="right")
        j0 = np.searchsorted(ys, my - half[g, 1])
        j1 = np.searchsorted(ys, my + half[g, 1], side="right")
        i0 = np.searchsorted(xs, mx - half[g, 0])
        i1 = np.searchsorted(xs, mx + half[g, 0], side="right")
        for k in range(k0, min(k1, nz)):
            dz = zs[k] - mz
            for j in range(j0, min(j1, ny)):
                dy = ys[j] - my
                qyz = b * dy * dy + 2.0 * f * dy * dz + c * dz * dz
                lin = 2.0 * (d * dy + e * dz)
                for i in range(i0, min(i1, nx)):
                    dx = xs[i] - mx
                    q = a * dx * dx + lin * dx + qyz
                    if q > 9.0:
                        continue
                    w = s * np.exp(-0.5 * q)
                    dens[k, j, i] += w
                    col[k, j, i, 0] += w * r
                    col[k, j, i, 1] += w * gg
                    col[k, j, i, 2] += w * bb


def rasterise_gaussians(idx: np.ndarray, mean: np.ndarray, inv_cov: np.ndarray, peak: np.ndarray,
                        rgb: np.ndarray, half: np.ndarray, xs: np.ndarray, ys: np.ndarray,
                        zs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sum Gaussians ``idx`` at voxel centres ``xs, ys, zs`` (ascending, source units).

    ``inv_cov`` rows are (xx, yy, zz, xy, xz, yz) of the inverse covariance; ``peak`` is the
    centre density; ``half`` the 3-sigma half-extent per axis; the kernel is cut at Mahalanobis
    distance 3.  Returns (density (nz, ny, nx), density-weighted colour (nz, ny, nx, 3)); divide
    the colour by the density.
    """
    dens = np.zeros((len(zs), len(ys), len(xs)), np.float32)
    col = np.zeros((len(zs), len(ys), len(xs), 3), np.float32)
    if len(idx):
        _gauss_kernel(np.ascontiguousarray(idx, np.int64), mean, inv_cov, peak, rgb, half,
                      np.ascontiguousarray(xs, np.float64), np.ascontiguousarray(ys, np.float64),
                      np.ascontiguousarray(zs, np.float64), dens, col)
    return dens, col
