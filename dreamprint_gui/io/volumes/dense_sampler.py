"""Trilinear sampling of a dense grid (nz, ny, nx, C) on the printer grid, one output layer at a
time.

Defines :func:`axis_map` (per-axis trilinear indices/weights), :func:`rows_with_data`,
:class:`DenseLayers` (the per-slab plan and working arrays) with :func:`dense_layer` (one output
layer, compiled, for callers that consume a layer at a time: the print job's fused path,
:mod:`...job.sample_label.dense_job`), and :func:`sample_dense` / :func:`sample_dense_density`
(whole slabs).

Trilinear interpolation is separable for an axis-aligned grid, so each axis is mapped once per
slab (numpy, O(n)) and evaluated x first: every source row an output layer needs is interpolated
at the output columns once per slab, as a *plane* per source layer (the two planes bracketing
the current output layer are kept, and consecutive output layers share them); each output row
is then one contiguous pass of z and y lerps over its columns (vectorised). Rows are stored
channel-major (density, then each premultiplied colour channel), so that the density and the
colour division (:func:`_colour_row`) also run as vector instructions. Source rows that hold no
value, and output rows whose four source rows hold none, are skipped. Interpolating source rows
first (z, then y, then x per voxel) did the same arithmetic per voxel but whole source rows per
output row: 1.5-2x slower when the print grid is not much finer than the source.

Every output value is ``((r00 gz + r01 fz) gy + (r10 gz + r11 fz) fy)`` of the x-interpolated
rows ``r = v[i0] gx + v[i1] fx``, in that order, whatever the traversal, so a voxel's value does
not depend on the slab it is sampled in.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["axis_map", "rows_with_data", "DenseLayers", "dense_layer", "dense_window_layer",
           "sample_dense", "sample_dense_density"]

# Modes of dense_layer: 0 all channels into ``out`` (C per voxel); 1 density into ``sigma``;
# 2 also colour (channels 1-3 / channel 0) into ``rgb``; 3 as 2 but the colour of a row
# without density is left as it was (for a consumer that reads colour only where the density
# is positive, see base.SlabBuffers).
RAW, DENSITY, COLOUR, COLOUR_WHERE_DENSE = 0, 1, 2, 3


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
def _x_row(vol, rows_nz, a, b, ix0, ix1, wx, vx, x):
    """Source row ``b`` of source layer ``a`` interpolated in x at the output columns into ``x``
    (C * nxo, channel-major; 0 at invalid columns); returns whether any value is non-zero. A
    row without data (``rows_nz``) is zeros without interpolating."""
    nc = vol.shape[3]
    nxo = ix0.shape[0]
    zero = np.float32(0.0)
    one = np.float32(1.0)
    if not rows_nz[a, b]:
        x[:] = zero
        return False
    v = vol[a, b]
    hit = 0
    for i in range(nxo):
        fx = wx[i]
        gx = one - fx
        for c in range(nc):
            t = v[ix0[i], c] * gx + v[ix1[i], c] * fx
            t = t if vx[i] else zero
            x[c * nxo + i] = t
            hit |= t != zero
    return hit != 0


@njit(cache=True, nogil=True, error_model="numpy")
def _colour_row(row, nxo, crow, cpl):
    """Colour (nxo * 3, interleaved) of one interpolated row (channel-major: density, then the
    three premultiplied channels, ``nxo`` each): clip(channel / density, 0, 1), 0 where the
    density is not positive. One channel at a time into ``cpl`` (3 * nxo scratch), so that the
    divisions run as vector instructions (one voxel at a time with the channels interleaved,
    they did not: 178 -> 73 ns per row of 83 voxels)."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    for c in range(3):
        for i in range(nxo):
            d = row[i]
            v = row[(c + 1) * nxo + i] / d
            cpl[c * nxo + i] = min(max(v, zero), one) if d > zero else zero
    for i in range(nxo):
        crow[3 * i] = cpl[i]
        crow[3 * i + 1] = cpl[nxo + i]
        crow[3 * i + 2] = cpl[2 * nxo + i]


