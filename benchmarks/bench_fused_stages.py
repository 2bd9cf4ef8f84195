"""Where a fused print job's time goes, per stage, on one thread: sample, label, encode, write.

For a source kind whose job takes a fused layer-at-a-time path (dense grids, scalar images
through a window, OpenVDB / NanoVDB leaf grids with or without a ``Cd`` colour grid), a job of
about ``--voxels`` voxels is planned as ``bench_convert.py`` plans it (j850-paper, ``--fit
box``), and ``--slabs`` slabs of ``--layers`` layers spread over its height are run stage by
stage, each timed in thread CPU time (best of ``--repeat``):

- ``fused``: the job's own compiled call (sample + label, one layer at a time);
- ``sample``: the same call with the labelling left out (the layer's samples kept);
- ``label``: :func:`dreamprint_gui.job.sample_label.layer_kernel.layer_labels` on those samples
  (with the sRGB encoding of a linear colour, which the fused paths do in the labelling's
  staged blocks);
- ``encode``: the slab's PNGs (:func:`dreamprint_gui.job.encode.png_slices.encode_labels_pngs`);
- ``write``: the PNGs written as new files into a folder under ``benchmarks/.jobs``.

Printed in ns per voxel, with the foreground share and the rate two fully busy cores would
reach at the fused + encode + write cost.

    PYTHONPATH=. python benchmarks/bench_fused_stages.py --kinds metaimage,openvdb-colour,demo
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from numba import njit

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_convert import PRINTER, jobs_dir  # noqa: E402
from bench_convert import height_for as demo_height

from dreamprint_gui.io.volumes.dense import window_kernel  # noqa: E402
from dreamprint_gui.io.volumes.dense_sampler import (  # noqa: E402
    COLOUR,
    COLOUR_WHERE_DENSE,
    DENSITY,
    RAW,
    dense_layer,
    dense_window_layer,
)
from dreamprint_gui.io.volumes.srgb_encode import AS_IS, CLIP, ENCODE  # noqa: E402
from dreamprint_gui.io.volumes.vdb.leaf_grid import (  # noqa: E402
    leaf_grid_layer,
    leaf_grid_values_where,
)
from dreamprint_gui.job.sample_label.layer_kernel import UNIFORM, layer_labels  # noqa: E402


@njit(cache=True, nogil=True)
def _sample_dense(vol, rows_nz, iz0, iz1, wz, vz, iy0, iy1, wy, vy, ix0, ix1, wx, vx, rslot,
                  srows, planes, planes_nz, plane_layer, row, cpl, scale, uniform, linear,
                  rgb, dens, threshold, nx):
    colour = vol.shape[3] == 4
    mode = (COLOUR_WHERE_DENSE if threshold > 0 else COLOUR) if colour else DENSITY
    for k in range(rgb.shape[0]):
        if not colour:
            for c in range(3):
                rgb[k, 0, c] = uniform[c]
        rf = rgb[k].reshape(-1)
        dense_layer(vol, rows_nz, k, iz0, iz1, wz, vz, iy0, iy1, wy, vy, ix0, ix1, wx, vx,
                    rslot, srows, planes, planes_nz, plane_layer, row, cpl, rf, rf, dens[k],
                    mode, scale)


@njit(cache=True)
def _one_colour(lut):
    li = lut.view(np.int32)
    same = True
    for i in range(lut.shape[0]):
        for c in range(3):
            same &= li[i, c] == li[0, c]
    return same


@njit(cache=True, nogil=True)
def _sample_window(vol, rows_nz, iz0, iz1, wz, vz, iy0, iy1, wy, vy, ix0, ix1, wx, vx, rslot,
                   srows, planes, planes_nz, plane_layer, row, cpl, low, inv_width, lut,
                   density, use_outside, outside_z, outside_y, outside_x, values, rgb, dens, nx):
    one_colour = _one_colour(lut)
    for k in range(rgb.shape[0]):
        if one_colour:
            for c in range(3):
                rgb[k, 0, c] = lut[0, c]
            dense_window_layer(vol, rows_nz, k, iz0, iz1, wz, vz, iy0, iy1, wy, vy, ix0, ix1,
                               wx, vx, rslot, srows, planes, planes_nz, plane_layer, row, low,
                               inv_width, density, dens[k])
        else:
            dense_layer(vol, rows_nz, k, iz0, iz1, wz, vz, iy0, iy1, wy, vy, ix0, ix1, wx, vx,
                        rslot, srows, planes, planes_nz, plane_layer, row, cpl, values, values,
                        dens[k], RAW, np.float32(1.0))
            window_kernel(values, low, inv_width, lut, density, rgb[k], dens[k])
        if use_outside:
            d = dens[k]
            for j in range(d.shape[0] // nx):
                for i in range(nx):
                    if outside_z[k] or outside_y[j] or outside_x[i]:
                        d[j * nx + i] = 0.0


@njit(cache=True, nogil=True)
def _sample_leaf(dense, rows_nz, k0, wk, j0, wj, i0, wi, plane, scale, uniform, rgb, dens):
    for k in range(rgb.shape[0]):
        for c in range(3):
            rgb[k, 0, c] = uniform[c]
        leaf_grid_layer(dense, rows_nz, k0[k], wk[k], j0, wj, i0, wi, plane, scale, dens[k])


@njit(cache=True, nogil=True)
def _sample_leaf_colour(dense, rows_nz, k0, wk, j0, wj, i0, wi, plane, scale, cdense, crows_nz,
                        ck0, cwk, cj0, cwj, ci0, cwi, cplane, linear, rgb, dens, threshold):
    for k in range(rgb.shape[0]):
        leaf_grid_layer(dense, rows_nz, k0[k], wk[k], j0, wj, i0, wi, plane, scale, dens[k])
        leaf_grid_values_where(cdense, crows_nz, ck0[k], cwk[k], cj0, cwj, ci0, cwi,
                               cplane.reshape(-1), rgb[k].reshape(-1), dens[k], threshold)


@njit(cache=True, nogil=True)
def _label_slab(rgb, dens, z0, threshold, bg_label, flat, n, sigma_clear, method, mask, ox, oy,
                oz, seed, order, labels, counts, sums, stats, op):
    for k in range(labels.shape[0]):
        layer_labels(rgb[k], dens[k], z0 + k, threshold, bg_label, flat, n, sigma_clear,
                     method, mask, ox, oy, oz, seed, order, labels[k], counts, sums[k], stats,
                     op)


def _colour_op(kind: str, plan: tuple) -> int:
    """What the job's labelling does to the sampled colours (the fused kernels' choice)."""
    if kind == "leaf_grid_colour":
        return ENCODE if plan[-1] else CLIP
    if kind == "dense":
        return (ENCODE if plan[-1] else AS_IS) if plan[0].shape[3] == 4 else UNIFORM
    if kind == "window":
        return UNIFORM if _one_colour(plan[23]) else AS_IS
    return UNIFORM


def _sample_only(kind: str, plan: tuple, rgb, dens, threshold, ny: int, nx: int) -> None:
    if kind == "dense":
        _sample_dense(*plan, rgb, dens, threshold, nx)
    elif kind == "window":
        _sample_window(*plan, rgb, dens, nx)
    elif kind == "leaf_grid":
        _sample_leaf(*plan, rgb, dens)
    else:
        _sample_leaf_colour(*plan, rgb, dens, threshold)


def _timed(fn, repeat: int) -> float:
    best = np.inf
    for _ in range(repeat):
        t = time.thread_time()
        fn()
        best = min(best, time.thread_time() - t)
    return best


def measure(kind: str, n_voxels: float, slabs: int, layers: int, repeat: int) -> dict:
    from bench_convert import height_of, source_file

    from dreamprint_gui.job.encode.png_slices import encode_labels_pngs
    from dreamprint_gui.job.plan import ConvertSettings, prepare_job
    from dreamprint_gui.job.slab import _LAYER_KERNELS, _oriented
    from dreamprint_gui.job.write import slice_name

    src = source_file(kind)
    h = demo_height(n_voxels) if src == "demo" else height_of(src, n_voxels)
    ctx = prepare_job(ConvertSettings(source=src, output="unused", height_mm=h, workers=1,
                                      printer=PRINTER, fit="box"))
    source, _ = ctx.resources()
    nx, ny, nz = ctx.shape_xyz
    args = ctx.kernel_args()
    threshold = args[0]
    lk = getattr(source, "layer_kind", "dense")
    fused = _LAYER_KERNELS[lk]
    scale = ctx.settings.density_scale
    out_dir = tempfile.mkdtemp(prefix="dp-stages-", dir=jobs_dir())
    t = {"fused": 0.0, "sample": 0.0, "label": 0.0, "encode": 0.0, "write": 0.0}
    voxels = fg = 0
    try:
        for z0 in np.linspace(0, max(0, nz - layers), slabs).astype(int):
            z0 = int(z0)
            z1 = min(nz, z0 + layers)
            n = z1 - z0
            labels = np.empty((n, ny, nx), np.uint8)
            rgb1 = np.empty((ny * nx, 3), np.float32)
            dens1 = np.empty(ny * nx, np.float32)

            def run_fused(z0=z0, z1=z1, n=n, labels=labels, rgb1=rgb1, dens1=dens1):
                plan = source.layer_plan(ctx.grid, z0, z1, density_scale=scale)
                fused(*plan, rgb1, dens1, z0, *args, labels, np.zeros(7, np.int64),
                      np.zeros((n, 7)), np.zeros(4))

            t["fused"] += _timed(run_fused, repeat)
            rgb = np.empty((n, ny * nx, 3), np.float32)
            dens = np.empty((n, ny * nx), np.float32)

            def run_sample(z0=z0, z1=z1, rgb=rgb, dens=dens):
                plan = source.layer_plan(ctx.grid, z0, z1, density_scale=scale)
                _sample_only(lk, plan, rgb, dens, threshold, ny, nx)

            t["sample"] += _timed(run_sample, repeat)
            lab2 = np.empty_like(labels)
            op = _colour_op(lk, source.layer_plan(ctx.grid, z0, z1, density_scale=scale))
            t["label"] += _timed(lambda z0=z0, n=n, rgb=rgb, dens=dens, lab2=lab2, op=op:
                                 _label_slab(rgb, dens, z0, *args, lab2, np.zeros(7, np.int64),
                                             np.zeros((n, 7)), np.zeros(4), op), repeat)
            if not np.array_equal(lab2, labels):
                raise SystemExit(f"{kind}: the sample-then-label labels differ from the fused")
            pngs: list[bytes] = []

            def run_encode(labels=labels, pngs=pngs):
                pngs[:] = encode_labels_pngs(_oriented(ctx, labels), ctx.palette,
                                             ctx.printer.png_mode,
                                             ctx.printer.pixels_per_metre())

            t["encode"] += _timed(run_encode, repeat)
            t0 = time.thread_time()
            for k, png in enumerate(pngs):
                with open(os.path.join(out_dir, slice_name(z0 + k, nz)), "wb") as f:
                    f.write(png)
            t["write"] += time.thread_time() - t0
            voxels += dens.size
            fg += int(np.count_nonzero(dens >= threshold))
    finally:
        shutil.rmtree(out_dir, ignore_errors=True)
    ns = {k: v / voxels * 1e9 for k, v in t.items()}
    total = ns["fused"] + ns["encode"] + ns["write"]
    return {"kind": kind, "layer_kind": lk, "grid": (nx, ny, nz), "fg": fg / voxels, **ns,
            "total": total, "bound": 2e3 / total}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--kinds", default="metaimage,openvdb-colour,demo")
    ap.add_argument("--voxels", type=float, default=1e9)
    ap.add_argument("--slabs", type=int, default=8)
    ap.add_argument("--layers", type=int, default=4)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    print(f"{'kind':>16} {'path':>16} {'grid (x,y,z)':>20} {'fg':>5} {'fused':>6} {'sample':>6} "
          f"{'label':>6} {'encode':>6} {'write':>6} {'total':>6} {'2 cores Mvox/s':>14} "
          f"{'load':>5}   (ns per voxel, thread CPU time)")
    for kind in a.kinds.split(","):
        r = measure(kind, a.voxels, a.slabs, a.layers, a.repeat)
        print(f"{r['kind']:>16} {r['layer_kind']:>16} {str(r['grid']):>20} {r['fg']:>5.2f} "
              f"{r['fused']:>6.2f} {r['sample']:>6.2f} {r['label']:>6.2f} {r['encode']:>6.2f} "
              f"{r['write']:>6.2f} {r['total']:>6.2f} {r['bound']:>14.0f} "
              f"{os.getloadavg()[0]:>5.1f}", flush=True)


if __name__ == "__main__":
    main()
