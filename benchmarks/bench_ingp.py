"""InstantNGP snapshot sampling speed (issue 18): voxels/s of ``IngpSource.sample_slab``.

The benchmark writes a snapshot shaped like instant-ngp's NeRF defaults (``--levels`` 16
levels of 2 features, a 2^19 hash table, base resolution 16, per-level scale from
aabb_scale 1; density MLP 64 wide with 1 hidden layer, colour MLP 64 wide with 2, SH degree 4;
float16 parameters, gzip'd msgpack) with seeded random weights, and an occupancy grid marking a
ball of radius ``--radius`` (0.35: ~18 % of the cells).  It samples ``--slabs`` slabs of
``--layers`` layers spread evenly over the height of a print ``--height-mm`` tall at the J850
voxel (0.042 x 0.084 x 0.014 mm) and prints, best of ``--repeat``:

* single thread: voxels/s (wall) and ns per voxel, and the thread's CPU time per voxel and per
  evaluated (occupied) voxel (what a quiet machine would show: this one is shared);
* two threads: two slabs sampled at once on two threads (as a print job runs one slab per core),
  and one call with ``threads=2`` (how ``sample_slab`` splits rows from the main thread);
* ``--view mean``: the same with the colour averaged over 6 directions.

    PYTHONPATH=. python benchmarks/bench_ingp.py [--height-mm 30] [--layers 8] [--slabs 9]
        [--repeat 3] [--mean]

Issue 25 (row path: occupancy a block at a time, coarse levels a row at a time), one run
alternating with the old kernels at load 1.2-2.5: 1 thread CPU 136-144 -> 106 ns/voxel,
850-900 -> 662 ns per evaluated voxel, of which the two networks ~270 (near the float32 FMA
peak: the floor of this snapshot's per-voxel networks). docs/instant-ngp.md, "Speed".
"""

from __future__ import annotations

import argparse
import gzip
import math
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import msgpack
import numpy as np

from dreamprint_gui.io.volumes import grid_for_source, open_source

VOXEL = (0.042, 0.084, 0.014)      # J850 voxel, mm


def _next16(v: int) -> int:
    return (v + 15) // 16 * 16


