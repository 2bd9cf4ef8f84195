"""Sampling speed and memory of the volume sources (issue 6).

Prints voxels/s per source kind for one slab (single thread: Dask runs one slab per core) and
the peak RSS growth while sampling a 1e10-voxel print of a small sparse source slab by slab.

    python benchmarks/volume_sampling.py [--vdb FILE]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import psutil

from dreamprint_gui.io.volumes import grid_for_source, open_source

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
VOXEL = (0.042, 0.084, 0.014)      # J850 voxel, mm


def rate(source, height_mm: float, layers: int = 64, repeat: int = 3) -> tuple[float, int]:
    g = grid_for_source(source, VOXEL, height_mm=height_mm)
    z0 = g.shape_xyz[2] // 2 - layers // 2
    source.sample_slab(g, z0, z0 + 1)                    # compile / warm up
    best = 0.0
    for _ in range(repeat):
        t = time.perf_counter()
        _, d = source.sample_slab(g, z0, z0 + layers)
        best = max(best, d.size / (time.perf_counter() - t))
    return best, d.size


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--vdb",
                    default=str(DATA / "volumes" / "blender_mantaflow_fluid_data_0190.vdb"))
    args = ap.parse_args()
    cases = [
        ("dense VTK image (hydrogen.vti), window + LUT", DATA / "volumes" / "hydrogen.vti", 40),
        ("sparse OpenVDB (Mantaflow smoke)", args.vdb, 40),
        ("MagicaVoxel (knight), nearest", DATA / "voxels" / "magicavoxel_chr_knight.vox", 40),
        ("procedural demo (400 Gaussians baked to 128^3)", "demo", 20),
        ("INRIA splats (9080 Gaussians)", DATA / "splats" / "inria3dgs_iter7000_sh3_9080.ply",
         40),
    ]
    for label, f, h in cases:
        r, n = rate(open_source(f), h)
        print(f"{label:48s} {r:10.3g} voxels/s  (slab of {n:,} voxels, 1 thread)")

    # memory: a ~1e10-voxel print of the small VDB, 4 layers at a time, 30 slabs mid-height
    proc = psutil.Process()
    s = open_source(args.vdb)
    g = grid_for_source(s, (0.0042, 0.0084, 0.0014), height_mm=12)
    base = proc.memory_info().rss
    peak = base
    mid = g.shape_xyz[2] // 2
    for z0 in range(mid, mid + 4 * 30, 4):
        out = s.sample_slab(g, z0, z0 + 4)
        peak = max(peak, proc.memory_info().rss)
        del out
    slab_bytes = 4 * g.shape_xyz[0] * g.shape_xyz[1] * 16
    print(f"print of {g.n_voxels:.3g} voxels: peak RSS growth {(peak - base) / 2**20:.0f} MiB "
          f"over 30 slabs; one 4-layer slab's output is {slab_bytes / 2**20:.0f} MiB")


if __name__ == "__main__":
    main()
