"""Compiled samplers that fill a slab of printer voxels from a source's own storage.

Defines :class:`SparseBlocks` / :func:`sample_sparse` (trilinear on 8^3 leaf blocks, the
OpenVDB layout, with a two-level lookup table) and :func:`rasterise_gaussians`
(density-weighted Gaussian kernels with 3-sigma support); re-exports the dense grid's sampler
(:mod:`.dense_sampler`: :func:`axis_map`, :func:`sample_dense`, :func:`sample_dense_density`,
:func:`rows_with_data`). Kernels are ``nogil`` so Dask threads sample different slabs
concurrently.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes.dense_sampler import (
    axis_map,
    rows_with_data,
    sample_dense,
    sample_dense_density,
)

__all__ = ["axis_map", "sample_dense", "sample_dense_density", "rows_with_data", "SparseBlocks",
           "sample_sparse", "rasterise_gaussians"]


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
        self.origins = origins
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
