"""Printable-gamut figures: table build time, accuracy per objective and intent, kernel speed.

Run from the checkout root:
    PYTHONPATH=. .venv/bin/python benchmarks/bench_gamut.py [--size 100]
        [--objective srgb|cielab|de2000|all] [--intent colorimetric|relative|perceptual|all]
Builds every objective x intent in a fresh temporary cache (so each build is really timed
cold), then prints per table: wall and CPU seconds of the build, the cached reload time,
LUT-vs-direct dE2000 at random in-gamut colours (mean, p95), the in-gamut fraction of sRGB, the
lookup-minus-lattice-best dE2000 (300 random sRGB targets vs the best mixture of a 5 % simplex
lattice, through ``mixture.predict``; mean, p95), and the largest dE2000 between the reproduced
colours of neighbouring nodes. Then the fused lookup+alignment kernel's voxels/s on one core and
its sigma error against the exact alignment (first table). The machine is shared: the load
average is printed with every build.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time

import numpy as np

from dreamprint_gui.core.profile import default_profile
from dreamprint_gui.gamut import (
    align_density,
    build_tables,
    get_tables,
    lookup,
    lookup_and_align_into,
)
from dreamprint_gui.gamut.evaluation import objective_figures
from dreamprint_gui.gamut.mapping import INTENTS
from dreamprint_gui.gamut.optimise import OBJECTIVES
from dreamprint_gui.gamut.tables import mixture_sigma


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=100)
    ap.add_argument("--objective", default="all")
    ap.add_argument("--intent", default="all")
    ap.add_argument("--samples", type=int, default=2000)
    args = ap.parse_args()
    profile = default_profile()
    objectives = list(OBJECTIVES) if args.objective == "all" else [args.objective]
    intents = list(INTENTS) if args.intent == "all" else [args.intent]
    for obj in objectives:  # compile the numba kernels outside the timing
        for intent in intents:
            build_tables(profile, obj, 5, intent=intent)
    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}")
    tables = {}
    with tempfile.TemporaryDirectory() as cache:
        for intent in intents:
            for obj in objectives:
                load = os.getloadavg()[0]
                w, c = time.perf_counter(), time.process_time()
                t = get_tables(profile, obj, args.size, cache=cache, intent=intent)
                w, c = time.perf_counter() - w, time.process_time() - c
                w2 = time.perf_counter()
                again = get_tables(profile, obj, args.size, cache=cache, intent=intent)
                w2 = time.perf_counter() - w2
                assert again.cached
                tables[obj, intent] = t
                f = objective_figures(t, profile, args.samples)
                a, g, j = (f["lut_vs_direct_dE2000"], f["lookup_minus_lattice_best_dE2000"],
                           f["adjacent_node_dE2000"])
                tag = f"[{obj}, {intent}]"
                print(f"{tag} build {args.size}^3 cold: {w:.1f} s wall, {c:.1f} s CPU (load "
                      f"average {load:.1f} at start); cached reload {w2 * 1e3:.0f} ms")
                print(f"{tag} LUT vs direct dE2000 ({a['count']} in-gamut of {args.samples}): "
                      f"mean {a['mean']:.4f}, p95 {a['p95']:.4f}, max {a['max']:.4f}; sRGB in "
                      f"gamut {100 * f['srgb_in_gamut_fraction']:.1f} %")
                print(f"{tag} lookup minus lattice-best dE2000 (300 targets, 5 % lattice): "
                      f"mean {g['mean']:+.3f}, p95 {g['p95']:+.3f}, max {g['max']:+.3f}")
                print(f"{tag} neighbouring nodes dE2000: max {j['max']:.3f}, p99.9 "
                      f"{j['p999']:.3f} (targets' own max {j['target_max']:.3f}; largest "
                      f"excess over the targets' jump {j['max_excess']:+.3f}); node dE2000 mean "
                      f"{f['node_dE2000_mean']:.3f}", flush=True)
    t = tables[objectives[0], intents[0]]
    rng = np.random.default_rng(0)
    n = 4_000_000
    rgb = rng.random((n, 3), dtype=np.float32)
    target = np.exp(rng.uniform(np.log(0.1), np.log(60.0), n)).astype(np.float32)
    out = np.empty((n, 6), np.float32)
    lookup_and_align_into(t, rgb[:10], target[:10], out[:10])
    best = min(_timed(lambda: lookup_and_align_into(t, rgb, target, out)) for _ in range(3))
    print(f"lookup_and_align_into, random colours (cache-hostile worst case): {n / best:.3g} "
          f"voxels/s on one core ({n} voxels, {best * 1e3:.0f} ms)")
    # colours of a smooth volume in scan order (neighbouring voxels, neighbouring colours)
    x = np.linspace(0.0, 6.0, n, dtype=np.float32)
    smooth = np.ascontiguousarray(np.stack([0.5 + 0.5 * np.sin(x * 7.0), 0.5 + 0.5 * np.sin(
        x * 11.0 + 1.0), 0.5 + 0.5 * np.sin(x * 3.0 + 2.0)], axis=1).astype(np.float32))
    best = min(_timed(lambda: lookup_and_align_into(t, smooth, target, out)) for _ in range(3))
    print(f"lookup_and_align_into, spatially coherent colours: {n / best:.3g} voxels/s on one "
          f"core")
    m = 20000
    r64 = rgb[:m].astype(np.float64)
    w = time.perf_counter()
    exact = align_density(t, r64, lookup(t, r64), target[:m], profile)
    w = time.perf_counter() - w
    ok = exact.clamped == 0
    lookup_and_align_into(t, rgb[:m], target[:m], out[:m])
    s = mixture_sigma(profile, out[:m].astype(np.float64))
    rel = np.abs(s[ok] - target[:m][ok]) / target[:m][ok]
    print(f"align_density (exact): {m / w:.3g} voxels/s; its sigma error "
          f"{np.max(np.abs(exact.sigma[ok] - target[:m][ok]) / target[:m][ok]):.1e} (max rel)")
    print(f"kernel sigma error vs target (reachable voxels): median {np.median(rel):.2e}, "
          f"p95 {np.percentile(rel, 95):.2e}, max {rel.max():.2e}; clamped low "
          f"{exact.n_clamped_low}, high {exact.n_clamped_high} of {m}")


def _timed(fn) -> float:
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


if __name__ == "__main__":
    main()