@njit(cache=True, nogil=True)
def _plan_rows(ny_src, iy0, iy1, vy):
    """(rslot, srows): the source rows the output rows read (``srows``, ascending) and each
    source row's index among them (``rslot``, -1 if unread)."""
    rslot = np.full(ny_src, -1, np.int64)
    for j in range(iy0.shape[0]):
        if vy[j]:
            rslot[iy0[j]] = 0
            rslot[iy1[j]] = 0
    nr = 0
    for b in range(ny_src):
        if rslot[b] == 0:
            rslot[b] = nr
            nr += 1
    srows = np.empty(nr, np.int64)
    for b in range(ny_src):
        if rslot[b] >= 0:
            srows[rslot[b]] = b
    return rslot, srows


class DenseLayers:
    """A slab's sampling plan: the axis maps (``maps``: iz0, iz1, wz, vz, iy0, iy1, wy, vy, ix0,
    ix1, wx, vx), the source rows read, and the working arrays of :func:`dense_layer` (two
    planes of x-interpolated source rows, a row and a colour scratch). ``args()`` is what
    :func:`dense_layer` takes after ``vol, rows_nz, k``."""

    def __init__(self, vol: np.ndarray, uz: np.ndarray, uy: np.ndarray, ux: np.ndarray,
                 pad: float):
        nz, ny, nx, nc = vol.shape
        self.maps = (*axis_map(uz, nz, pad), *axis_map(uy, ny, pad), *axis_map(ux, nx, pad))
        nxo = len(ux)
        self.rslot, self.srows = _plan_rows(ny, self.maps[4], self.maps[5], self.maps[7])
        self.planes = np.empty((2, len(self.srows), nc * nxo), np.float32)
        self.planes_nz = np.zeros((2, len(self.srows)), np.bool_)
        self.plane_layer = np.full(2, -1, np.int64)
        self.row = np.empty(nc * nxo, np.float32)
        self.cpl = np.empty(3 * nxo, np.float32)

    def args(self) -> tuple:
        return (*self.maps, self.rslot, self.srows, self.planes, self.planes_nz,
                self.plane_layer, self.row, self.cpl)


@njit(cache=True, nogil=True, error_model="numpy")
def _plane(vol, rows_nz, a, srows, ix0, ix1, wx, vx, planes, planes_nz, plane_layer, s):
    for r in range(srows.shape[0]):
        planes_nz[s, r] = _x_row(vol, rows_nz, a, srows[r], ix0, ix1, wx, vx, planes[s, r])
    plane_layer[s] = a


@njit(cache=True, nogil=True, error_model="numpy")
def _planes_for(vol, rows_nz, p, q, srows, ix0, ix1, wx, vx, planes, planes_nz, plane_layer):
    """Slots of the planes of source layers ``p`` and ``q`` (interpolated when not kept)."""
    sp = -1
    sq = -1
    for s in range(2):
        if plane_layer[s] == p:
            sp = s
        if plane_layer[s] == q:
            sq = s
    if sp < 0:
        sp = 1 if plane_layer[0] == q else 0  # never evict q's plane
        _plane(vol, rows_nz, p, srows, ix0, ix1, wx, vx, planes, planes_nz, plane_layer, sp)
        if q == p:
            sq = sp
    if sq < 0:
        sq = 1 - sp
        _plane(vol, rows_nz, q, srows, ix0, ix1, wx, vx, planes, planes_nz, plane_layer, sq)
    return sp, sq


