"""Bulk K and S of an ink from a thickness series of free-standing slabs (translucency target).

Method step: ink calibration (paper section 4.2) for slabs measured in air, where both faces
reflect. The forward model per wavelength and slab of thickness t:

- bulk: Kubelka-Munk two-flux R, T of the layer (paper eqs. 3-4,
  :func:`~dreamprint_gui.physics.kubelka_munk.reflectance_transmittance`);
- faces: Saunderson on both sides (:func:`~dreamprint_gui.physics.saunderson.slab_apply`), k1
  the normal-incidence Fresnel reflectance of the refractive index n (0.040 at n = 1.5), k2 the
  internal reflectance of diffuse light (0.596 at n = 1.5) or, with ``fit_k2``, one k2 per ink
  fitted over all wavelengths (a nearly non-scattering slab keeps its light collimated, which
  reflects inside much less than diffuse light does: the thickness series sees it).

Per wavelength, ``scipy.optimize.least_squares`` (trust-region reflective with a Cauchy loss of
scale 3 sigma, so that one bad slab does not drag the others off) on (ln K, ln S) minimises the
measured R and T residuals of every slab, each divided by the noise model
``sigma = rel_noise * value + abs_noise`` (1 % and 0.001 by default), started from the median of
the exact inverses (:func:`~dreamprint_gui.physics.saunderson.slab_remove`, then
:func:`~dreamprint_gui.physics.kubelka_munk.invert_closed_form`) of the slabs. The fitted k2
minimises the summed chi^2: a grid over 0-0.9 (step 0.02, every 5th wavelength) finds the valley,
Brent's bounded search (``scipy.optimize.minimize_scalar``) refines it within one step.

Uncertainty: ``cov = s^2 (J^T J)^-1`` at the solution (J in ln K, ln S of the weighted
residuals as ``least_squares`` returns it: scaled by the Cauchy loss, so a slab far off
counts less, and with the two faint prior rows; ``s^2 = chi^2 / (m - 2)`` with m data at that
wavelength, or 1, the noise model, when m <= 2), so ``sigma_K = K sigma_lnK``: one standard
deviation, conditional on k1 and k2.

Per slab: rms of the R and T residuals over wavelengths, dE2000 (D65, 2 degree) between the
measured and the fitted R and T spectra, and whether the slab fits (``MISFIT_DE2000``,
``MISFIT_CHI``). One thickness cannot separate the faces from the bulk: it is fitted with a
warning that k2 is held and that any error of the faces goes into K and S.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dreamprint_gui.core.calibration_types import LayerMeasurement, layer_arrays
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.physics import saunderson
from dreamprint_gui.physics.colorimetry import delta_E2000, observer_for
from dreamprint_gui.physics.kubelka_munk import invert_closed_form, reflectance_transmittance

__all__ = ["SlabOptions", "SlabFit", "SlabResidual", "fit_slabs", "slab_forward",
           "simulate_slabs", "series_warnings", "MISFIT_DE2000", "MISFIT_CHI",
           "REFRACTIVE_INDEX"]

REFRACTIVE_INDEX = 1.5     # cured PolyJet photopolymers: about 1.49-1.53
MISFIT_DE2000 = 1.0        # a slab whose fitted R or T colour is further off does not fit
MISFIT_CHI = 3.0           # ... or whose rms residual exceeds 3 sigma of the noise model
_FLOOR = 1e-9              # 1/mm: a coefficient below this is 0 at mm thicknesses
_PRIOR = 1e-3              # pull towards the start per unit of ln K, ln S (weighted units)
_K2_MAX = 0.9
_K2_STEP = 0.02
_ROBUST_SCALE = 3.0        # sigma: residuals beyond it weigh less (Cauchy loss), one bad slab
                           # does not drag the others off


@dataclass(frozen=True)
class SlabOptions:
    """How slabs measured in air are fitted: the faces' refractive index, and whether k2 is
    fitted (one per ink) or the diffuse value of that index. The CLI's ``calibrate --slabs``
    and the wizard's slab page build it."""

    refractive_index: float = REFRACTIVE_INDEX
    fit_k2: bool = False

    def fit(self, layers: list[LayerMeasurement], wavelengths_nm: ArrayLike) -> SlabFit:
        return fit_slabs(layers, wavelengths_nm, refractive_index=self.refractive_index,
                         fit_k2=self.fit_k2)

    def record(self) -> dict[str, Any]:
        return {"refractive_index": self.refractive_index, "fit_k2": self.fit_k2}


