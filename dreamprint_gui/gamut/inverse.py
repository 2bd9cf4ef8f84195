"""The inverse of a print: for target colours, the device RGB whose print is nearest (issue 48).

Defines :func:`nearest_rgb`, which the ICC profile's B2A tables and gamut tag are built from.

Method, for targets ``t`` (media-relative PCS CIELAB, :class:`.print_pcs.PrintPCS`) and the
print ``f(rgb)`` (media-relative CIELAB of the print of ``rgb``):

1. Start: ``f`` on an m^3 lattice of the RGB cube; for each target the ``k`` lattice colours
   nearest in CIELAB (a k-d tree, scipy's ``cKDTree``) and, of those, the one of smallest
   CIEDE2000 to the target.
2. Refine: Levenberg-Marquardt on the CIELAB residual ``f(rgb) - t`` inside the cube (Jacobian
   by forward differences of ``f``, each step clipped to [0, 1]^3, damping raised on a
   rejected step, lowered on an accepted one). A refined RGB replaces the start only where its
   CIEDE2000 to the target is smaller: in gamut both metrics reach 0 together; outside, the
   result stays the CIEDE2000-nearest of the two.

The print ``f`` is many-to-one (every RGB outside the printable gamut prints a colour on its
boundary), so the RGB returned is *a* nearest one; the lattice start makes it deterministic.
Hand-written: scipy's ``least_squares`` solves one problem per call, which would mean a Python
loop over the 10^4-10^5 targets of a profile; this vectorises the same damped Gauss-Newton step
over all of them (a 33^3 B2A table: about 3 s).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from dreamprint_gui.physics.colorimetry import delta_E2000

__all__ = ["nearest_rgb"]

_H = 1e-4  # forward-difference step in RGB


def nearest_rgb(forward: Callable[[NDArray], NDArray], targets: NDArray, lattice: int = 33,
                k: int = 12, iterations: int = 12,
                progress: Callable[[int, int], None] | None = None
                ) -> tuple[NDArray[np.float64], NDArray]:
    """(rgb (N, 3), dE2000 (N,) of its print to the target) for CIELAB targets (N, 3);
    ``forward`` maps RGB (M, 3) to CIELAB (M, 3) (module doc). ``progress(i, iterations)``
    after each refining iteration (an ICC profile's 33^3 B2A: about 0.1 s each, 1 s under
    load)."""
    from scipy.spatial import cKDTree

    t = np.asarray(targets, dtype=np.float64).reshape(-1, 3)
    a = np.linspace(0.0, 1.0, lattice)
    grid = np.stack(np.meshgrid(a, a, a, indexing="ij"), axis=-1).reshape(-1, 3)
    lab_grid = forward(grid)
    _, idx = cKDTree(lab_grid).query(t, k=k)
    de = delta_E2000(lab_grid[idx], t[:, None, :])
    best = np.argmin(de, axis=1)
    rgb = grid[idx[np.arange(len(t)), best]]
    de_start = de[np.arange(len(t)), best]

    x = rgb.copy()
    r = forward(x) - t
    cost = np.einsum("ni,ni->n", r, r)
    lam = np.full(len(t), 1e-3)
    active = cost > 1e-10
    for it in range(iterations):
        if progress is not None and it:
            progress(it, iterations)
        ia = np.flatnonzero(active)
        if ia.size == 0:
            break
        xa, ra = x[ia], r[ia]
        jac = np.empty((ia.size, 3, 3))
        for j in range(3):
            step = np.where(xa[:, j] + _H <= 1.0, _H, -_H)
            xs = xa.copy()
            xs[:, j] += step
            jac[:, :, j] = (forward(xs) - t[ia] - ra) / step[:, None]
        jtj = np.einsum("nki,nkj->nij", jac, jac)
        jtr = np.einsum("nki,nk->ni", jac, ra)
        diag = np.einsum("nii->ni", jtj)
        a_mat = jtj + (lam[ia, None] * np.maximum(diag, 1e-9))[:, :, None] * np.eye(3)
        try:
            delta = np.linalg.solve(a_mat, -jtr[:, :, None])[:, :, 0]
        except np.linalg.LinAlgError:
            delta = np.zeros_like(xa)
        xn = np.clip(xa + delta, 0.0, 1.0)
        rn = forward(xn) - t[ia]
        cn = np.einsum("ni,ni->n", rn, rn)
        better = cn < cost[ia]
        ib = ia[better]
        x[ib], r[ib], cost[ib] = xn[better], rn[better], cn[better]
        lam[ib] = np.maximum(lam[ib] * 0.3, 1e-7)
        lam[ia[~better]] *= 10.0
        # done: matched, stalled (no step moves it) or damped to a standstill
        active[ia] = (cost[ia] > 1e-10) & (lam[ia] < 1e4) & (
            better | (np.abs(delta).max(axis=1) > 1e-7))
    de_refined = delta_E2000(r + t, t)
    use = de_refined < de_start
    rgb[use] = x[use]
    return rgb, np.where(use, de_refined, de_start)
