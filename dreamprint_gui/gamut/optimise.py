"""Ink concentrations that reproduce target colours (paper eq. 10), solved for many targets at once.

Defines
-------
- :data:`OBJECTIVES`: ``"srgb"`` (paper eq. 10: squared distance of gamma-encoded, unclipped
  sRGB), ``"cielab"`` (squared CIELAB distance, i.e. dE76^2) and ``"de2000"`` (squared CIEDE2000,
  Sharma, Wu & Dalal 2005, written as a 3-vector residual ``r`` with ``|r|^2 = dE00^2``, see
  :func:`de2000_residual`). For an out-of-gamut target the minimum is the closest printable
  colour in that metric (the ``colorimetric`` intent). :data:`ALIASES`: the former names
  ``"rgb"``, ``"lab"``; :func:`canonical_objective` maps them.
- :func:`solve`, :func:`solve_xyz`: for targets (N, 3) (encoded sRGB, or XYZ) and starts (N, 5),
  the concentrations of C, M, Y, K, W on the simplex (``sum = 1``, ``c >= 0``; Clear excluded,
  eq. 10's constraint) minimising the objective.
- :func:`solve_grid`: the whole n^3 sRGB cube, coarse to fine (multi-start on a 5^3 grid, then
  each finer level warm-started by trilinear interpolation of the previous one).

Method: Levenberg-Marquardt (projected Gauss-Newton) per target, each step a small quadratic
programme on the simplex solved exactly by a primal active-set method; compiled with numba and
run in parallel over targets (``prange``). A tiny Tikhonov term ``lam * |c|^2`` picks, among the
mixtures of equal colour (5 inks, 3 colour constraints), the most evenly spread one, so that the
table is a smooth function of the colour and interpolation between nodes stays accurate.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numba as nb
import numpy as np
from numpy.typing import NDArray

from dreamprint_gui.gamut.forward import (
    N_COLOUR_INKS,
    ForwardModel,
    spectrum_xyz_jac,
    xyz_to_lab_jac,
    xyz_to_srgb_jac,
)

__all__ = ["OBJECTIVES", "ALIASES", "REGULARISATION", "canonical_objective", "solve",
           "solve_xyz", "solve_grid", "targets_for", "target_coords", "resample",
           "de2000_residual", "srgb_to_xyz"]

OBJECTIVES: tuple[str, ...] = ("srgb", "cielab", "de2000")
ALIASES = {"rgb": "srgb", "lab": "cielab"}
_CODE = {"srgb": 0, "cielab": 1, "de2000": 2}
# Tikhonov weight per objective, in the objective's squared units: 1e-4 dE^2 for CIELAB and
# CIEDE2000, the same relative weight for sRGB (whose unit range is ~1/100 of CIELAB's).
REGULARISATION = {"cielab": 1e-4, "de2000": 1e-4, "srgb": 1e-8}
# targets this close to grey get the cielab alternative start in the table's final level
NEUTRAL_CHROMA = 10.0
# solve_grid solves a level in pieces of this many nodes and reports progress after each (the
# 100^3 table's last level is 1e6 nodes, tens of seconds: 16 pieces; a piece keeps both cores busy)
GRID_CHUNK = 65536
_DEG = math.pi / 180.0
_25_7 = 25.0 ** 7


def canonical_objective(objective: str | None, default: str) -> str:
    """The objective's canonical name (``None``: ``default``; ``rgb``/``lab`` are aliases)."""
    name = default if objective is None else ALIASES.get(objective, objective)
    if name not in OBJECTIVES:
        raise ValueError(f"unknown objective {objective!r}; choose one of {OBJECTIVES}")
    return name


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
def de2000_residual(lab1, lab2, r):
    """CIEDE2000 of reference ``lab1`` and sample ``lab2`` as a residual 3-vector ``r``.

    Sharma, Wu & Dalal (2005), eqs. 1-22 with k_L = k_C = k_H = 1: with t_L = dL'/S_L,
    t_C = dC'/S_C, t_H = dH'/S_H, dE00^2 = t_L^2 + t_C^2 + t_H^2 + R_T t_C t_H. Since
    |R_T| <= 2, the quadratic form factors (Cholesky) as
    ``r = (t_L, t_C + R_T t_H / 2, sqrt(1 - R_T^2 / 4) t_H)``, so ``|r|^2 = dE00^2`` and a
    Gauss-Newton solver can minimise it like any least-squares residual. Returns dE00^2.
    """
    L1, a1, b1 = lab1[0], lab1[1], lab1[2]
    L2, a2, b2 = lab2[0], lab2[1], lab2[2]
    cb = 0.5 * (math.sqrt(a1 * a1 + b1 * b1) + math.sqrt(a2 * a2 + b2 * b2))
    cb7 = cb ** 7
    g = 0.5 * (1.0 - math.sqrt(cb7 / (cb7 + _25_7)))
    a1p = (1.0 + g) * a1
    a2p = (1.0 + g) * a2
    c1p = math.sqrt(a1p * a1p + b1 * b1)
    c2p = math.sqrt(a2p * a2p + b2 * b2)
    h1p = 0.0 if (a1p == 0.0 and b1 == 0.0) else math.atan2(b1, a1p) % (2.0 * math.pi)
    h2p = 0.0 if (a2p == 0.0 and b2 == 0.0) else math.atan2(b2, a2p) % (2.0 * math.pi)
    dl = L2 - L1
    dc = c2p - c1p
    cc = c1p * c2p
    if cc == 0.0:
        dh = 0.0
    else:
        dh = h2p - h1p
        if dh > math.pi:
            dh -= 2.0 * math.pi
        elif dh < -math.pi:
            dh += 2.0 * math.pi
    dH = 2.0 * math.sqrt(cc) * math.sin(0.5 * dh)
    lb = 0.5 * (L1 + L2)
    cbp = 0.5 * (c1p + c2p)
    if cc == 0.0:
        hb = h1p + h2p
    elif abs(h1p - h2p) <= math.pi:
        hb = 0.5 * (h1p + h2p)
    elif h1p + h2p < 2.0 * math.pi:
        hb = 0.5 * (h1p + h2p + 2.0 * math.pi)
    else:
        hb = 0.5 * (h1p + h2p - 2.0 * math.pi)
    T = (1.0 - 0.17 * math.cos(hb - 30.0 * _DEG) + 0.24 * math.cos(2.0 * hb)
         + 0.32 * math.cos(3.0 * hb + 6.0 * _DEG) - 0.20 * math.cos(4.0 * hb - 63.0 * _DEG))
    dtheta = 30.0 * _DEG * math.exp(-(((hb / _DEG) - 275.0) / 25.0) ** 2)
    cbp7 = cbp ** 7
    rc = 2.0 * math.sqrt(cbp7 / (cbp7 + _25_7))
    l50 = (lb - 50.0) ** 2
    sl = 1.0 + 0.015 * l50 / math.sqrt(20.0 + l50)
    sc = 1.0 + 0.045 * cbp
    sh = 1.0 + 0.015 * cbp * T
    rt = -math.sin(2.0 * dtheta) * rc
    tl = dl / sl
    tc = dc / sc
    th = dH / sh
    r[0] = tl
    r[1] = tc + 0.5 * rt * th
    r[2] = math.sqrt(max(1.0 - 0.25 * rt * rt, 0.0)) * th
    return r[0] * r[0] + r[1] * r[1] + r[2] * r[2]


