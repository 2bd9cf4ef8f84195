"""The print job's per-layer kernel: background test -> lookup -> alignment -> halftone -> labels.

Defines
-------
- :func:`layer_labels`: one layer of sampled colour and density (1/mm) -> material labels, label
  counts, intended concentrations and the clamp report; compiled (numba), releases the GIL.
- :func:`strip_labels`: the same for a strip of a layer's rows, the samples of that strip alone
  in the arrays (a fused sampler's strips stay in the L2 cache), the layer's unfinished block
  carried from strip to strip in :func:`layer_state`: the results of the whole layer.
- :func:`slab_labels`: the same for every layer of a slab in one call (a call from Python costs
  ~70 us of argument checks, as much as a small job's layer of 20 000 voxels).

In passes over blocks of foreground voxels, so that the arithmetic of 8-16 voxels runs in one
vector instruction (AVX2 / AVX-512) instead of one voxel's latency chain at a time: (1) gather
the voxels whose density reaches the background threshold with their halftone threshold
(a row with enough foreground: the whole row's thresholds as copies of mask rows,
:func:`halftone.threshold_row`, then a branch-free compaction; a sparse row: voxel by voxel),
across rows until a block of ``ROW_BLOCK`` voxels is full (a narrow row alone would feed the
vector passes a few voxels at a time), then stage their colour and target; (2)
tetrahedral lookup of the table node fields (:func:`gamut.alignment.interpolate_block`, or once
per run of one colour: :func:`gamut.alignment.lookup_runs`; for a source of one colour, once per
layer, and only the targets are staged: :data:`UNIFORM`); (3)
density alignment (:func:`gamut.alignment.align_rows`); (4) halftone
(:func:`halftone.label_rows`), then the labels are scattered into the layer
(:func:`halftone.scatter_counts`) and their intended concentrations summed
(:func:`block_conc_sums`). A block's working arrays stay in the L2 cache. A voxel's label
depends on its position, the seed and its own inputs only, so the passes do not change what a
slab, a worker count or a scheduler produces.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from dreamprint_gui.core.kernels.vec16 import accumulate8
from dreamprint_gui.gamut.alignment import (
    K_TARGET,
    ROW_BLOCK,
    ROW_STRIDE,
    align_block,
    block_buffers,
    lookup_align_block,
    stage_voxel,
    uniform_lanes,
)
from dreamprint_gui.io.volumes.srgb_encode import AS_IS, prepare_staged
from dreamprint_gui.job.halftone import (
    fg_threshold,
    label_rows,
    scatter_counts,
    threshold_row,
    tile_layout,
)

__all__ = ["layer_labels", "strip_labels", "layer_state", "strip_rows", "slab_labels",
           "block_conc_sums", "DENSE_ROW", "UNIFORM", "STRIP_VOXELS"]

# A ``colour_op`` of :func:`layer_labels` besides those of :mod:`..io.volumes.srgb_encode`:
# every voxel's colour is ``rgb[0]``'s (sRGB): a source of one colour (a scalar image without a
# colour map, a density-only VDB). The lookup is done once per layer
# (:func:`..gamut.alignment.uniform_lanes`) and only ``rgb[0]`` is read.
UNIFORM = 3

# The fused samplers (.dense_job, .leaf_grid_job) sample and label a layer in strips of rows of
# at most this many voxels (16 bytes each of colour and density: 512 kB, within the L2 cache; a
# 1e10-voxel job's layer is 32 MB): :func:`strip_rows`, :func:`strip_labels`.
STRIP_VOXELS = 1 << 15


# A row with at least 1/DENSE_ROW of its voxels in the foreground gets its halftone thresholds
# for the whole row (:func:`.halftone.threshold_row`) and a branch-free compaction; a sparser
# row, its foreground voxels' thresholds one by one.
DENSE_ROW = 8


@njit(cache=True, nogil=True, inline="always")
def block_conc_sums(C, m, acc, sums):
    """``sums[q] += C[q * ROW_STRIDE + k]`` over ``k < m`` for the six inks (``C`` the block's
    concentration rows, 1-D), as 8 float64 partial sums per ink (:func:`.vec16.accumulate8`,
    ``acc`` (48,) scratch) added in a fixed order: a float sum written as one loop waits for
    each addition in turn (~5 cycles per voxel). The same bits on every CPU."""
    RS = ROW_STRIDE
    acc[:] = 0.0
    m8 = m - m % 8
    for k0 in range(0, m8, 8):
        for q in range(6):
            accumulate8(C, np.int64(q * RS + k0), acc, np.int64(q))
    for q in range(6):
        s = 0.0
        for j in range(8):
            s += acc[q * 8 + j]
        for k in range(m8, m):
            s += C[q * RS + k]
        sums[q] += s


@njit(cache=True, nogil=True)
def strip_rows(ny, nx, strip_voxels):
    """Rows per strip of a layer of ``ny`` rows of ``nx`` voxels: ``strip_voxels`` voxels at
    most, one row at least."""
    return max(1, min(ny, strip_voxels // max(nx, 1)))


@njit(cache=True, nogil=True)
def layer_state(nx):
    """The working arrays of one layer's labelling (:func:`strip_labels`), which carry its
    unfinished block from one strip of rows to the next: (flat positions, halftone thresholds,
    a row's thresholds, the block buffers of :func:`..gamut.alignment.block_buffers`, labels,
    sums scratch, (voxels waiting, how many of them are staged, background voxels so far),
    and a row's foreground flags). Reusable from layer to layer of rows of ``nx`` voxels."""
    RB = ROW_BLOCK
    col, W, off, A, G, C = block_buffers()
    return (np.empty(RB + nx, np.int64), np.empty(RB + nx), np.empty(nx), col, W, off, A, G, C,
            np.empty(RB, np.uint8), np.empty(48), np.zeros(3, np.int64), np.empty(nx, np.uint8))


@njit(cache=True, nogil=True, inline="always")
def _stage(rgb, dens, idx, k0, a, b, shift, uniform, col, G):
    """Voxels ``a .. b - 1`` of the block that starts at waiting voxel ``k0``: their target, and
    their colour as read unless ``uniform``, from the strip's arrays (layer position ``idx``
    minus ``shift``) into the block buffers (:func:`..gamut.alignment.stage_voxel`)."""
    if uniform:
        tg = G[K_TARGET * ROW_STRIDE:]
        for k in range(a, b):
            tg[k] = dens[idx[k0 + k] - shift]
    else:
        for k in range(a, b):
            p = idx[k0 + k] - shift
            stage_voxel(col, G, k, rgb[p, 0], rgb[p, 1], rgb[p, 2], dens[p])


@njit(cache=True, nogil=True, error_model="numpy")
def layer_labels(rgb, dens, z, threshold, bg_label, flat, n, sigma_clear,
                 method, mask, ox, oy, oz, seed, order, labels, counts, sums, stats,
                 colour_op=AS_IS):
    """``rgb`` (ny*nx, 3) float32 sRGB, ``dens`` (ny*nx,) float32 1/mm of layer ``z`` ->
    ``labels`` (ny, nx) uint8. Accumulates ``counts`` (7,) int64, ``sums`` (7,) float64
    (intended concentrations; background voxels count 1 for ``bg_label``) and ``stats`` (4,)
    (clamped low, clamped high, worst low shortfall, worst high shortfall). ``colour_op``
    (:mod:`..io.volumes.srgb_encode`): the colours as read are sRGB-encoded (``ENCODE``: ``rgb``
    holds linear values) or clipped (``CLIP``) first, in the staged block
    (:func:`..io.volumes.srgb_encode.prepare_staged`): only the foreground voxels', the only
    colours read (the rest of ``rgb`` may hold anything); ``UNIFORM``: every voxel has
    ``rgb[0]``'s colour, the only one read (the same labels, looked up once). The whole layer
    as one strip (:func:`strip_labels`)."""
    ny, nx = labels.shape
    strip_labels(rgb, dens, z, 0, ny, threshold, bg_label, flat, n, sigma_clear, method, mask,
                 ox, oy, oz, seed, order, labels, counts, sums, stats, colour_op,
                 layer_state(nx))


@njit(cache=True, nogil=True, error_model="numpy")
def strip_labels(rgb, dens, z, y0, ny_strip, threshold, bg_label, flat, n, sigma_clear,
                 method, mask, ox, oy, oz, seed, order, labels, counts, sums, stats, colour_op,
                 state):
    """:func:`layer_labels` of rows ``y0 .. y0 + ny_strip - 1`` of layer ``z`` (``labels`` the
    whole layer, (ny, nx)), whose samples alone ``rgb`` (ny_strip*nx, 3) and ``dens``
    (ny_strip*nx,) hold, so that a sampler can fill a strip that stays in the L2 cache instead
    of a layer (a 1e10-voxel job's layer of colour and density is 32 MB). Call it for the
    strips of a layer in order from ``y0 = 0`` with one ``state`` (:func:`layer_state`): the
    block that a strip leaves unfinished waits there, its voxels' inputs staged before the
    strip's arrays are refilled, so the blocks, and with them every label, count, sum and
    clamp report, are those of the whole layer in one call, whatever the strips."""
    ny = labels.shape[0]
    nx = labels.shape[1]
    mz, my, mx = mask.shape
    cols, rows, tiles = tile_layout(0, nx, y0, ny_strip, z, ox, oy, oz, mz, my, mx, seed)
    RB = ROW_BLOCK
    # Foreground voxels of consecutive rows (flat position in the layer, halftone threshold)
    # wait here until a block is full: narrow rows would otherwise give the vector passes a few
    # voxels at a time.
    idx, tq, trow, col, W, off, A, G, C, lab, acc, ints, fl = state
    C2 = C.reshape((8, ROW_STRIDE))
    out = labels.reshape(-1)
    uniform = colour_op == UNIFORM
    if y0 == 0:  # a new layer
        ints[:] = 0
        if uniform:  # G's lookup lanes, once for every block of the layer
            uniform_lanes(flat, n, rgb[0, 0], rgb[0, 1], rgb[0, 2], col, W, off, A, G)
    m = ints[0]       # voxels waiting
    staged = ints[1]  # the first ``staged`` of them are in the block buffers already
    n_bg = ints[2]
    shift = y0 * nx   # layer position -> position in this strip's arrays
    for jl in range(ny_strip):
        j = y0 + jl
        base = j * nx
        src = jl * nx
        out[base:base + nx] = bg_label
        # vectorised: the row's foreground count and span [lo, hi]; an empty row (a third or
        # more of most jobs) is filled with no compaction, and a row's compaction covers its
        # span only (a sparse source's rows are two to three times their foreground)
        n_fg = 0
        lo = nx
        hi = -1
        for i in range(nx):
            f = dens[src + i] >= threshold  # NaN is background
            fl[i] = 1 if f else 0
            n_fg += 1 if f else 0
            lo = min(lo, i if f else nx)
            hi = max(hi, i if f else -1)
        n_bg += nx - n_fg
        if n_fg * DENSE_ROW >= hi + 1 - lo:
            # the span's thresholds at once (copies of mask rows), then a branch-free compaction
            # that reads the scan's flags: testing the density again there, after the stores of
            # the previous voxel, took 5-6 ns per voxel instead of ~1.5 on an AMD Zen 1 core
            threshold_row(method, mask, tiles, cols, rows, seed, jl, 0, j, z, lo, hi + 1, trow)
            for i in range(lo, hi + 1):
                idx[m] = base + i
                tq[m] = trow[i]
                m += np.int64(fl[i])
        elif n_fg > 0:  # few foreground voxels: their thresholds one by one
            for i in range(lo, hi + 1):
                if dens[src + i] >= threshold:
                    idx[m] = base + i
                    tq[m] = fg_threshold(method, mask, tiles, cols, rows, seed, i, jl, i, j, z)
                    m += 1
        if m < RB and j < ny - 1:
            continue
        k0 = 0
        while k0 < m and (m - k0 >= RB or j == ny - 1):
            mb = min(RB, m - k0)
            first = staged if k0 == 0 else 0  # waiting from an earlier strip: staged then
            _stage(rgb, dens, idx, k0, first, mb, shift, uniform, col, G)
            if uniform:
                align_block(sigma_clear, mb, G, C, stats)
            else:
                prepare_staged(col, mb, ROW_STRIDE, colour_op)
                lookup_align_block(flat, n, sigma_clear, col, mb, W, off, A, G, C, stats)
            label_rows(C2, tq[k0:], mb, order, bg_label, lab)
            scatter_counts(out, idx, k0, lab, mb, counts)
            block_conc_sums(C, mb, acc, sums)
            k0 += mb
        if k0 > 0:
            staged = 0  # what waits now was beyond the blocks: not staged
        for k in range(m - k0):  # the unfinished block's voxels move to the front
            idx[k] = idx[k0 + k]
            tq[k] = tq[k0 + k]
        m -= k0
    if y0 + ny_strip < ny:
        # the layer goes on in another strip, into these arrays: stage what waits (m < RB)
        _stage(rgb, dens, idx, 0, staged, m, shift, uniform, col, G)
        staged = m
    else:
        counts[bg_label] += n_bg
        sums[bg_label] += n_bg
    ints[0] = m
    ints[1] = staged
    ints[2] = n_bg


@njit(cache=True, nogil=True, error_model="numpy")
def slab_labels(rgb, dens, z0, threshold, bg_label, flat, n, sigma_clear,
                method, mask, ox, oy, oz, seed, order, labels, counts, sums, stats):
    """:func:`layer_labels` for layers ``z0 .. z0 + L - 1``: ``rgb`` (L, ny*nx, 3), ``dens``
    (L, ny*nx), ``labels`` (L, ny, nx); ``sums`` (L, 7), one row per layer (a layer's sum does
    not depend on the slab it was in, so the job's total need not either)."""
    for k in range(labels.shape[0]):
        layer_labels(rgb[k], dens[k], z0 + k, threshold, bg_label, flat, n, sigma_clear,
                     method, mask, ox, oy, oz, seed, order, labels[k], counts, sums[k], stats)