def write_realistic(path: Path, levels: int = 16, log2_t: int = 19, radius: float = 0.35,
                    seed: int = 1) -> float:
    """Write the snapshot; return the occupied fraction of the occupancy grid."""
    rng = np.random.default_rng(seed)
    base, feat, aabb_scale = 16, 2, 1
    pls = math.exp(math.log(2048.0 * aabb_scale / base) / (levels - 1))
    n_entries = 0
    for lvl in range(levels):
        s = float(np.float32(np.exp2(np.float32(lvl) * np.float32(np.log2(np.float32(pls))))
                             * np.float32(base) - np.float32(1)))
        r = math.ceil(s) + 1
        n_entries += min((r ** 3 + 7) // 8 * 8, 2 ** log2_t)
    enc_w = _next16(levels * feat)
    dm = [(64, enc_w), (16, 64)]
    rm = [(64, 32), (64, 64), (16, 64)]
    mats = [rng.normal(0, 1 / math.sqrt(i), (o, i)) for o, i in dm + rm]
    table = rng.uniform(-1e-1, 1e-1, n_entries * feat)
    params = np.concatenate([m.reshape(-1) for m in mats] + [table]).astype(np.float16)
    # occupancy: a ball around the cube centre, Morton-ordered like instant-ngp's grid
    idx = np.arange(128 ** 3, dtype=np.int64)
    xyz = [np.zeros_like(idx) for _ in range(3)]
    for b in range(7):
        for a in range(3):
            xyz[a] |= ((idx >> (3 * b + a)) & 1) << b
    c = [(v + 0.5) / 128 - 0.5 for v in xyz]
    grid = np.where(c[0] ** 2 + c[1] ** 2 + c[2] ** 2 < radius ** 2, 1.0, 0.0)
    cfg = {
        "encoding": {"otype": "HashGrid", "n_levels": levels, "n_features_per_level": feat,
                     "log2_hashmap_size": log2_t, "base_resolution": base},
        "network": {"otype": "FullyFusedMLP", "activation": "ReLU", "output_activation": "None",
                    "n_neurons": 64, "n_hidden_layers": 1},
        "dir_encoding": {"otype": "Composite", "nested": [
            {"n_dims_to_encode": 3, "otype": "SphericalHarmonics", "degree": 4},
            {"otype": "Identity"}]},
        "rgb_network": {"otype": "FullyFusedMLP", "activation": "ReLU",
                        "output_activation": "None", "n_neurons": 64, "n_hidden_layers": 2},
        "snapshot": {"version": 1, "mode": "nerf", "n_params": int(params.size),
                     "params_type": "__half", "params_binary": params.tobytes(),
                     "density_grid_size": 128,
                     "density_grid_binary": grid.astype(np.float16).tobytes(),
                     "nerf": {"aabb_scale": aabb_scale,
                              "dataset": {"scale": 0.33, "offset": [0.5, 0.5, 0.5],
                                          "aabb_scale": aabb_scale, "is_hdr": False}},
                     "aabb": {"min": [0, 0, 0], "max": [1, 1, 1]},
                     "render_aabb": {"min": [0, 0, 0], "max": [1, 1, 1]}},
    }
    path.write_bytes(gzip.compress(msgpack.packb(cfg, use_bin_type=True), compresslevel=1))
    return float(grid.mean())


def measure(source, height_mm: float, layers: int, repeat: int, n_slabs: int) -> dict:
    """Rates over ``n_slabs`` slabs of ``layers`` layers spread evenly over the print's height
    (the print's mix of empty and occupied layers), best of ``repeat``."""
    g = grid_for_source(source, VOXEL, height_mm=height_mm)
    nz = g.shape_xyz[2]
    starts = [int(k * (nz - layers) / max(1, n_slabs - 1)) for k in range(n_slabs)]
    source.threads = 1
    source.sample_slab(g, starts[0], starts[0] + 1)        # compile / warm up
    one = 0.0
    cpu_ns = math.inf
    evaluated = 0.0
    for _ in range(repeat):
        n = 0
        occ = 0
        t, c = time.perf_counter(), time.thread_time()
        for z0 in starts:
            _, d = source.sample_slab(g, z0, z0 + layers)
            n += d.size
            occ += int(np.count_nonzero(d))
        wall, cpu = time.perf_counter() - t, time.thread_time() - c
        one = max(one, n / wall)
        cpu_ns = min(cpu_ns, cpu / n * 1e9)
        evaluated = occ / n
    def timed(z0):
        c = time.thread_time()
        d = source.sample_slab(g, z0, z0 + layers)[1]
        return d.size, time.thread_time() - c

    two = 0.0
    two_cpu_ns = math.inf
    with ThreadPoolExecutor(2) as ex:                       # two slabs at once, as a job does
        for _ in range(repeat):
            t = time.perf_counter()
            res = [f.result() for f in [ex.submit(timed, z0) for z0 in starts]]
            n = sum(v for v, _ in res)
            two = max(two, n / (time.perf_counter() - t))
            two_cpu_ns = min(two_cpu_ns, sum(c for _, c in res) / n * 1e9)
    source.threads = 2
    split = 0.0
    for _ in range(repeat):
        t = time.perf_counter()
        n = sum(source.sample_slab(g, z0, z0 + layers)[1].size for z0 in starts)
        split = max(split, n / (time.perf_counter() - t))
    return {"grid": g.shape_xyz, "voxels": n, "evaluated": evaluated, "one": one,
            "cpu_ns": cpu_ns, "two": two, "two_cpu_ns": two_cpu_ns, "split": split}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--height-mm", type=float, default=30.0)
    ap.add_argument("--layers", type=int, default=8)
    ap.add_argument("--slabs", type=int, default=9, help="slabs spread over the height")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--levels", type=int, default=16)
    ap.add_argument("--radius", type=float, default=0.35)
    ap.add_argument("--mean", action="store_true", help="also measure view=mean")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / "bench.ingp"
        occ = write_realistic(p, a.levels, radius=a.radius)
        print(f"snapshot: {p.stat().st_size / 1e6:.1f} MB, {a.levels} levels x 2 features, "
              f"2^19 table, MLPs 64 wide (1 + 2 hidden), occupancy grid {100 * occ:.1f} % "
              "occupied")
        views = ["down"] + (["mean"] if a.mean else [])
        for view in views:
            src = open_source(p, view=view)
            r = measure(src, a.height_mm, a.layers, a.repeat, a.slabs)
            nx, ny, nz = r["grid"]
            print(f"view={view}: print grid {nx} x {ny} x {nz}; {a.slabs} slabs of {a.layers} "
                  f"layers over the height = {r['voxels']:,} voxels, "
                  f"{100 * r['evaluated']:.1f} % evaluated (occupied)")
            ns = 1e9 / r["one"]
            print(f"  1 thread : {r['one'] / 1e6:6.2f} Mvox/s wall ({ns:.1f} ns/voxel); CPU time "
                  f"{r['cpu_ns']:.1f} ns/voxel = {r['cpu_ns'] / max(r['evaluated'], 1e-9):.0f} "
                  "ns per evaluated voxel")
            print(f"  2 threads, one slab per thread (as a job) : {r['two'] / 1e6:6.2f} Mvox/s "
                  "wall; "
                  f"CPU time {r['two_cpu_ns']:.1f} ns/voxel per thread -> "
                  f"{2e3 / r['two_cpu_ns']:.1f} Mvox/s on 2 cores of their own")
            print(f"  2 threads, each slab split (threads=2)    : {r['split'] / 1e6:6.2f} Mvox/s")


if __name__ == "__main__":
    main()