@nb.njit(cache=True)
def _de2000_jac(target, lab, jlab, r, J, scratch):
    """r = de2000_residual(target, lab); J = dr/dLab (central differences) @ jlab."""
    cost = de2000_residual(target, lab, r)
    probe = scratch[0]
    rp = scratch[1]
    rm = scratch[2]
    D = scratch[3:6]
    h = 1e-5
    for b in range(3):
        for a in range(3):
            probe[a] = lab[a]
        probe[b] = lab[b] + h
        de2000_residual(target, probe, rp)
        probe[b] = lab[b] - h
        de2000_residual(target, probe, rm)
        for a in range(3):
            D[a, b] = (rp[a] - rm[a]) / (2.0 * h)
    for a in range(3):
        for i in range(J.shape[1]):
            J[a, i] = D[a, 0] * jlab[0, i] + D[a, 1] * jlab[1, i] + D[a, 2] * jlab[2, i]
    return cost


@nb.njit(cache=True)
def _residual(c, target, objective, K, S, W, t, white, M, xyz, jx, tmp, col, J, r, jl,
              scratch):
    spectrum_xyz_jac(c, K, S, W, t, xyz, jx, tmp)
    if objective == 0:
        xyz_to_srgb_jac(xyz, jx, M, col, J)
    elif objective == 2:
        xyz_to_lab_jac(xyz, jx, white, col, jl)
        return _de2000_jac(target, col, jl, r, J, scratch)
    else:
        xyz_to_lab_jac(xyz, jx, white, col, J)
    cost = 0.0
    for a in range(3):
        r[a] = col[a] - target[a]
        cost += r[a] * r[a]
    return cost