def slab_forward(K: ArrayLike, S: ArrayLike, t: ArrayLike, k1: float, k2: float
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Measured R_m, T_m of a slab of thickness t in air: KM bulk (eqs. 3-4) + both faces."""
    R, T = reflectance_transmittance(K, S, t)
    return saunderson.slab_apply(R, T, k1, k2)


def simulate_slabs(ink: str, K: ArrayLike, S: ArrayLike, thicknesses_mm: list[float],
                   k1: float, k2: float, rel_noise: float,
                   rng: np.random.Generator) -> list[LayerMeasurement]:
    """Slabs measured by :func:`slab_forward`, with Gaussian noise of ``rel_noise`` times the
    value on every R and T (independent per wavelength): the round trip's data."""
    out = []
    for t in thicknesses_mm:
        R, T = slab_forward(K, S, t, k1, k2)
        R = np.clip(R * (1.0 + rel_noise * rng.standard_normal(R.shape)), 0.0, 1.0)
        T = np.clip(T * (1.0 + rel_noise * rng.standard_normal(T.shape)), 0.0, 1.0)
        out.append(LayerMeasurement(ink, float(t), R, None if math.isinf(t) else T,
                                    f"simulated {t:g} mm"))
    return out


@dataclass
class SlabResidual:
    """How well the fitted K, S reproduce one slab (R or T None: not measured)."""

    thickness_mm: float
    source: str
    rms_R: float | None
    rms_T: float | None
    dE2000_R: float | None
    dE2000_T: float | None
    chi: float          # rms of the residuals in units of the noise model
    fits: bool

    def record(self) -> dict[str, Any]:
        return {"thickness_mm": None if math.isinf(self.thickness_mm) else self.thickness_mm,
                "source": self.source, "rms_R": self.rms_R, "rms_T": self.rms_T,
                "dE2000_R": self.dE2000_R, "dE2000_T": self.dE2000_T, "chi": self.chi,
                "fits": self.fits}


@dataclass
class SlabFit:
    """Bulk K, S (1/mm) of one ink, their 1-sigma uncertainty, the faces and the residuals."""

    ink: str
    wavelengths_nm: NDArray[np.float64]
    K: NDArray[np.float64]
    S: NDArray[np.float64]
    sigma_K: NDArray[np.float64]
    sigma_S: NDArray[np.float64]
    refractive_index: float
    k1: float
    k2: float
    k2_fitted: bool
    slabs: list[SlabResidual]
    rms_R: NDArray[np.float64]  # per wavelength, over the slabs that measured R (NaN: none)
    rms_T: NDArray[np.float64]
    warnings: list[str] = field(default_factory=list)

    def predict(self, thickness_mm: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """What the instrument reads from a slab of this ink (bulk and faces as fitted)."""
        return slab_forward(self.K, self.S, thickness_mm, self.k1, self.k2)

    @property
    def method(self) -> str:
        k2 = "fitted" if self.k2_fitted else "diffuse, from n"
        return (f"slab series, KM bulk + Saunderson faces (n {self.refractive_index:g}, "
                f"k1 {self.k1:.3f}, k2 {self.k2:.3f} {k2})")

    @property
    def layers(self) -> list[str]:
        return [f"{s.thickness_mm:g} mm: {s.source}" for s in self.slabs]

    def summary(self) -> dict[str, Any]:
        def worst(x: NDArray) -> float | None:
            x = x[np.isfinite(x)]
            return float(x.max()) if x.size else None

        with np.errstate(invalid="ignore", divide="ignore"):
            rel_K = self.sigma_K / np.where(self.K > 0, self.K, np.nan)
            rel_S = self.sigma_S / np.where(self.S > 0, self.S, np.nan)
        band = (self.wavelengths_nm >= 450) & (self.wavelengths_nm <= 700)
        rR = [s.rms_R for s in self.slabs if s.rms_R is not None]
        rT = [s.rms_T for s in self.slabs if s.rms_T is not None]
        return {"ink": self.ink, "method": self.method, "layers": self.layers,
                "max_rms_R": max(rR) if rR else None, "max_rms_T": max(rT) if rT else None,
                "k1": self.k1, "k2": self.k2, "k2_fitted": self.k2_fitted,
                "max_rel_sigma_K_450_700": worst(rel_K[band]),
                "max_rel_sigma_S_450_700": worst(rel_S[band]),
                "slabs": [s.record() for s in self.slabs], "warnings": self.warnings}

    def residual_record(self) -> dict[str, Any]:
        """What the profile keeps of the fit (its ``residuals`` entry for this ink)."""
        def lst(x: NDArray) -> list[float | None]:
            return [float(v) if np.isfinite(v) else None for v in x]

        return {"sigma_K": lst(self.sigma_K), "sigma_S": lst(self.sigma_S),
                "faces": {"refractive_index": self.refractive_index, "k1": self.k1,
                          "k2": self.k2, "k2_fitted": self.k2_fitted},
                "slabs": [s.record() for s in self.slabs], "warnings": self.warnings}


def _check_slabs(layers: list[LayerMeasurement]) -> None:
    """What a slab series needs beyond :func:`~dreamprint_gui.core.calibration_types.
    layer_arrays`'s checks: thicknesses > 0, R or T per slab, no T of an opaque slab."""
    for m in layers:
        if not m.thickness_mm > 0:
            raise DreamPrintError(f"ink {m.ink}: thickness must be > 0 mm, got "
                                  f"{m.thickness_mm}", m.source or None)
        if m.R is None and m.T is None:
            raise DreamPrintError(f"ink {m.ink}: a slab has neither R nor T", m.source or None)
        if np.isinf(m.thickness_mm) and m.T is not None:
            raise DreamPrintError(f"ink {m.ink}: an optically thick slab (thickness inf) has "
                                  "no transmittance; give its R only", m.source or None)


class _Problem:
    """One ink's data and noise model; fits K, S per wavelength for a given k2."""

    def __init__(self, t: NDArray, R: NDArray, T: NDArray, hasR: NDArray, hasT: NDArray,
                 k1: float, rel_noise: float, abs_noise: float) -> None:
        self.t, self.R, self.T, self.hasR, self.hasT, self.k1 = t, R, T, hasR, hasT, k1
        self.sR = rel_noise * np.abs(np.nan_to_num(R)) + abs_noise
        self.sT = rel_noise * np.abs(np.nan_to_num(T)) + abs_noise

    def start(self, j: int, k2: float) -> NDArray:
        both = self.hasR[:, j] & self.hasT[:, j] & np.isfinite(self.t)
        starts = []
        for i in np.flatnonzero(both):
            Ri, Ti = saunderson.slab_remove(self.R[i, j], self.T[i, j], self.k1, k2)
            if 0.0 <= Ri and 0.0 < Ti and Ri + Ti <= 1.0:
                k0, s0 = invert_closed_form(Ri, Ti, self.t[i])
                if np.isfinite(k0) and np.isfinite(s0):
                    starts.append((float(k0), float(s0)))
        if starts:
            k0, s0 = np.median(np.asarray(starts), axis=0)
        else:
            sel = self.hasT[:, j] & (self.T[:, j] > 0) & np.isfinite(self.t)
            tr = np.clip(self.T[sel, j] / (1.0 - self.k1) ** 2, 1e-12, 1.0)
            k0 = float(np.median(-np.log(tr) / self.t[sel])) if sel.any() else 1.0
            s0 = 0.1 * max(k0, 1e-3)
        return np.log(np.maximum([k0, s0], _FLOOR))

    def weighted(self, x: NDArray, j: int, k2: float) -> NDArray:
        Rm, Tm = slab_forward(np.exp(x[0]), np.exp(x[1]), self.t, self.k1, k2)
        hr, ht = self.hasR[:, j], self.hasT[:, j]
        return np.concatenate([((Rm - self.R[:, j]) / self.sR[:, j])[hr],
                               ((Tm - self.T[:, j]) / self.sT[:, j])[ht]])

    def fit(self, j: int, k2: float) -> tuple[NDArray, float, NDArray, int]:
        """(ln K, ln S), chi^2 of the data, covariance of (ln K, ln S), number of data."""
        from scipy.optimize import least_squares

        x0 = self.start(j, k2)

        def res(x: NDArray) -> NDArray:
            return np.concatenate([self.weighted(x, j, k2), _PRIOR * (x - x0)])

        sol = least_squares(res, x0, method="trf", loss="cauchy", f_scale=_ROBUST_SCALE,
                            xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=400)
        r = self.weighted(sol.x, j, k2)
        m = r.size
        chi2 = float(r @ r)
        s2 = chi2 / (m - 2) if m > 2 else 1.0
        J = sol.jac
        cov = np.linalg.pinv(J.T @ J) * s2
        return sol.x, chi2, cov, m


def fit_slabs(layers: list[LayerMeasurement], wavelengths_nm: ArrayLike, *,
              refractive_index: float = REFRACTIVE_INDEX, k2: float | None = None,
              fit_k2: bool = False, rel_noise: float = 0.01,
              abs_noise: float = 1e-3) -> SlabFit:
    """Fit bulk K, S (1/mm) of one ink to its slabs' measured R and T (see the module).

    ``k2`` None: the diffuse internal reflectance of ``refractive_index``; ``fit_k2``: one k2
    fitted over all wavelengths (needs two or more thicknesses; with one, held and warned).
    """
    from scipy.optimize import minimize_scalar

    if not layers:
        raise ValueError("no slabs to fit")
    ink = layers[0].ink
    wl = np.asarray(wavelengths_nm, dtype=np.float64)
    n_wl = wl.size
    _check_slabs(layers)
    t, R, T, hasR, hasT = layer_arrays(layers, n_wl)
    if not hasT.any():
        raise DreamPrintError(f"ink {ink}: no transmittance measured; K and S cannot be "
                              "separated from reflectance alone")
    k1 = saunderson.fresnel_k1(refractive_index)
    k2_value = saunderson.diffuse_internal_k2(refractive_index) if k2 is None else float(k2)
    if not 0.0 <= k2_value < 1.0:
        raise DreamPrintError(f"k2 must lie in [0, 1), got {k2_value:g}")
    warnings = series_warnings(layers, k2_value, refractive_index)
    if len({float(x) for x in t if np.isfinite(x)}) < 2:
        fit_k2 = False
    prob = _Problem(t, R, T, hasR, hasT, k1, rel_noise, abs_noise)

    def total_chi2(k2v: float, step: int = 1) -> float:
        return sum(prob.fit(j, k2v)[1] for j in range(0, n_wl, step))

    if fit_k2:
        # chi^2(k2) has a narrow valley and a plateau (k2 > 0.6): a coarse grid on every 5th
        # wavelength finds the valley, Brent's bounded search refines it on all of them
        grid = np.arange(0.0, _K2_MAX + 1e-9, _K2_STEP)
        best = int(np.argmin([total_chi2(float(k), 5) for k in grid]))
        lo, hi = max(0.0, grid[best] - _K2_STEP), min(_K2_MAX, grid[best] + _K2_STEP)
        sol = minimize_scalar(total_chi2, bounds=(lo, hi), method="bounded",
                              options={"xatol": 1e-4})
        k2_value = float(sol.x)
    K = np.empty(n_wl)
    S = np.empty(n_wl)
    sK = np.empty(n_wl)
    sS = np.empty(n_wl)
    for j in range(n_wl):
        x, _, cov, _ = prob.fit(j, k2_value)
        K[j], S[j] = np.exp(x)
        sK[j], sS[j] = np.sqrt(np.maximum(np.diag(cov), 0.0)) * np.exp(x)
    K = np.where(K <= _FLOOR * 1.000001, 0.0, K)
    S = np.where(S <= _FLOOR * 1.000001, 0.0, S)
    slabs = _slab_residuals(layers, wl, K, S, t, R, T, hasR, hasT, prob, k1, k2_value)
    Rm, Tm = slab_forward(K, S, t[:, None], k1, k2_value)
    with np.errstate(invalid="ignore"):
        rms_R = np.sqrt(np.nanmean(np.where(hasR, (Rm - R) ** 2, np.nan), axis=0)) \
            if hasR.any() else np.full(n_wl, np.nan)
        rms_T = np.sqrt(np.nanmean(np.where(hasT, (Tm - T) ** 2, np.nan), axis=0))
    bad = [s for s in slabs if not s.fits]
    for s in bad:
        warnings.append(f"ink {ink}: the {s.thickness_mm:g} mm slab does not fit (dE2000 R "
                        f"{_fmt(s.dE2000_R)}, T {_fmt(s.dE2000_T)}; {s.chi:.1f} sigma): "
                        f"remeasure it or check its thickness ({s.source})")
    if len(bad) > len(slabs) // 2 and not fit_k2 and len({s.thickness_mm for s in slabs}) > 1:
        warnings.append(f"ink {ink}: most slabs do not fit with k2 {k2_value:.3f} (diffuse "
                        "light at the faces): fit k2 (--fit-k2), as for a nearly clear ink "
                        "whose light stays collimated")
    return SlabFit(ink, wl, K, S, sK, sS, float(refractive_index), k1, k2_value, fit_k2,
                   slabs, rms_R, rms_T, warnings)


def series_warnings(layers: list[LayerMeasurement], k2: float,
                    refractive_index: float) -> list[str]:
    """What a thickness series of one ink cannot separate, before any fit (the fit, the CLI
    and the wizard's slab page say the same)."""
    if not layers:
        return []
    ink = layers[0].ink
    out = []
    thick = sorted({float(m.thickness_mm) for m in layers if math.isfinite(m.thickness_mm)})
    if not any(m.T is not None for m in layers):
        out.append(f"ink {ink}: no transmittance measured; K and S cannot be separated from "
                   "reflectance alone")
    if len(thick) < 2:
        out.append(
            f"ink {ink}: one thickness ({', '.join(f'{x:g}' for x in thick) or 'none'} mm) "
            f"cannot separate the slab's faces from its bulk: k2 is held at {k2:.3f} (n "
            f"{refractive_index:g}), any error in it goes into K and S, and nothing checks the "
            "fit; measure two or more thicknesses (0.5-8 mm)")
    if not any(m.R is not None for m in layers):
        out.append(f"ink {ink}: no reflectance measured; K and S are separated only by how T "
                   "falls with thickness (see the uncertainty)")
    # what no slab in air of this index can read (the faces alone reflect k1, pass (1-k1)^2)
    k1 = saunderson.fresnel_k1(refractive_index)
    Rs = [float(np.median(m.R)) for m in layers if m.R is not None]
    Ts = [float(np.median(m.T)) for m in layers if m.T is not None]
    if Rs and min(Rs) < 0.8 * k1:
        out.append(f"ink {ink}: R (median {min(Rs):.3f}) lies below the faces' own "
                   f"reflectance k1 {k1:.3f}: measured without the specular component (SCE)? "
                   "Slabs need it included (SCI, M0-M2 with gloss)")
    if Ts and max(Ts) > 1.01 * (1.0 - k1) ** 2:
        out.append(f"ink {ink}: T (median {max(Ts):.3f}) exceeds what the two faces of n "
                   f"{refractive_index:g} pass ({(1.0 - k1) ** 2:.3f}): check the instrument's "
                   "100 % baseline (air, not a blank slab) or the refractive index")
    return out


def _fmt(x: float | None) -> str:
    return "-" if x is None else f"{x:.2f}"


def _slab_residuals(layers: list[LayerMeasurement], wl: NDArray, K: NDArray, S: NDArray,
                    t: NDArray, R: NDArray, T: NDArray, hasR: NDArray, hasT: NDArray,
                    prob: _Problem, k1: float, k2: float) -> list[SlabResidual]:
    obs = observer_for(wl)
    Rm, Tm = slab_forward(K, S, t[:, None], k1, k2)
    out = []
    for i, m in enumerate(layers):
        vals: dict[str, tuple[float | None, float | None]] = {}
        chis = []
        for key, meas, model, has, sig in (("R", R, Rm, hasR, prob.sR),
                                           ("T", T, Tm, hasT, prob.sT)):
            if not has[i].all():
                vals[key] = (None, None)
                continue
            d = model[i] - meas[i]
            chis.append(d / sig[i])
            de = float(delta_E2000(obs.spectra_to_Lab(meas[i]), obs.spectra_to_Lab(model[i])))
            vals[key] = (float(np.sqrt(np.mean(d * d))), de)
        chi = float(np.sqrt(np.mean(np.concatenate(chis) ** 2)))
        des = [v[1] for v in vals.values() if v[1] is not None]
        fits = chi <= MISFIT_CHI and max(des) <= MISFIT_DE2000
        out.append(SlabResidual(float(m.thickness_mm), m.source, vals["R"][0], vals["T"][0],
                                vals["R"][1], vals["T"][1], chi, fits))
    return out
