"""Printable-gamut figures: table build time, LUT-vs-direct accuracy, alignment kernel speed.

Run from the checkout root:
    PYTHONPATH=. .venv/bin/python benchmarks/bench_gamut.py [--size 100] [--objective lab|rgb|both]
Builds in a fresh temporary cache (so the build is really timed), then prints wall and CPU
seconds of the build, the cached reload time, LUT-vs-direct dE2000 at random in-gamut colours,
mean node dE2000 per objective, the fused lookup+alignment kernel's voxels/s on one core, and its
sigma error against the exact alignment.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time

import numpy as np

from dreamprint_gui.engine.gamut import (
    align_density,
    build_tables,
    get_tables,
    lookup,
    lookup_and_align_into,
)
from dreamprint_gui.engine.gamut.evaluation import lut_vs_direct
from dreamprint_gui.engine.gamut.tables import mixture_sigma
from dreamprint_gui.engine.profile import default_profile


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=100)
    ap.add_argument("--objective", default="both")
    ap.add_argument("--samples", type=int, default=4000)
    args = ap.parse_args()
    profile = default_profile()
    build_tables(profile, "lab", 5)  # compile the numba kernels outside the timing
    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}")
    objectives = ["lab", "rgb"] if args.objective == "both" else [args.objective]
    tables = {}
    with tempfile.TemporaryDirectory() as cache:
        for obj in objectives:
            w, c = time.perf_counter(), time.process_time()
            t = get_tables(profile, obj, args.size, cache=cache)
            w, c = time.perf_counter() - w, time.process_time() - c
            w2 = time.perf_counter()
            again = get_tables(profile, obj, args.size, cache=cache)
            w2 = time.perf_counter() - w2
            assert again.cached
            tables[obj] = t
            lut, _ = lut_vs_direct(t, profile, args.samples, seed=1)
            print(f"[{obj}] build {args.size}^3: {w:.1f} s wall, {c:.1f} s CPU; cached reload "
                  f"{w2 * 1e3:.0f} ms; node dE2000 mean {t.dE2000.mean():.3f}")
            print(f"[{obj}] LUT vs direct dE2000 ({lut.size} in-gamut of {args.samples}): "
                  f"mean {lut.mean():.4f}, p95 {np.percentile(lut, 95):.4f}, max {lut.max():.4f}")
    t = tables[objectives[0]]
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