@nb.njit(cache=True, parallel=True)
def _solve_many(targets, starts, alt, objective, lam, max_iter, K, S, W, t, white, M,
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
        jl = np.empty((3, n))
        scratch = np.empty((6, 3))
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
        f = _residual(c, target, objective, K, S, W, t, white, M, xyz, jx, tmp, col, J, r,
                      jl, scratch)
        for i in range(n):
            f += lam * c[i] * c[i]
        if alt.shape[0] > 0:  # a second start: keep the one of lower cost
            tot = 0.0
            for i in range(n):
                trial[i] = max(alt[k, i], 0.0)
                tot += trial[i]
            for i in range(n):
                trial[i] = trial[i] / tot if tot > 0 else 1.0 / n
            f2 = _residual(trial, target, objective, K, S, W, t, white, M,
                           xyz, jx, tmp, col, J2, r2, jl, scratch)
            for i in range(n):
                f2 += lam * trial[i] * trial[i]
            if f2 < f:
                f = f2
                for i in range(n):
                    c[i] = trial[i]
                for a in range(3):
                    r[a] = r2[a]
                    for i in range(n):
                        J[a, i] = J2[a, i]
        mu = -1.0
        it = 0
        while it < max_iter:
            # CIEDE2000 is a cone (not smooth) at its zero: once the colour is matched to
            # 1e-5 dE00 there is nothing left to gain, and LM would only reject steps
            if objective == 2 and r[0] * r[0] + r[1] * r[1] + r[2] * r[2] < 1e-10:
                break
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
                           xyz, jx, tmp, col, J2, r2, jl, scratch)
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


def srgb_to_xyz(model: ForwardModel, rgb: NDArray) -> NDArray[np.float64]:
    """XYZ (white Y = 1) of encoded sRGB (IEC 61966-2-1), the inverse of ``mixtures_srgb``."""
    import colour

    lin = colour.models.eotf_sRGB(np.asarray(rgb, dtype=np.float64))
    return lin @ np.linalg.inv(model.xyz_to_rgb).T


def target_coords(model: ForwardModel, objective: str, xyz: NDArray) -> NDArray[np.float64]:
    """The objective's target coordinates of XYZ colours: encoded sRGB or CIELAB."""
    import colour

    objective = canonical_objective(objective, "cielab")
    xyz = np.asarray(xyz, dtype=np.float64)
    if objective == "srgb":
        return colour.models.eotf_inverse_sRGB(xyz @ model.xyz_to_rgb.T)
    return colour.XYZ_to_Lab(xyz, illuminant=colour.XYZ_to_xy(model.white))


def targets_for(model: ForwardModel, objective: str, rgb: NDArray) -> NDArray[np.float64]:
    """The objective's target coordinates (sRGB itself or CIELAB) of encoded sRGB colours."""
    rgb = np.asarray(rgb, dtype=np.float64)
    if canonical_objective(objective, "cielab") == "srgb":
        return rgb
    return target_coords(model, "cielab", srgb_to_xyz(model, rgb))


def _solve_coords(model: ForwardModel, objective: str, tgt: NDArray, starts: NDArray,
                  max_iter: int, alt: NDArray | None = None
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray]:
    tgt = np.ascontiguousarray(np.asarray(tgt, dtype=np.float64).reshape(-1, 3))
    st = np.ascontiguousarray(np.asarray(starts, dtype=np.float64).reshape(-1, N_COLOUR_INKS))
    st = np.broadcast_to(st, (tgt.shape[0], N_COLOUR_INKS)).copy()
    alt = (np.empty((0, N_COLOUR_INKS)) if alt is None
           else np.ascontiguousarray(alt, dtype=np.float64).reshape(-1, N_COLOUR_INKS))
    out = np.empty_like(st)
    cost = np.empty(tgt.shape[0])
    iters = np.empty(tgt.shape[0], dtype=np.int64)
    _solve_many(tgt, st, alt, _CODE[objective], REGULARISATION[objective], max_iter,
                model.K, model.S, model.weights, model.thickness_mm, model.white,
                model.xyz_to_rgb, out, cost, iters)
    return out, cost, iters


def _de2000_polished(model: ForwardModel, lab: NDArray, starts: NDArray, max_iter: int,
                     polish: bool | float, polish_iter: int | None
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray]:
    lab = np.asarray(lab, dtype=np.float64).reshape(-1, 3)
    st = np.broadcast_to(np.asarray(starts, dtype=np.float64).reshape(-1, N_COLOUR_INKS),
                         (lab.shape[0], N_COLOUR_INKS))
    alt = None
    if polish is not False:
        mask = (np.ones(lab.shape[0], dtype=bool) if polish is True
                else np.hypot(lab[:, 1], lab[:, 2]) < float(polish))
        alt = st.copy()
        if mask.any():
            alt[mask] = _solve_coords(model, "cielab", lab[mask], st[mask],
                                      polish_iter or max_iter)[0]
    return _solve_coords(model, "de2000", lab, st, max_iter, alt)


