"""Halftoning quality and speed: blue-noise mask vs the paper's i.i.d. stochastic halftoning, and
the lattice test of the mask's tiling.

For constant-concentration blocks on the j850-paper grid (0.084 x 0.028 x 0.014 mm), prints
per ink the variance of its local fraction in boxes about 0.25 mm wide relative to the binomial
variance of i.i.d. sampling (i.i.d. = 1.0, lower is smoother), the mean absolute bias of each
ink's fraction with the i.i.d. standard error for scale, and the kernel speed.

Lattice (always run; ``--no-quality`` runs only it): a uniform smoke-like colour whose magenta
is rare (0.7 %) is halftoned over a block of whole mask tiles, three ways: ``random``
(i.i.d.), ``one shift`` (the mask tiled with one offset for the whole job: the tiling before
per-tile shifts, reproduced here in numpy) and ``blue-noise`` (the job's halftoner: a hashed
shift per tile). For the rare ink's placement (indicator of its voxels) it prints: the power
spectrum at the tile period's fundamentals (harmonic index -1..1 per axis) relative to i.i.d.
placement (whose periodogram is 1 at every frequency, its maximum over these 17 bins ~ 3.5: a
lattice shows as a peak far above); the mean power over all the tile's harmonics relative to
the mean over all frequencies (1 without a lattice: a lattice puts its power there); the
largest number of the ink's voxels of one layer on one residue of the tile period (x mod mx,
y mod my) (i.i.d.: a few); the variance ratio in 0.25 mm and 1 mm boxes (low-frequency noise,
below 1 = below i.i.d.) and the bias of its fraction. ``--picture FILE.png`` draws one layer's
rare-ink voxels of the ``one shift`` and ``blue-noise`` halftones side by side, in mm.

    python benchmarks/bench_halftone.py [--no-quality] [--picture docs/halftone-lattice.png]
"""

from __future__ import annotations

import argparse
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
# Smoke-like colour: magenta (index 1) is the rare ink.
RARE = np.array([0.05, 0.007, 0.03, 0.01, 0.10, 0.803], np.float32)
RARE_INK = 1


def quality() -> None:
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


def one_shift_labels(h: Halftoner, conc: np.ndarray, shape_zyx) -> np.ndarray:
    """The labels of the mask tiled with the halftoner's single seed offset (no per-tile shift):
    the tiling this module replaced, as the reference the lattice test compares against."""
    mz, my, mx = h.mask.shape
    ox, oy, oz = h.offset_xyz
    nz, ny, nx = shape_zyx
    z = (np.arange(nz) + oz) % mz
    y = (np.arange(ny) + oy) % my
    x = (np.arange(nx) + ox) % mx
    t = h.mask[np.ix_(z, y, x)].astype(np.float64) * float(conc.sum())
    order = np.asarray(h.order)
    cum = np.cumsum(conc[order].astype(np.float64))
    return order[np.minimum(np.searchsorted(cum, t, side="right"), 5)].astype(np.uint8)


def lattice_figures(lab: np.ndarray, mask_shape, c: float) -> dict:
    ind = (lab == RARE_INK).astype(np.float64)
    n = ind.size
    nz, ny, nx = ind.shape
    mz, my, mx = mask_shape
    p = np.abs(np.fft.rfftn(ind - ind.mean())) ** 2 / (n * c * (1 - c))  # i.i.d.: 1 everywhere
    fz, fy, fx = nz // mz, ny // my, nx // mx  # FFT bins of the tile fundamental per axis
    harm = p[::fz, ::fy, ::fx].ravel()[1:]  # every tile harmonic but the mean
    low = p[np.ix_([0, fz, -fz], [0, fy, -fy], [0, fx])].ravel()[1:]  # |harmonic| <= 1
    res = np.zeros((my, mx))
    layer = ind[nz // 2]
    for j in range(my):
        for i in range(mx):
            res[j, i] = layer[j::my, i::mx].sum()
    r25, b = fraction_variance_ratio(lab, np.eye(6)[RARE_INK] * c + 0, box_for_voxel(VOX))
    r1, _ = fraction_variance_ratio(lab, np.eye(6)[RARE_INK] * c, box_for_voxel(VOX, 1.0))
    return {"low": float(low.max()), "harm": float(harm.mean() / p.ravel()[1:].mean()),
            "residue": f"{int(res.max())}/{int(layer.sum())}",
            "r25": float(r25[RARE_INK]), "r1": float(r1[RARE_INK]), "bias": float(b[RARE_INK])}


def lattice(picture: str | None) -> None:
    h = Halftoner.create("blue-noise", 7, VOX)
    mz, my, mx = h.mask.shape
    shape = (2 * mz, 4 * my, 8 * mx)  # whole tiles: the tile harmonics fall on FFT bins
    n = int(np.prod(shape))
    c = float(RARE[RARE_INK])
    block = np.broadcast_to(RARE, (*shape, 6))
    print(f"\nlattice: C M Y K W Cl = {[round(float(v), 4) for v in RARE]}, rare ink M "
          f"{100 * c:.1f} %; mask {mx} x {my} x {mz} voxels (x, y, z); block "
          f"{shape[2]} x {shape[1]} x {shape[0]} ({n:,} voxels)")
    print("  method      fundamentals: max power / i.i.d. | all harmonics: mean power / mean "
          "of all frequencies | most on one residue of a layer | var ratio 0.25 mm, 1 mm | bias")
    runs = {"random": Halftoner.create("random", 7, VOX).block(block),
            "one shift": one_shift_labels(h, RARE, shape),
            "blue-noise": h.block(block)}
    for name, lab in runs.items():
        f = lattice_figures(lab, h.mask.shape, c)
        print(f"  {name:10s}  {f['low']:32.2f} | {f['harm']:54.2f} | {f['residue']:>30s} | "
              f"{f['r25']:.3f}, {f['r1']:.3f}        | {f['bias']:+.1e}")
    if picture:
        draw(runs, shape, picture)


def draw(runs: dict, shape, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    nz, ny, nx = shape
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.9), constrained_layout=True)
    for ax, name, title in ((axes[0], "one shift", "before: one mask offset for the job"),
                            (axes[1], "blue-noise", "after: a hashed shift per tile")):
        ys, xs = np.nonzero(runs[name][nz // 2] == RARE_INK)
        ax.scatter((xs + 0.5) * VOX[0], (ys + 0.5) * VOX[1], s=4, c="#c0007a")
        ax.set_xlim(0, nx * VOX[0])
        ax.set_ylim(0, ny * VOX[1])
        ax.set_aspect("equal")
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
        ax.set_title(f"{title}\n(magenta {100 * RARE[RARE_INK]:.1f} %, one layer)")
    fig.savefig(path, dpi=110)
    print(f"  picture: {path}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--no-quality", action="store_true", help="only the lattice test")
    ap.add_argument("--picture", default=None, help="PNG of one layer before/after")
    a = ap.parse_args()
    if not a.no_quality:
        quality()
    lattice(a.picture)


if __name__ == "__main__":
    main()
