"""Ink concentrations that reproduce target colours (paper eq. 10), solved for many targets at once.

Defines
-------
- :data:`OBJECTIVES`: ``"rgb"`` (paper eq. 10: squared distance of gamma-encoded, unclipped sRGB)
  and ``"lab"`` (squared CIELAB distance, i.e. dE76; for out-of-gamut targets its minimum is the
  closest printable colour in CIELAB, the table's gamut-mapping policy).
- :func:`solve`: for targets (N, 3) and starts (N, 5), the concentrations of C, M, Y, K, W on the
  simplex (``sum = 1``, ``c >= 0``; Clear excluded, eq. 10's constraint) minimising the objective.
- :func:`solve_grid`: the whole n^3 sRGB cube, coarse to fine (multi-start on a 5^3 grid, then
  each finer level warm-started by trilinear interpolation of the previous one).

Method: Levenberg-Marquardt (projected Gauss-Newton) per target, each step a small quadratic
programme on the simplex solved exactly by a primal active-set method; compiled with numba and
run in parallel over targets (``prange``). A tiny Tikhonov term ``lam * |c|^2`` picks, among the
mixtures of equal colour (5 inks, 3 colour constraints), the most evenly spread one, so that the
table is a smooth function of the colour and trilinear interpolation between nodes stays accurate.
"""

from __future__ import annotations

from collections.abc import Callable

import numba as nb
import numpy as np
from numpy.typing import NDArray

from .forward import (
    N_COLOUR_INKS,
    ForwardModel,
    spectrum_xyz_jac,
    xyz_to_lab_jac,
    xyz_to_srgb_jac,
)

__all__ = ["OBJECTIVES", "REGULARISATION", "solve", "solve_grid", "targets_for", "resample"]

OBJECTIVES: tuple[str, ...] = ("rgb", "lab")
# Tikhonov weight per objective, in the objective's squared units: 1e-4 dE^2 for CIELAB, the
# same relative weight for sRGB (whose unit range is ~1/100 of CIELAB's).
REGULARISATION = {"lab": 1e-4, "rgb": 1e-8}


@nb.njit(cache=True)
def _solve_linear(A, b, n):
    """Solve A[:n,:n] x = b[:n] in place (Gaussian elimination, partial pivoting); x in b."""
    for k in range(n):
        p = k
        big = abs(A[k, k])
        for i in range(k + 1, n):
            if abs(A[i, k]) > big:
                big = abs(A[i, k])
                p = i
        if big < 1e-300:
            return False
        if p != k:
            for j in range(n):
                A[k, j], A[p, j] = A[p, j], A[k, j]
            b[k], b[p] = b[p], b[k]
        for i in range(k + 1, n):
            f = A[i, k] / A[k, k]
            for j in range(k, n):
                A[i, j] -= f * A[k, j]
            b[i] -= f * b[k]
    for k in range(n - 1, -1, -1):
        s = b[k]
        for j in range(k + 1, n):
            s -= A[k, j] * b[j]
        b[k] = s / A[k, k]
    return True


@nb.njit(cache=True)
def _simplex_qp(H, g, c, d, active, A, rhs, free_idx):
    """min 1/2 d'Hd + g'd  s.t. sum(d) = 0, c + d >= 0 (primal active set, feasible start d=0)."""
    n = c.shape[0]
    for i in range(n):
        d[i] = 0.0
    for _ in range(4 * n + 4):
        nf = 0
        for i in range(n):
            if not active[i]:
                free_idx[nf] = i
                nf += 1
        # q = H d + g
        # KKT on the free set: H_FF p + nu 1 = -q_F, sum p = 0
        m = nf + 1
        for a in range(m):
            for b in range(m):
                A[a, b] = 0.0
        for a in range(nf):
            ia = free_idx[a]
            q = g[ia]
            for j in range(n):
                q += H[ia, j] * d[j]
            rhs[a] = -q
            for b in range(nf):
                A[a, b] = H[ia, free_idx[b]]
            A[a, nf] = 1.0
            A[nf, a] = 1.0
        rhs[nf] = 0.0
        if not _solve_linear(A, rhs, m):
            return
        nu = rhs[nf]
        alpha = 1.0
        block = -1
        for a in range(nf):
            i = free_idx[a]
            p = rhs[a]
            if p < 0.0:
                room = c[i] + d[i]
                if room + alpha * p < 0.0:
                    alpha = max(room / -p, 0.0)
                    block = i
        for a in range(nf):
            d[free_idx[a]] += alpha * rhs[a]
        if block >= 0:
            d[block] = -c[block]
            active[block] = True
            continue
        # full step: release the active bound with the most negative multiplier, if any
        worst = -1
        lam_min = -1e-14
        for i in range(n):
            if active[i]:
                q = g[i]
                for j in range(n):
                    q += H[i, j] * d[j]
                lam = q + nu
                if lam < lam_min:
                    lam_min = lam
                    worst = i
        if worst < 0:
            return
        active[worst] = False


