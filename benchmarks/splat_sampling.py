"""Gaussian-splat rasterisation speed (issue 6): voxels/s of ``GaussianCloud.sample_slab``.

Cases: the INRIA sample (9080 Gaussians) and a deterministic synthetic cloud shaped like a
3DGS reconstruction (``--n`` Gaussians, default 2e5, on a noisy sphere shell with log-normal,
flattened, randomly rotated kernels).  One 64-layer slab at mid-height, single thread (Dask
runs one slab per core), best of ``--repeat``; also the 2-thread rate (the same slab sampled
twice at once).  Run from the checkout root with ``PYTHONPATH=.`` to measure this tree.

    PYTHONPATH=. python benchmarks/splat_sampling.py [--n 200000] [--height-mm 40] [--repeat 3]
"""

from __future__ import annotations

import argparse
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from dreamprint_gui.io.volumes import grid_for_source, open_source
from dreamprint_gui.io.volumes.splats.cloud import GaussianCloud

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
VOXEL = (0.042, 0.084, 0.014)      # J850 voxel, mm


def synthetic_cloud(n: int, seed: int = 7) -> GaussianCloud:
    """``n`` Gaussians on a unit sphere shell (radial noise 2 %), sigmas log-normal around
    0.006 with one axis flattened 3x (surface-like), random rotations, opacities sigmoid(N(0,2))."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    means = d * (1.0 + 0.02 * rng.normal(size=(n, 1)))
    sig = np.exp(rng.normal(np.log(0.006), 0.5, (n, 3)))
    sig[:, 2] /= 3.0
    quats = rng.normal(size=(n, 4))
    opac = 1.0 / (1.0 + np.exp(-rng.normal(0.0, 2.0, n)))
    rgb = rng.uniform(0.0, 1.0, (n, 3))
    return GaussianCloud(f"synthetic-{n}", "synthetic", means, sig, quats, opac, rgb)


def rate(source, height_mm: float, layers: int = 64, repeat: int = 3):
    g = grid_for_source(source, VOXEL, height_mm=height_mm)
    z0 = g.shape_xyz[2] // 2 - layers // 2
    source.sample_slab(g, z0, z0 + 1)                    # compile / warm up
    best = 0.0
    for _ in range(repeat):
        t = time.perf_counter()
        _, d = source.sample_slab(g, z0, z0 + layers)
        best = max(best, d.size / (time.perf_counter() - t))
    # the same slab twice at once on two threads (the kernels release the GIL)
    with ThreadPoolExecutor(2) as ex:
        t = time.perf_counter()
        futs = [ex.submit(source.sample_slab, g, z0, z0 + layers) for _ in range(2)]
        n = sum(f.result()[1].size for f in futs)
        two = n / (time.perf_counter() - t)
    return best, two, d.size, float((d > 0).mean())


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=200_000)
    ap.add_argument("--height-mm", type=float, default=40.0)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    t = time.perf_counter()
    synth = synthetic_cloud(args.n)
    t_build = time.perf_counter() - t
    cases = [("INRIA splats (9080 Gaussians)",
              open_source(DATA / "splats" / "inria3dgs_iter7000_sh3_9080.ply")),
             (f"synthetic shell ({args.n} Gaussians)", synth)]
    print(f"synthetic cloud built in {t_build:.2f} s; voxel {VOXEL} mm, "
          f"height {args.height_mm} mm, 64-layer slab at mid-height")
    for label, src in cases:
        r1, r2, n, occ = rate(src, args.height_mm, repeat=args.repeat)
        print(f"{label:40s} {r1:10.3g} voxels/s 1 thread, {r2:10.3g} voxels/s 2 threads "
              f"(slab {n:,} voxels, {occ:.0%} non-empty)")


if __name__ == "__main__":
    main()
