"""Calibration from a chart of printed mixtures: refit all inks' K and S jointly.

Given recipes (fractions of each ink) and the measured reflectance of each opaque patch, the
inks' K(lambda) and S(lambda) are refitted to minimise the CIEDE2000 difference between each
patch's predicted colour (eq. 7 at the profile's colour reference, R_inf by default) and its
measured colour.

Model: smooth multiplicative corrections of the base profile,
``ln K_i(lambda) = ln K0_i(lambda) + sum_b a_ib P_b(x)``, the same for S with ``c_ib``, where
``P_b`` are Legendre polynomials in ``x`` in [-1, 1] across the grid. Opaque patches determine K
and S only up to a common factor per wavelength (``R_inf`` of every mixture depends only on the
ratios of the inks' K and S at each wavelength), so that factor is fixed by the base profile (the
pure-ink or thickness data it was calibrated from): S of the anchor ink (the most scattering
one, normally White) is held at the base's. A small ridge term keeps the corrections near the
base where the chart says nothing.

The reported error is k-fold cross-validated dE2000 (each patch predicted by a fit that did not
see it): a fit judged on its own patches flatters itself.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.profile import INKS, InkProfile, now_iso
from dreamprint_gui.physics import saunderson as sd
from dreamprint_gui.physics.colorimetry import delta_E2000, observer_for
from dreamprint_gui.physics.kubelka_munk import mix, reflectance_transmittance

# least_squares evaluations per fit (each trust-region iteration takes one Jacobian and >= 1)
_MAX_NFEV = 100

__all__ = ["ChartFit", "fit_chart"]


@dataclass
class ChartFit:
    profile: InkProfile
    fit_dE2000: NDArray[np.float64]  # per patch, the fit's own
    cv_dE2000: NDArray[np.float64]  # per patch, predicted by a fold that did not see it
    base_dE2000: NDArray[np.float64]  # per patch, the base profile before refitting
    folds: int
    n_basis: int

    def report(self) -> dict[str, Any]:
        def stats(x: NDArray) -> dict[str, float]:
            return {"mean": float(np.mean(x)), "p95": float(np.percentile(x, 95)),
                    "max": float(np.max(x))}

        return {"patches": int(self.fit_dE2000.size), "folds": self.folds,
                "basis_functions": self.n_basis, "base_dE2000": stats(self.base_dE2000),
                "fit_dE2000": stats(self.fit_dE2000),
                "cross_validated_dE2000": stats(self.cv_dE2000)}


class _Model:
    def __init__(self, base: InkProfile, inks: list[int], n_basis: int, anchor: int) -> None:
        wl = base.wavelengths_nm
        x = 2.0 * (wl - wl[0]) / (wl[-1] - wl[0]) - 1.0
        self.P = np.polynomial.legendre.legvander(x, n_basis - 1)  # (n_wl, n_basis)
        self.base = base
        self.inks = inks
        self.nb = n_basis
        self.anchor = anchor  # index into inks whose S constant term is fixed
        self.lnK0 = np.log(np.maximum(base.K, 1e-12))
        self.lnS0 = np.log(np.maximum(base.S, 1e-12))
        self.obs = observer_for(wl)

    @property
    def n_params(self) -> int:
        return (2 * len(self.inks) - 1) * self.nb

    def unpack(self, p: NDArray) -> tuple[NDArray, NDArray]:
        """K, S (6, n_wl) of one parameter vector, or (B, 6, n_wl) of a batch (B, n_params)."""
        p = np.asarray(p, dtype=np.float64)
        batch = p.reshape(-1, p.shape[-1])
        n_inks, n = len(self.inks), len(self.inks) * self.nb
        a = batch[:, :n].reshape(-1, n_inks, self.nb)
        c = np.insert(batch[:, n:].reshape(-1, n_inks - 1, self.nb), self.anchor, 0.0, axis=1)
        K = np.repeat(self.base.K[None], batch.shape[0], axis=0)
        S = np.repeat(self.base.S[None], batch.shape[0], axis=0)
        K[:, self.inks] = np.exp(self.lnK0[self.inks] + a @ self.P.T)
        S[:, self.inks] = np.exp(self.lnS0[self.inks] + c @ self.P.T)
        shape = p.shape[:-1] + K.shape[1:]
        return K.reshape(shape), S.reshape(shape)

    def lab(self, K: NDArray, S: NDArray, recipes: NDArray, saunderson: tuple | None) -> NDArray:
        Km, Sm = mix(recipes, K, S)
        R, T = reflectance_transmittance(Km, Sm, self.base.colour_thickness_mm)
        if saunderson is not None:

            R, T = sd.apply(R, T, *saunderson)
        return self.obs.spectra_to_Lab(R + T)


def _fit(model: _Model, recipes: NDArray, target_lab: NDArray, p0: NDArray, ridge: float,
         saunderson: tuple | None,
         iteration: Callable[[int], None] | None = None) -> NDArray:
    """``iteration(n)`` after the n-th Jacobian (one trust-region step, about 0.1-1 s)."""
    from scipy.optimize import least_squares

    steps = [0]

    def dE(params: NDArray) -> NDArray:
        K, S = model.unpack(params)
        return delta_E2000(model.lab(K, S, recipes, saunderson), target_lab)

    def residuals(p: NDArray) -> NDArray:
        return np.concatenate([dE(p), ridge * p])

    def jacobian(p: NDArray) -> NDArray:
        # Forward differences, all parameters in one batched evaluation (one model call instead
        # of n_params): the model is cheap per patch but costly per call.
        h = 1.5e-8 * np.maximum(1.0, np.abs(p))  # sqrt(machine epsilon), as scipy's 2-point
        stack = np.vstack([p, p + np.diag(h)])
        values = dE(stack)
        J = ((values[1:] - values[0]) / h[:, None]).T
        steps[0] += 1
        if iteration is not None:
            iteration(steps[0])
        return np.vstack([J, ridge * np.eye(p.size)])

    sol = least_squares(residuals, p0, jac=jacobian, method="trf", max_nfev=_MAX_NFEV, xtol=1e-8,
                        ftol=1e-8)
    return sol.x


def fit_chart(base: InkProfile, recipes: ArrayLike, reflectance: ArrayLike, *,
              n_basis: int = 5, folds: int = 5, ridge: float = 0.05,
              saunderson: tuple[float, float] | None = None, name: str = "chart-calibrated",
              source: str | None = None,
              progress: Callable[..., None] | None = None) -> ChartFit:
    """Refit the inks used in ``recipes`` (n, 6) to the measured ``reflectance`` (n, n_wl).

    Reflectance is on ``base.wavelengths_nm`` as fractions. ``saunderson=(k1, k2)`` when the
    instrument's readings include the surface reflections. ``progress(done, total)`` after the
    fit to every patch and after each cross-validation fold (``folds + 1`` steps; 0 first).
    """
    c = np.asarray(recipes, dtype=np.float64)
    Rm = np.asarray(reflectance, dtype=np.float64)
    if c.ndim != 2 or c.shape[1] != len(INKS):
        raise DreamPrintError(f"recipes must have one column per ink ({', '.join(INKS)})", source)
    if Rm.shape != (c.shape[0], base.wavelengths_nm.size):
        raise DreamPrintError(f"{Rm.shape[0]} spectra of {Rm.shape[-1]} wavelengths for "
                              f"{c.shape[0]} recipes on a {base.wavelengths_nm.size}-point grid",
                              source)
    used = [i for i in range(len(INKS)) if c[:, i].max() > 0]
    n_patches = c.shape[0]
    if n_patches < 2 * len(used):
        raise DreamPrintError(f"{n_patches} patches are too few to refit {len(used)} inks; "
                              f"measure at least {2 * len(used)}", source)
    anchor = int(np.argmax([base.S[i].mean() for i in used]))
    model = _Model(base, used, n_basis, anchor)
    obs = model.obs
    target = obs.spectra_to_Lab(Rm)
    k = max(2, min(folds, n_patches))
    if progress is not None:
        progress(0, k + 1)
    def during(done: int):
        if progress is None:
            return None
        return lambda n: progress(done, k + 1,
                                  f"fit {done + 1}: iteration {n} of at most {_MAX_NFEV}")

    p_full = _fit(model, c, target, np.zeros(model.n_params), ridge, saunderson, during(0))
    if progress is not None:
        progress(1, k + 1)
    K, S = model.unpack(p_full)
    fit_dE = delta_E2000(model.lab(K, S, c, saunderson), target)
    base_dE = delta_E2000(model.lab(base.K, base.S, c, saunderson), target)
    order = np.random.default_rng(0).permutation(n_patches)
    cv = np.empty(n_patches)
    for f in range(k):
        test = order[f::k]
        train = np.setdiff1d(order, test)
        p = _fit(model, c[train], target[train], p_full, ridge, saunderson, during(f + 1))
        Kf, Sf = model.unpack(p)
        cv[test] = delta_E2000(model.lab(Kf, Sf, c[test], saunderson), target[test])
        if progress is not None:
            progress(f + 2, k + 1)
    profile = base.with_settings(
        name=name, K=K, S=S,
        provenance={
            "created": now_iso(),
            "model": f"chart refit: Legendre({n_basis}) log-corrections of K and S of inks "
                     f"{[INKS[i] for i in used]} minimising dE2000; scale fixed by "
                     f"{INKS[used[anchor]]} of the base profile",
            "base_profile": base.name,
            "chart": source or "",
        },
    )
    fit = ChartFit(profile, fit_dE, cv, base_dE, k, n_basis)
    profile.residuals.update({"chart": fit.report()})
    return fit