@njit(cache=True, nogil=True, error_model="numpy")
def dense_layer(vol, rows_nz, k, iz0, iz1, wz, vz, iy0, iy1, wy, vy, ix0, ix1, wx, vx, rslot,
                srows, planes, planes_nz, plane_layer, row, cpl, out, rgb, sigma, mode, scale,
                j0=0, nrows=-1):
    """Output layer ``k`` of a slab (:class:`DenseLayers`) into flat arrays of that layer:
    ``out`` (ny * nx * C, mode 0), ``sigma`` (ny * nx: ``max(density * scale, 0)``) and ``rgb``
    (ny * nx * 3: colour / density clipped to [0, 1], 0 where the density is not positive);
    see the modes above. 0 outside the grid. With ``nrows >= 0``, the layer's rows ``j0 ..
    j0 + nrows - 1`` only, into arrays of those rows (a strip: the same values)."""
    nc = vol.shape[3]
    nyo = iy0.shape[0] if nrows < 0 else nrows
    nxo = ix0.shape[0]
    w = nxo * nc
    zero = np.float32(0.0)
    if not vz[k]:
        if mode == RAW:
            out[:nyo * w] = zero
        else:
            sigma[:nyo * nxo] = zero
            if mode == COLOUR:
                rgb[:nyo * nxo * 3] = zero
        return
    sp, sq = _planes_for(vol, rows_nz, iz0[k], iz1[k], srows, ix0, ix1, wx, vx, planes,
                         planes_nz, plane_layer)
    fz = wz[k]
    for jl in range(nyo):
        j = jl + j0
        b0 = rslot[iy0[j]]
        b1 = rslot[iy1[j]]
        empty = not vy[j] or (mode != RAW and not (planes_nz[sp, b0] or planes_nz[sq, b0]
                                                   or planes_nz[sp, b1] or planes_nz[sq, b1]))
        if empty:
            if mode == RAW:
                out[jl * w:(jl + 1) * w] = zero
            else:
                sigma[jl * nxo:(jl + 1) * nxo] = zero
                if mode == COLOUR:
                    rgb[jl * nxo * 3:(jl + 1) * nxo * 3] = zero
            continue
        _lerp_row(row, w, planes[sp, b0], planes[sq, b0], planes[sp, b1], planes[sq, b1],
                  fz, wy[j])
        if mode == RAW:
            for i in range(nxo):
                for c in range(nc):
                    out[jl * w + i * nc + c] = row[c * nxo + i]
            continue
        for i in range(nxo):
            sigma[jl * nxo + i] = max(row[i] * scale, zero)
        if mode >= COLOUR:
            _colour_row(row, nxo, rgb[jl * nxo * 3:(jl + 1) * nxo * 3], cpl)


@njit(cache=True, nogil=True, error_model="numpy")
def dense_window_layer(vol, rows_nz, k, iz0, iz1, wz, vz, iy0, iy1, wy, vy, ix0, ix1, wx, vx,
                       rslot, srows, planes, planes_nz, plane_layer, row, low, inv_width,
                       density, sigma, j0=0, nrows=-1):
    """Output layer ``k`` of a one-channel grid through a window: ``sigma`` (ny * nx) =
    ``clip((v - low) * inv_width, 0, 1) * density`` of the trilinear sample ``v``, in the row
    pass (a scalar image without a colour map: the paper's sec. 4.1 scalar field ->
    extinction). The bits of :func:`dense_layer` (mode ``RAW``) followed by
    :func:`.dense.window_kernel`'s density (the same expressions and types, 0 outside the
    grid), without
    the layer of samples in between (a 1e9-voxel job's layer is 2 MB, as large as L2). With
    ``nrows >= 0``, rows ``j0 .. j0 + nrows - 1`` only, into an array of those rows."""
    nyo = iy0.shape[0] if nrows < 0 else nrows
    nxo = ix0.shape[0]
    zero = np.float32(0.0)
    if not vz[k]:
        for jl in range(nyo):
            _window_row(row, nxo, zero, True, low, inv_width, density, sigma, jl * nxo)
        return
    sp, sq = _planes_for(vol, rows_nz, iz0[k], iz1[k], srows, ix0, ix1, wx, vx, planes,
                         planes_nz, plane_layer)
    fz = wz[k]
    for jl in range(nyo):
        j = j0 + jl
        if not vy[j]:
            _window_row(row, nxo, zero, True, low, inv_width, density, sigma, jl * nxo)
            continue
        b0 = rslot[iy0[j]]
        b1 = rslot[iy1[j]]
        _lerp_row(row, nxo, planes[sp, b0], planes[sq, b0], planes[sp, b1], planes[sq, b1],
                  fz, wy[j])
        _window_row(row, nxo, zero, False, low, inv_width, density, sigma, jl * nxo)


