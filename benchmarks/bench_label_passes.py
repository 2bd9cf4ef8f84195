"""Where labelling's time goes, pass by pass, per source kind.

The layer kernel (:func:`dreamprint_gui.job.sample_label.layer_kernel.layer_labels`) is re-run
here with its passes switched on one after another (a copy of its loop with a switch per pass;
the passes themselves are the library's functions): (0) background test and compaction only,
(1) + staging of the foreground voxels (colour, target, halftone threshold), (2) + the table
lookup (clean colours, runs, interpolation), (3) + density alignment, (4) + the halftone's
label rule, (5) + the scatter of labels and their counts, (6) + the sums of intended
concentrations (the whole kernel). A source of one colour is labelled as the job labels it
(``UNIFORM``, ``bench_label.job_colour_op``): one lookup per layer, before the passes; its
staging is the targets only and its lookup column is then ~0. Each pass's cost is the
difference between two consecutive columns, in ns per foreground voxel (all of a layer's
time over its foreground voxels, as ``bench_label.py`` counts), thread CPU time, best of
``--repeat``, over ``--slabs`` slabs of ``--layers`` layers of a job of ``--voxels``.

    PYTHONPATH=. python benchmarks/bench_label_passes.py --kinds demo,metaimage --voxels 1e9
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from numba import njit

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_label import job_colour_op  # noqa: E402
from bench_sources import KINDS, source_path  # noqa: E402
from job_hashes import height_for  # noqa: E402

from dreamprint_gui.gamut.alignment import (  # noqa: E402
    K_TARGET,
    ROW_BLOCK,
    ROW_STRIDE,
    RUN_MIN,
    align_block,
    block_buffers,
    count_runs,
    finish_staging,
    interpolate_block,
    lookup_runs,
    stage_voxel,
    uniform_lanes,
)
from dreamprint_gui.job.halftone import (  # noqa: E402
    fg_threshold,
    label_rows,
    scatter_counts,
    threshold_row,
    tile_layout,
)
from dreamprint_gui.job.sample_label.layer_kernel import (  # noqa: E402
    DENSE_ROW,
    UNIFORM,
    block_conc_sums,
)

PASSES = ("background + compaction", "+ staging", "+ lookup", "+ alignment", "+ label rule",
          "+ scatter and counts", "+ concentration sums")


@njit(cache=False, nogil=True, error_model="numpy")
def _layer(rgb, dens, z, threshold, bg_label, flat, n, sigma_clear, method, mask, ox, oy,
           oz, seed, order, labels, counts, sums, stats, upto, uniform):
    ny, nx = labels.shape
    mz, my, mx = mask.shape
    cols, rows, tiles = tile_layout(0, nx, 0, ny, z, ox, oy, oz, mz, my, mx, seed)
    RB = ROW_BLOCK
    idx = np.empty(RB + nx, np.int64)
    tq = np.full(RB + nx, 0.5)
    trow = np.empty(nx)
    col, W, off, A, G, C = block_buffers()
    C2 = C.reshape((8, ROW_STRIDE))
    C[:] = 0.1
    lab = np.zeros(RB, np.uint8)
    acc = np.empty(48)
    out = labels.reshape(-1)
    n_bg = 0
    m = 0
    fl = np.empty(nx, np.uint8)
    if uniform and upto >= 2:  # the job's UNIFORM colour op: one lookup per layer
        uniform_lanes(flat, n, rgb[0, 0], rgb[0, 1], rgb[0, 2], col, W, off, A, G)
    for j in range(ny):
        base = j * nx
        out[base:base + nx] = bg_label
        n_fg = 0
        lo = nx
        hi = -1
        for i in range(nx):
            f = dens[base + i] >= threshold
            fl[i] = 1 if f else 0
            n_fg += 1 if f else 0
            lo = min(lo, i if f else nx)
            hi = max(hi, i if f else -1)
        n_bg += nx - n_fg
        if n_fg * DENSE_ROW >= hi + 1 - lo:
            if upto >= 1:
                threshold_row(method, mask, tiles, cols, rows, seed, j, 0, j, z, lo, hi + 1,
                              trow)
            for i in range(lo, hi + 1):
                idx[m] = base + i
                tq[m] = trow[i]
                m += np.int64(fl[i])
        elif n_fg > 0:
            for i in range(lo, hi + 1):
                if dens[base + i] >= threshold:
                    idx[m] = base + i
                    if upto >= 1:
                        tq[m] = fg_threshold(method, mask, tiles, cols, rows, seed, i, j, i, j,
                                             z)
                    m += 1
        if m < RB and j < ny - 1:
            continue
        k0 = 0
        while k0 < m and (m - k0 >= RB or j == ny - 1):
            mb = min(RB, m - k0)
            if upto >= 1 and uniform:
                for k in range(mb):
                    G[K_TARGET * ROW_STRIDE + k] = dens[idx[k0 + k]]
            elif upto >= 1:
                for k in range(mb):
                    p = idx[k0 + k]
                    stage_voxel(col, G, k, rgb[p, 0], rgb[p, 1], rgb[p, 2], dens[p])
            if upto >= 2 and not uniform:
                finish_staging(col, mb)
                if count_runs(col, mb) * RUN_MIN <= mb:
                    lookup_runs(flat, n, col, mb, W, off, A, G)
                else:
                    interpolate_block(flat, n, col, mb, W, off, A, G)
            if upto >= 3:
                align_block(sigma_clear, mb, G, C, stats)
            if upto >= 4:
                label_rows(C2, tq[k0:], mb, order, bg_label, lab)
            if upto >= 5:
                scatter_counts(out, idx, k0, lab, mb, counts)
            if upto >= 6:
                block_conc_sums(C, mb, acc, sums)
            k0 += mb
        for k in range(m - k0):
            idx[k] = idx[k0 + k]
            tq[k] = tq[k0 + k]
        m -= k0
    counts[bg_label] += n_bg
    sums[bg_label] += n_bg


def measure(kind: str, n_voxels: float, slabs: int, layers: int, repeat: int) -> dict:
    from dreamprint_gui.job.plan import ConvertSettings, prepare_job

    src = source_path(kind)
    ctx = prepare_job(ConvertSettings(source=src, output="unused",
                                      height_mm=height_for(src, n_voxels), workers=1))
    nx, ny, nz = ctx.shape_xyz
    args = ctx.kernel_args()
    threshold = float(args[0])
    uniform = job_colour_op(ctx.source) == UNIFORM
    best = np.zeros(len(PASSES))
    fg = 0
    for z0 in np.linspace(0, max(0, nz - layers), slabs).astype(int):
        z1 = min(nz, z0 + layers)
        rgb, dens = ctx.source.sample_slab(ctx.grid, int(z0), int(z1))
        n = z1 - z0
        rgb = np.ascontiguousarray(rgb.reshape(n, -1, 3), np.float32)
        dens = np.ascontiguousarray(dens.reshape(n, -1), np.float32)
        labels = np.empty((ny, nx), np.uint8)
        fg += int(np.count_nonzero(dens >= threshold))
        for upto in range(len(PASSES)):
            b = np.inf
            for _ in range(repeat):
                t = time.thread_time()
                for k in range(n):
                    _layer(rgb[k], dens[k], int(z0) + k, *args, labels, np.zeros(7, np.int64),
                           np.zeros(7), np.zeros(4), upto, uniform)
                b = min(b, time.thread_time() - t)
            best[upto] += b
    return {"kind": kind, "grid": (nx, ny, nz), "fg": fg, "cum_ns_fg": best / max(fg, 1) * 1e9}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--kinds", default=",".join(KINDS))
    ap.add_argument("--voxels", type=float, default=1e9)
    ap.add_argument("--slabs", type=int, default=6)
    ap.add_argument("--layers", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=4)
    a = ap.parse_args()
    print("ns per foreground voxel, cumulative (pass cost in brackets)")
    print(f"{'kind':>14} " + " ".join(f"{p:>24}" for p in PASSES))
    for kind in a.kinds.split(","):
        r = measure(kind, a.voxels, a.slabs, a.layers, a.repeat)
        c = r["cum_ns_fg"]
        d = np.diff(c, prepend=0.0)
        print(f"{kind:>14} " + " ".join(f"{c[i]:>15.1f} ({d[i]:>5.1f})" for i in range(len(c))),
              flush=True)


if __name__ == "__main__":
    main()
