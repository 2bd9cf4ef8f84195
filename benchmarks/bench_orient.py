"""The cost of turning a source (``--up``): sampling CPU time per voxel, unturned vs turned.

For each source (the demo cloud, the knight .vox, the INRIA splat sample) and each ``--up``
axis, the source is opened, turned (:func:`dreamprint_gui.io.volumes.orient.orient_source`:
splats are turned in place, other sources wrapped in ``OrientedSource``), laid on a grid of
about ``--voxels`` voxels (j850-paper voxel, declared box) and sampled slab by slab as a job's
general path does (``sample_slab`` into reused buffers, ``--slab-voxels`` per slab). Printed:
ns of process CPU time per voxel (best of ``--repeat``; CPU time, so other processes on the
machine inflate it less than wall time), and the ratio to ``--up z``. A dense grid's job with
``--up z`` takes the fused layer path instead (bench_convert.py); a turned one takes this one.

    PYTHONPATH=$PWD python benchmarks/bench_orient.py --voxels 1e7
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_sources import source_path  # noqa: E402

VOXEL = (0.084, 0.028, 0.014)  # j850-paper


def cpu_ns_per_voxel(src, n_voxels: float, slab_voxels: int, repeat: int) -> tuple[float, tuple]:
    from dreamprint_gui.io.volumes.base import SlabBuffers, grid_for_source

    lo, hi = src.bounds
    ext = [h - lo_ for lo_, h in zip(lo, hi, strict=True)]
    mpu = (n_voxels * VOXEL[0] * VOXEL[1] * VOXEL[2] / (ext[0] * ext[1] * ext[2])) ** (1 / 3)
    grid = grid_for_source(src, VOXEL, height_mm=ext[2] * mpu)
    nx, ny, nz = grid.shape_xyz
    step = max(1, slab_voxels // (nx * ny))
    best = float("inf")
    for _ in range(repeat):
        buf = SlabBuffers()
        t0 = time.process_time()
        for z in range(0, nz, step):
            src.sample_slab(grid, z, min(nz, z + step), out=buf)
        best = min(best, time.process_time() - t0)
    return best / grid.n_voxels * 1e9, tuple(grid.shape_xyz)


def main() -> None:
    from dreamprint_gui.io.volumes import open_source
    from dreamprint_gui.io.volumes.orient import UP_AXES, choose_orientation, orient_source

    ap = argparse.ArgumentParser()
    ap.add_argument("--voxels", type=float, default=1e7)
    ap.add_argument("--slab-voxels", type=int, default=4_000_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--kinds", default="demo,vox,inria-sample")
    a = ap.parse_args()
    print(f"load {open('/proc/loadavg').read().split()[:3]}, {os.cpu_count()} cores; "
          f"~{a.voxels:.0e} voxels, one thread, process CPU ns per voxel (best of {a.repeat})")
    print(f"{'source':>13} {'up':>3} {'grid (x,y,z)':>18} {'ns/voxel':>9} {'vs up z':>8}")
    for kind in a.kinds.split(","):
        base = open_source(source_path(kind))
        ref = None
        for up in ("z", *[u for u in UP_AXES if u != "z"]):
            src = orient_source(base, choose_orientation(base, up, 0))
            ns, shape = cpu_ns_per_voxel(src, a.voxels, a.slab_voxels, a.repeat)
            ref = ns if up == "z" else ref
            print(f"{kind:>13} {up:>3} {str(shape):>18} {ns:9.1f} {ns / ref:8.2f}", flush=True)


if __name__ == "__main__":
    main()