@njit(cache=True, nogil=True, inline="always")
def _lerp_row(row, n, r00, r01, r10, r11, fz, fy):
    """``row[:n]``: the trilinear sample of one output row from its four x-interpolated plane
    rows (z0/z1 x y0/y1), weights ``fz`` along z and ``fy`` along y (float32 throughout)."""
    gz = np.float32(1.0) - fz
    gy = np.float32(1.0) - fy
    for t in range(n):
        row[t] = (r00[t] * gz + r01[t] * fz) * gy + (r10[t] * gz + r11[t] * fz) * fy


@njit(cache=True, nogil=True, inline="always")
def _window_row(row, nxo, fill, filled, lo, inv_width, dens, sigma, base):
    """The window of one output row (``row``, or ``fill`` everywhere) into ``sigma``."""
    out = sigma[base:base + nxo]
    for q in range(nxo):
        v = fill if filled else row[q]
        t = (v - lo) * inv_width
        t = min(max(t, 0.0), 1.0)
        out[q] = t * dens


@njit(cache=True, nogil=True, error_model="numpy")
def _dense_slab(vol, rows_nz, iz0, iz1, wz, vz, iy0, iy1, wy, vy, ix0, ix1, wx, vx, rslot, srows,
                planes, planes_nz, plane_layer, row, cpl, out, rgb, sigma, mode, scale):
    """:func:`dense_layer` for every layer of a slab: ``out``, ``rgb``, ``sigma`` flat, layer
    after layer (an unused one may be a 1-element dummy)."""
    nc = vol.shape[3]
    nv = iy0.shape[0] * ix0.shape[0]
    for k in range(iz0.shape[0]):
        o = out[k * nv * nc:(k + 1) * nv * nc] if mode == RAW else out
        s = sigma if mode == RAW else sigma[k * nv:(k + 1) * nv]
        c = rgb[k * nv * 3:(k + 1) * nv * 3] if mode >= COLOUR else rgb
        dense_layer(vol, rows_nz, k, iz0, iz1, wz, vz, iy0, iy1, wy, vy, ix0, ix1, wx, vx, rslot,
                    srows, planes, planes_nz, plane_layer, row, cpl, o, c, s, mode, scale)


_DUMMY = np.zeros(1, np.float32)


def sample_dense(vol: np.ndarray, uz: np.ndarray, uy: np.ndarray, ux: np.ndarray,
                 pad: float, rows_nz: np.ndarray | None = None) -> np.ndarray:
    """Trilinear samples of ``vol`` (nz, ny, nx, C) at continuous indices on a separable grid.

    Returns float32 (len(uz), len(uy), len(ux), C); 0 outside the valid range (see axis_map).
    ``rows_nz``: :func:`rows_with_data` of ``vol`` if the caller keeps it (else computed).
    """
    out = np.empty((len(uz), len(uy), len(ux), vol.shape[3]), np.float32)
    rows = rows_with_data(vol) if rows_nz is None else rows_nz
    _dense_slab(vol, rows, *DenseLayers(vol, uz, uy, ux, pad).args(), out.reshape(-1), _DUMMY,
                _DUMMY, RAW, np.float32(1.0))
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
        mode = COLOUR_WHERE_DENSE if out is not None and out.colour_where_dense else COLOUR
    else:
        rgb = None
        mode = DENSITY
    rows = rows_with_data(vol) if rows_nz is None else rows_nz
    _dense_slab(vol, rows, *DenseLayers(vol, uz, uy, ux, pad).args(), _DUMMY,
                _DUMMY if rgb is None else rgb.reshape(-1), sigma.reshape(-1), mode,
                np.float32(scale))
    return rgb, sigma