@nb.njit(cache=True)
def _residual(c, target, objective, K, S, W, t, white, M, xyz, jx, tmp, col, J, r):
    spectrum_xyz_jac(c, K, S, W, t, xyz, jx, tmp)
    if objective == 0:
        xyz_to_srgb_jac(xyz, jx, M, col, J)
    else:
        xyz_to_lab_jac(xyz, jx, white, col, J)
    cost = 0.0
    for a in range(3):
        r[a] = col[a] - target[a]
        cost += r[a] * r[a]
    return cost


@nb.njit(cache=True, parallel=True)
def _solve_many(targets, starts, objective, lam, max_iter, K, S, W, t, white, M,
                out, cost_out, iters_out):
    n_targets = targets.shape[0]
    n = K.shape[0]
    for k in nb.prange(n_targets):
        xyz = np.empty(3)
        jx = np.empty((3, n))
        tmp = np.empty(n)
        col = np.empty(3)
        J = np.empty((3, n))
        r = np.empty(3)
        J2 = np.empty((3, n))
        r2 = np.empty(3)
        H = np.empty((n, n))
        g = np.empty(n)
        d = np.empty(n)
        active = np.zeros(n, dtype=np.bool_)
        A = np.empty((n + 1, n + 1))
        rhs = np.empty(n + 1)
        free_idx = np.empty(n, dtype=np.int64)
        c = np.empty(n)
        trial = np.empty(n)
        target = targets[k]
        # project the start onto the simplex (clip, renormalise)
        tot = 0.0
        for i in range(n):
            c[i] = max(starts[k, i], 0.0)
            tot += c[i]
        for i in range(n):
            c[i] = c[i] / tot if tot > 0 else 1.0 / n
        f = _residual(c, target, objective, K, S, W, t, white, M, xyz, jx, tmp, col, J, r)
        for i in range(n):
            f += lam * c[i] * c[i]
        mu = -1.0
        it = 0
        while it < max_iter:
            it += 1
            for i in range(n):
                gi = lam * c[i]
                for a in range(3):
                    gi += J[a, i] * r[a]
                g[i] = gi
                for j in range(n):
                    h = 0.0
                    for a in range(3):
                        h += J[a, i] * J[a, j]
                    H[i, j] = h
            if mu < 0.0:
                dmax = 0.0
                for i in range(n):
                    dmax = max(dmax, H[i, i])
                mu = 1e-6 * dmax + 1e-12
            for i in range(n):
                H[i, i] += lam + mu
                active[i] = c[i] <= 0.0
            _simplex_qp(H, g, c, d, active, A, rhs, free_idx)
            step = 0.0
            tot = 0.0
            for i in range(n):
                trial[i] = max(c[i] + d[i], 0.0)
                tot += trial[i]
                step = max(step, abs(d[i]))
            for i in range(n):
                trial[i] /= tot
            f2 = _residual(trial, target, objective, K, S, W, t, white, M,
                           xyz, jx, tmp, col, J2, r2)
            for i in range(n):
                f2 += lam * trial[i] * trial[i]
            if f2 <= f:
                converged = (f - f2) <= 1e-13 * (1.0 + f) or step < 1e-10
                f = f2
                for i in range(n):
                    c[i] = trial[i]
                for a in range(3):
                    r[a] = r2[a]
                    for i in range(n):
                        J[a, i] = J2[a, i]
                mu = max(mu * 0.2, 1e-15)
                if converged:
                    break
            else:
                mu *= 8.0
                if step < 1e-12 or mu > 1e12:
                    break
        for i in range(n):
            out[k, i] = c[i]
        cost_out[k] = f
        iters_out[k] = it