def solve(model: ForwardModel, objective: str, rgb: NDArray, starts: NDArray,
          max_iter: int = 60, polish: bool | float = True, polish_iter: int | None = None
          ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray]:
    """Concentrations (N, 5) minimising the objective for encoded sRGB targets ``rgb`` (N, 3).

    Returns ``(conc, cost, iterations)``; ``cost`` includes the small regularisation term.
    ``de2000`` is solved as a polishing step: first ``cielab`` from ``starts``, then CIEDE2000
    from whichever of ``starts`` and that solution has the lower CIEDE2000 (CIEDE2000 is not
    smooth at neutral colours, where Gauss-Newton converges slowly from far away).
    ``polish``: True for every target, a number for the targets of CIELAB chroma below it
    only, False for none; ``polish_iter`` caps the ``cielab`` iterations (default
    ``max_iter``).
    """
    objective = canonical_objective(objective, "cielab")
    tgt = targets_for(model, objective, rgb)
    if objective == "de2000":
        return _de2000_polished(model, tgt, starts, max_iter, polish, polish_iter)
    return _solve_coords(model, objective, tgt, starts, max_iter)


def solve_xyz(model: ForwardModel, objective: str, xyz: NDArray, starts: NDArray,
              max_iter: int = 60, polish: bool | float = True, polish_iter: int | None = None
              ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray]:
    """As :func:`solve` for targets given as XYZ (e.g. gamut-mapped colours)."""
    objective = canonical_objective(objective, "cielab")
    tgt = target_coords(model, objective, xyz)
    if objective == "de2000":
        return _de2000_polished(model, tgt, starts, max_iter, polish, polish_iter)
    return _solve_coords(model, objective, tgt, starts, max_iter)


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
               progress: Callable[[float], None] | None = None,
               target_xyz: Callable[[NDArray], NDArray] | None = None
               ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The n^3 table: concentrations (n, n, n, 5) and objective cost per node (coarse to fine).

    ``target_xyz(rgb)`` gives the XYZ each node reproduces (a rendering intent's gamut mapping);
    default: the node's own sRGB colour.
    """
    objective = canonical_objective(objective, "cielab")

    levels = [5]
    while levels[-1] * 2 - 1 < size:
        levels.append(levels[-1] * 2 - 1)
    levels.append(size)
    levels = sorted(set(levels))
    work = np.array([lv ** 3 for lv in levels], dtype=float)
    work[0] *= 6
    done = 0.0

    def run(rgb, starts, max_iter, polish: bool | float = True, polish_iter=None):
        """Solve ``rgb`` in pieces of ``GRID_CHUNK`` nodes (each node's solve is independent:
        the same result as one call), reporting progress after each piece."""
        starts = np.broadcast_to(starts, (rgb.shape[0], N_COLOUR_INKS))
        pieces = []
        for a in range(0, rgb.shape[0], GRID_CHUNK):
            b = min(a + GRID_CHUNK, rgb.shape[0])
            if target_xyz is None:
                pieces.append(solve(model, objective, rgb[a:b], starts[a:b], max_iter, polish,
                                    polish_iter))
            else:
                pieces.append(solve_xyz(model, objective, target_xyz(rgb[a:b]), starts[a:b],
                                        max_iter, polish, polish_iter))
            if progress is not None and len(pieces) * GRID_CHUNK < rgb.shape[0]:
                progress(0.8 * (done + work[levels.index(lv)] * b / rgb.shape[0])
                         / work.sum())
        return tuple(np.concatenate(p) for p in zip(*pieces, strict=True))

    conc = cost = None
    for lv in levels:
        rgb = _grid_rgb(lv).reshape(-1, 3)
        if conc is None:
            best_c = best_f = None
            for s in _starts():
                c, f, _ = run(rgb, s, 200)
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
            # of far-out-of-gamut targets, whose cost it changes by < 0.1 dE76. de2000: the
            # cielab alternative start only at the coarsest and the final level, there only for
            # near-neutral targets (CIELAB chroma < NEUTRAL_CHROMA, where CIEDE2000 is a cone)
            # and 6 cielab steps from the warm start (it is only a start).
            final = lv == size
            conc, cost, _ = run(rgb, start.reshape(-1, N_COLOUR_INKS), 12 if final else 40,
                                polish=NEUTRAL_CHROMA if final else False, polish_iter=6)
        done += work[levels.index(lv)]
        if progress is not None:
            progress(0.8 * done / work.sum())
    return conc.reshape(size, size, size, N_COLOUR_INKS), cost.reshape(size, size, size)
