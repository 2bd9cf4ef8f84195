"""Halftoning quality and speed: blue-noise mask vs the paper's i.i.d. stochastic halftoning.

For constant-concentration blocks on the j850-paper grid (0.084 x 0.028 x 0.014 mm), prints
per ink the variance of its local fraction in boxes about 0.25 mm wide relative to the binomial
variance of i.i.d. sampling (i.i.d. = 1.0, lower is smoother), the mean absolute bias of each
ink's fraction with the i.i.d. standard error for scale, and the kernel speed.

    python benchmarks/bench_halftone.py
"""

from __future__ import annotations

import time

import numpy as np

from dreamprint_gui.job.halftone import Halftoner, box_for_voxel, fraction_variance_ratio

VOX = (0.084, 0.028, 0.014)
CASES = {
    "mixed": [0.10, 0.20, 0.05, 0.02, 0.13, 0.50],
    "two inks 50/50": [0.5, 0, 0, 0, 0, 0.5],
    "cloud (mostly Clear)": [0.02, 0.01, 0.03, 0.005, 0.015, 0.92],
    "grey (K/W)": [0, 0, 0, 0.3, 0.7, 0],
}


def main() -> None:
    box = box_for_voxel(VOX)
    shape = (144, 144, 48)  # (z, y, x): 2.0 x 4.0 x 4.0 mm
    n = int(np.prod(shape))
    print(f"block {shape[2]} x {shape[1]} x {shape[0]} voxels (x, y, z), box {box[::-1]} voxels"
          " (x, y, z) ~ 0.25 mm")
    for name, conc in CASES.items():
        c = np.array(conc, np.float32)
        block = np.broadcast_to(c, (*shape, 6))
        print(f"\n{name}: C M Y K W Cl = {conc}")
        for method in ("random", "blue-noise"):
            h = Halftoner.create(method, 7, VOX)
            h.block(block[:2])  # compile
            t = time.perf_counter()
            lab = h.block(block)
            dt = time.perf_counter() - t
            ratio, bias = fraction_variance_ratio(lab, c, box)
            se = np.sqrt(c * (1 - c) / n)
            used = c > 0
            print(f"  {method:10s} variance ratio per ink "
                  + " ".join("  -  " if np.isnan(r) else f"{r:5.3f}" for r in ratio)
                  + f" | mean |bias| {np.abs(bias[used]).mean():.1e} (i.i.d. s.e. "
                  f"{se[used].mean():.1e}) | {n / dt / 1e6:.0f} Mvox/s")


if __name__ == "__main__":
    main()
