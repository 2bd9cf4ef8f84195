"""Where a print job's time goes per source kind: sampling vs labelling, and the rate that
labelling alone allows.

For each kind (:mod:`bench_sources`) a job of about ``--voxels`` voxels is planned as
``dreamprint convert`` plans it; ``--slabs`` slabs of ``--layers`` layers spread evenly over
its height are sampled (the source's ``sample_slab``, the general path) and labelled
(:func:`dreamprint_gui.job.sample_label.layer_kernel.layer_labels`: background test, table
lookup, density alignment, halftone; for a source of one colour with the job's ``UNIFORM``
colour op, one lookup per layer, as its fused path labels it: :func:`job_colour_op`), each
timed on one thread, best of ``--repeat``. Printed
per kind: the foreground share (voxels at or above the background threshold, the only ones the
lookup and alignment run on), ns per voxel of sampling and of labelling, labelling's ns per
foreground voxel (all of labelling's time, the background voxels' share included, over the
foreground voxels: a kind with little foreground shows more), and ``label-bound Mvox/s``: the
rate that two cores would reach if labelling were the only cost (2 / label ns per voxel).
Sampling is timed through ``sample_slab`` into fresh arrays (the general path), not through the
fused layer-at-a-time path that dense grids, OpenVDB / NanoVDB leaves and scalar images take in
a job: for those kinds a job samples faster than this column says (NanoVDB most of all). A
kind whose label-bound rate is below 1e8 voxels/s cannot reach the conversion target on this
machine whatever its sampling costs, without changing the labels' arithmetic (and so the
slices).

    PYTHONPATH=. python benchmarks/bench_label.py                    # every kind, 1e9-voxel jobs
    PYTHONPATH=. python benchmarks/bench_label.py --kinds demo,metaimage --voxels 1e8
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_sources import KINDS, source_path  # noqa: E402
from job_hashes import height_for  # noqa: E402
from numba import njit  # noqa: E402

from dreamprint_gui.io.volumes.srgb_encode import AS_IS  # noqa: E402
from dreamprint_gui.job.sample_label.layer_kernel import UNIFORM, layer_labels  # noqa: E402


@njit(cache=True, nogil=True)
def _slab_labels_op(rgb, dens, z0, threshold, bg_label, flat, n, sigma_clear, method, mask, ox,
                    oy, oz, seed, order, labels, counts, sums, stats, op):
    """``slab_labels`` with a ``colour_op`` (``layer_labels``)."""
    for k in range(labels.shape[0]):
        layer_labels(rgb[k], dens[k], z0 + k, threshold, bg_label, flat, n, sigma_clear,
                     method, mask, ox, oy, oz, seed, order, labels[k], counts, sums[k], stats,
                     op)


def job_colour_op(source) -> int:
    """The ``colour_op`` the job's fused path labels this source with: ``UNIFORM`` (one lookup
    per layer) for a source of one colour (a scalar image without a colour map, a dense grid
    without colour channels, a fog volume without a colour grid), else ``AS_IS`` (the general
    path's colours are already sRGB)."""
    kind = getattr(source, "layer_kind", None)
    if kind == "leaf_grid" and not getattr(source, "is_level_set", False):
        return UNIFORM
    if kind == "window":
        lut = source.lut.view(np.int32)
        return UNIFORM if bool((lut == lut[:1]).all()) else AS_IS
    vol = getattr(getattr(source, "volume", None), "data", None)
    if hasattr(source, "layer_plan") and vol is not None and vol.shape[3] == 1 \
            and kind in (None, "dense"):
        return UNIFORM
    return AS_IS


def measure(kind: str, n_voxels: float, slabs: int, layers: int, repeat: int) -> dict:
    from dreamprint_gui.job.plan import ConvertSettings, prepare_job

    src = source_path(kind)
    ctx = prepare_job(ConvertSettings(source=src, output="unused",
                                      height_mm=height_for(src, n_voxels), workers=1))
    nx, ny, nz = ctx.shape_xyz
    args = ctx.kernel_args()
    threshold = float(args[0])
    op = job_colour_op(ctx.source)
    t_sample = t_label = 0.0
    voxels = fg = 0
    for z0 in np.linspace(0, max(0, nz - layers), slabs).astype(int):
        z1 = min(nz, z0 + layers)
        best_s = best_l = np.inf
        for _ in range(repeat):
            t = time.thread_time()
            rgb, dens = ctx.source.sample_slab(ctx.grid, int(z0), int(z1))
            best_s = min(best_s, time.thread_time() - t)
            n = z1 - z0
            rgb = np.ascontiguousarray(rgb.reshape(n, -1, 3), np.float32)
            dens = np.ascontiguousarray(dens.reshape(n, -1), np.float32)
            labels = np.empty((n, ny, nx), np.uint8)
            t = time.thread_time()
            _slab_labels_op(rgb, dens, int(z0), *args, labels, np.zeros(7, np.int64),
                            np.zeros((n, 7)), np.zeros(4), op)
            best_l = min(best_l, time.thread_time() - t)
        t_sample += best_s
        t_label += best_l
        voxels += dens.size
        fg += int(np.count_nonzero(dens >= threshold))
    label_ns = t_label / voxels * 1e9
    return {"kind": kind, "grid": (nx, ny, nz), "fg": fg / voxels,
            "sample_ns": t_sample / voxels * 1e9, "label_ns": label_ns,
            "label_ns_fg": t_label / max(fg, 1) * 1e9, "bound": 2e3 / label_ns}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--kinds", default=",".join(KINDS))
    ap.add_argument("--voxels", type=float, default=1e9)
    ap.add_argument("--slabs", type=int, default=8)
    ap.add_argument("--layers", type=int, default=4)
    ap.add_argument("--repeat", type=int, default=2)
    a = ap.parse_args()
    print(f"{'kind':>16} {'grid (x,y,z)':>20} {'fg share':>8} {'sample ns':>9} "
          f"{'label ns':>8} {'label ns/fg':>11} {'label-bound Mvox/s':>18}")
    for kind in a.kinds.split(","):
        r = measure(kind, a.voxels, a.slabs, a.layers, a.repeat)
        print(f"{kind:>16} {str(r['grid']):>20} {r['fg']:>8.3f} {r['sample_ns']:>9.1f} "
              f"{r['label_ns']:>8.1f} {r['label_ns_fg']:>11.1f} {r['bound']:>18.0f}",
              flush=True)


if __name__ == "__main__":
    main()