def targets_for(model: ForwardModel, objective: str, rgb: NDArray) -> NDArray[np.float64]:
    """The objective's target coordinates (sRGB itself or CIELAB) of encoded sRGB colours."""
    rgb = np.asarray(rgb, dtype=np.float64)
    if objective == "rgb":
        return rgb
    if objective == "lab":
        import colour

        lin = colour.models.eotf_sRGB(rgb)
        xyz = lin @ np.linalg.inv(model.xyz_to_rgb).T
        return colour.XYZ_to_Lab(xyz, illuminant=colour.XYZ_to_xy(model.white))
    raise ValueError(f"unknown objective {objective!r}; choose one of {OBJECTIVES}")


def solve(model: ForwardModel, objective: str, rgb: NDArray, starts: NDArray,
          max_iter: int = 60) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray]:
    """Concentrations (N, 5) minimising the objective for encoded sRGB targets ``rgb`` (N, 3).

    Returns ``(conc, cost, iterations)``; ``cost`` includes the small regularisation term.
    """
    tgt = np.ascontiguousarray(targets_for(model, objective, rgb).reshape(-1, 3))
    st = np.ascontiguousarray(np.asarray(starts, dtype=np.float64).reshape(-1, N_COLOUR_INKS))
    st = np.broadcast_to(st, (tgt.shape[0], N_COLOUR_INKS)).copy()
    out = np.empty_like(st)
    cost = np.empty(tgt.shape[0])
    iters = np.empty(tgt.shape[0], dtype=np.int64)
    _solve_many(tgt, st, 0 if objective == "rgb" else 1, REGULARISATION[objective], max_iter,
                model.K, model.S, model.weights, model.thickness_mm, model.white,
                model.xyz_to_rgb, out, cost, iters)
    return out, cost, iters


def _starts() -> NDArray[np.float64]:
    """Multi-start set for the coarsest level: the centre and each ink dominant."""
    s = [np.full(N_COLOUR_INKS, 1.0 / N_COLOUR_INKS)]
    for i in range(N_COLOUR_INKS):
        e = np.full(N_COLOUR_INKS, 0.4 / (N_COLOUR_INKS - 1))
        e[i] = 0.6
        s.append(e)
    return np.asarray(s)


def _grid_rgb(n: int) -> NDArray[np.float64]:
    a = np.linspace(0.0, 1.0, n)
    return np.stack(np.meshgrid(a, a, a, indexing="ij"), axis=-1)


def resample(conc: NDArray, n_new: int) -> NDArray[np.float64]:
    """Trilinear resampling of a (n, n, n, 5) table onto an n_new^3 grid of the same cube."""
    n = conc.shape[0]
    x = np.linspace(0.0, n - 1, n_new)
    i0 = np.minimum(np.floor(x).astype(int), n - 2)
    f = x - i0
    out = conc
    for axis in range(3):
        a = np.take(out, i0, axis=axis)
        b = np.take(out, i0 + 1, axis=axis)
        shape = [1, 1, 1, 1]
        shape[axis] = n_new
        w = f.reshape(shape)
        out = a * (1.0 - w) + b * w
    return out


def solve_grid(model: ForwardModel, objective: str, size: int,
               progress: Callable[[float], None] | None = None
               ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The n^3 table: concentrations (n, n, n, 5) and objective cost per node (coarse to fine)."""
    levels = [5]
    while levels[-1] * 2 - 1 < size:
        levels.append(levels[-1] * 2 - 1)
    levels.append(size)
    levels = sorted(set(levels))
    work = np.array([lv ** 3 for lv in levels], dtype=float)
    work[0] *= 6
    done = 0.0
    conc = cost = None
    for lv in levels:
        rgb = _grid_rgb(lv).reshape(-1, 3)
        if conc is None:
            best_c = best_f = None
            for s in _starts():
                c, f, _ = solve(model, objective, rgb, s, max_iter=200)
                if best_c is None:
                    best_c, best_f = c, f
                else:
                    better = f < best_f
                    best_c[better], best_f[better] = c[better], f[better]
            conc, cost = best_c, best_f
        else:
            n_prev = round(conc.shape[0] ** (1 / 3))
            start = resample(conc.reshape(n_prev, n_prev, n_prev, N_COLOUR_INKS), lv)
            # Warm starts converge in a few steps; the cap only stops the slow (linear) tail
            # of far-out-of-gamut targets, whose cost it changes by < 0.1 dE76.
            conc, cost, _ = solve(model, objective, rgb, start.reshape(-1, N_COLOUR_INKS),
                                  max_iter=12 if lv == size else 40)
        done += work[levels.index(lv)]
        if progress is not None:
            progress(0.8 * done / work.sum())
    return conc.reshape(size, size, size, N_COLOUR_INKS), cost.reshape(size, size, size)
