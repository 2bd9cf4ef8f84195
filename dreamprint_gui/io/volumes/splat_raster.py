"""Tiled, compiled rasteriser of Gaussian splats into a slab of printer voxels.

Defines :func:`rasterise_splats` (density and density-weighted colour, the colour divide fused)
and the tile sizes ``TILE_X``, ``TILE_Y``, ``TILE_Z``.  The density model is the one derived in
:mod:`.splats` (kernel ``s exp(-q/2)``, q the squared Mahalanobis distance, cut at q <= 9).

How it stays fast:

* The slab is cut into fixed tiles of TILE_Z x TILE_Y x TILE_X voxels; each Gaussian is binned
  into the tiles its 3-sigma box overlaps, and a tile sums its Gaussians into a float64
  accumulator small enough to stay in cache, then writes colour / density once.
* Per voxel row (fixed y, z) the support ``q <= 9`` is one run of voxels in x (q is a convex
  quadratic in x). Where the Gaussian's box, clipped to the tile, is at most SCAN_X = 8 voxels
  wide in x (most Gaussians at printer resolution: x is the coarsest axis) the run is found by
  testing q voxel by voxel; in a wider box the interval is solved in closed form and its ends
  confirmed with the same q test. Both give the same run, so the same slices; for a row of a
  few voxels the scan is cheaper than a square root and the end corrections (with the slab
  buffers reused, the 1e6-Gaussian scene's sample stage in ``benchmarks/bench_convert.py``:
  89.5 -> 74.3 ns/voxel at 1e8 voxels, 40.8 -> 37.7 at 1e9). Rows (y) are limited by the
  (y, z) marginal ellipse, solved in closed form.
* Along a row ``q(x_{i+1}) - q(x_i)`` is linear in i, so ``exp(-q/2)`` follows the recurrence
  ``w <- w r``, ``r <- r exp(-a h^2)`` (a = inverse-covariance xx term, h = voxel pitch); it is
  re-evaluated exactly at the first voxel of every row segment.  A segment never crosses a
  tile, so it has at most TILE_X = 128 steps: relative drift below n^2 eps ~ 2e-12, far below
  the float32 output's 6e-8.  Wide, flat tiles (128 x 8 x 8, a 256 KiB accumulator) keep most
  rows in one segment, so the per-row set-up (support interval, two exps) is paid about once.

Determinism: a voxel's value depends only on its position, the Gaussians whose support holds
it, summed in ascending Gaussian index, and the fixed x tiling (where the recurrence restarts);
x/y tiles are anchored at voxel 0 of the grid and rows never split across z, so results are
bit-identical whatever the slab boundaries or the thread that samples a slab.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from dreamprint_gui.io.volumes.base import SlabBuffers

__all__ = ["rasterise_splats", "TILE_X", "TILE_Y", "TILE_Z"]

TILE_X = 128
TILE_Y = 8
TILE_Z = 8
SCAN_X = 8  # boxes at most this many voxels wide in x: the row's run found by scanning


@njit(cache=True, nogil=True)
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


@njit(cache=True, nogil=True)
def _q(xi, mx, a, lin, qyz):
    dx = xi - mx
    return a * dx * dx + lin * dx + qyz


@njit(cache=True, nogil=True)
def _splat_kernel(idx, mean, inv_cov, peak, rgb, half, xs, ys, zs, scale, rgb_out, sigma_out):
    nz = zs.shape[0]
    ny = ys.shape[0]
    nx = xs.shape[0]
    n = idx.shape[0]
    box = np.empty((n, 6), np.int64)
    ntx = (nx + TILE_X - 1) // TILE_X
    nty = (ny + TILE_Y - 1) // TILE_Y
    ntz = (nz + TILE_Z - 1) // TILE_Z
    n_tiles = ntx * nty * ntz
    start = np.zeros(n_tiles + 1, np.int64)
    for t in range(n):
        g = idx[t]
        box[t, 0] = np.searchsorted(xs, mean[g, 0] - half[g, 0])
        box[t, 1] = min(np.searchsorted(xs, mean[g, 0] + half[g, 0], side="right"), nx)
        box[t, 2] = np.searchsorted(ys, mean[g, 1] - half[g, 1])
        box[t, 3] = min(np.searchsorted(ys, mean[g, 1] + half[g, 1], side="right"), ny)
        box[t, 4] = np.searchsorted(zs, mean[g, 2] - half[g, 2])
        box[t, 5] = min(np.searchsorted(zs, mean[g, 2] + half[g, 2], side="right"), nz)
        if box[t, 0] >= box[t, 1] or box[t, 2] >= box[t, 3] or box[t, 4] >= box[t, 5]:
            box[t, 0] = box[t, 1]               # marks an empty box
            continue
        for tz in range(box[t, 4] // TILE_Z, (box[t, 5] - 1) // TILE_Z + 1):
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
        for tz in range(box[t, 4] // TILE_Z, (box[t, 5] - 1) // TILE_Z + 1):
            for ty in range(box[t, 2] // TILE_Y, (box[t, 3] - 1) // TILE_Y + 1):
                for tx in range(box[t, 0] // TILE_X, (box[t, 1] - 1) // TILE_X + 1):
                    tile = (tz * nty + ty) * ntx + tx
                    members[fill[tile]] = t
                    fill[tile] += 1

    h = (xs[nx - 1] - xs[0]) / (nx - 1) if nx > 1 else 1.0
    inv_h = 1.0 / h
    inv_hy = (ny - 1) / (ys[ny - 1] - ys[0]) if ny > 1 else 1.0
    acc = np.zeros((TILE_Z, TILE_Y, TILE_X, 4), np.float64)
    for tz in range(ntz):
        z0 = tz * TILE_Z
        z1 = min(z0 + TILE_Z, nz)
        for ty in range(nty):
            y0 = ty * TILE_Y
            y1 = min(y0 + TILE_Y, ny)
            for tx in range(ntx):
                tile = (tz * nty + ty) * ntx + tx
                if start[tile] == start[tile + 1]:
                    continue                     # outside every support: stays 0
                x0 = tx * TILE_X
                x1 = min(x0 + TILE_X, nx)
                acc[:] = 0.0
                for m in range(start[tile], start[tile + 1]):
                    t = members[m]
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
                    cr = rgb[g, 0]
                    cg = rgb[g, 1]
                    cb = rgb[g, 2]
                    step = math.exp(-a * h * h)
                    inv_2a = 0.5 / a
                    s_yy = b - d * d / a
                    sy_z = f - d * e / a
                    s_zz = c - e * e / a
                    bx0 = max(box[t, 0], x0)
                    bx1 = min(box[t, 1], x1)
                    by0 = max(box[t, 2], y0)
                    by1 = min(box[t, 3], y1)
                    for k in range(max(box[t, 4], z0), min(box[t, 5], z1)):
                        dz = zs[k] - mz
                        # rows (y) whose minimum of q over x is <= 9: the (y, z) marginal
                        # ellipse, Schur complement S of the inverse covariance; one spare row
                        # each side absorbs rounding (those rows are tested exactly below)
                        syz = sy_z * dz
                        disc_y = syz * syz - s_yy * (s_zz * dz * dz - 9.0)
                        if s_yy > 0.0 and disc_y >= 0.0:
                            hwy = math.sqrt(disc_y) / s_yy
                            cy = my - syz / s_yy
                            ja, jb = _span(cy - hwy, cy + hwy, ys[0], inv_hy, 1, by0, by1)
                        elif s_yy > 0.0 and disc_y < 0.0:
                            ja, jb = _span(my - syz / s_yy, my - syz / s_yy, ys[0], inv_hy, 1,
                                           by0, by1)
                        else:
                            ja, jb = by0, by1
                        for j in range(ja, jb):
                            dy = ys[j] - my
                            qyz = b * dy * dy + 2.0 * f * dy * dz + c * dz * dz
                            lin = 2.0 * (d * dy + e * dz)
                            # the run of voxels where q <= 9 (q is convex in x: one run)
                            if bx1 - bx0 <= SCAN_X:
                                # a narrow box: test q voxel by voxel along the row
                                lo = bx0
                                while lo < bx1 and _q(xs[lo], mx, a, lin, qyz) > 9.0:
                                    lo += 1
                                hi = lo
                                while hi < bx1 and _q(xs[hi], mx, a, lin, qyz) <= 9.0:
                                    hi += 1
                            else:
                                # the interval solved in closed form, its ends then checked
                                # with q itself (rounding)
                                centre = mx - lin * inv_2a
                                disc = lin * lin - 4.0 * a * (qyz - 9.0)
                                hw = math.sqrt(disc) * inv_2a if disc > 0.0 else 0.0
                                lo, hi = _span(centre - hw, centre + hw, xs[0], inv_h, 0, bx0,
                                               bx1)
                                while lo < hi and _q(xs[lo], mx, a, lin, qyz) > 9.0:
                                    lo += 1
                                while hi > lo and _q(xs[hi - 1], mx, a, lin, qyz) > 9.0:
                                    hi -= 1
                                while lo > bx0 and _q(xs[lo - 1], mx, a, lin, qyz) <= 9.0:
                                    lo -= 1
                                while hi < bx1 and _q(xs[hi], mx, a, lin, qyz) <= 9.0:
                                    hi += 1
                            if lo >= hi:
                                continue
                            q0 = _q(xs[lo], mx, a, lin, qyz)
                            w = s * math.exp(-0.5 * q0)
                            r = 1.0
                            if hi - lo > 1:
                                r = math.exp(-0.5 * (_q(xs[lo + 1], mx, a, lin, qyz) - q0))
                            row = acc[k - z0, j - y0]
                            for i in range(lo - x0, hi - x0):
                                row[i, 0] += w
                                row[i, 1] += w * cr
                                row[i, 2] += w * cg
                                row[i, 3] += w * cb
                                w *= r
                                r *= step
                for k in range(z0, z1):
                    for j in range(y0, y1):
                        row = acc[k - z0, j - y0]
                        for i in range(x0, x1):
                            dd = row[i - x0, 0]
                            if dd > 0.0:
                                sigma_out[k, j, i] = np.float32(dd * scale)
                                inv = 1.0 / dd
                                for ch in range(3):
                                    v = row[i - x0, ch + 1] * inv
                                    rgb_out[k, j, i, ch] = np.float32(min(max(v, 0.0), 1.0))


def rasterise_splats(idx: np.ndarray, mean: np.ndarray, inv_cov: np.ndarray, peak: np.ndarray,
                     rgb: np.ndarray, half: np.ndarray, xs: np.ndarray, ys: np.ndarray,
                     zs: np.ndarray, scale: float, out: SlabBuffers | None = None
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Colour and density of the Gaussians ``idx`` (ascending) at voxel centres ``xs, ys, zs``.

    ``xs``, ``ys``, ``zs``: ascending, evenly spaced voxel centres (source units) of the whole
    grid in x and y and of the slab in z.  ``inv_cov`` rows are (xx, yy, zz, xy, xz, yz) of the
    inverse covariance, ``peak`` the centre density, ``half`` the 3-sigma half-extent per axis.
    Returns (colour (nz, ny, nx, 3) = density-weighted mean of ``rgb`` clipped to [0, 1], 0 where
    no Gaussian reaches; density * ``scale`` (nz, ny, nx)), both float32. ``out``: a worker's
    :class:`.base.SlabBuffers` to write into instead of new arrays (a fresh slab's page faults
    cost as much as a tenth of the rasteriser); with ``out.colour_where_dense`` the colour
    where no Gaussian reaches is left as it was.
    """
    shape = (len(zs), len(ys), len(xs))
    if out is None:
        rgb_out = np.zeros(shape + (3,), np.float32)
        sigma_out = np.zeros(shape, np.float32)
    else:
        rgb_out, sigma_out = out.take(shape)
        sigma_out.fill(0.0)
        if not out.colour_where_dense:
            rgb_out.fill(0.0)
    if len(idx) and all(shape):
        _splat_kernel(np.ascontiguousarray(idx, np.int64), mean, inv_cov, peak, rgb, half,
                      np.ascontiguousarray(xs, np.float64), np.ascontiguousarray(ys, np.float64),
                      np.ascontiguousarray(zs, np.float64), float(scale), rgb_out, sigma_out)
    return rgb_out, sigma_out
