"""Ink calibration: measured R and T of ink layers -> K and S per wavelength (paper section 4.2).

Defines
-------
- :func:`invert_closed_form`: Kubelka's explicit inversion of one layer's R, T at thickness t.
- :func:`fit_ink`: Levenberg-Marquardt over one or several layers (thicknesses, R and/or T;
  an optically thick patch, thickness inf, contributes R_inf), started from the closed form
  with a faint pull towards that start (weight ``_PRIOR`` per unit of ln K, ln S: it decides
  only where the data leave K and S free, e.g. layers all opaque); per-wavelength residuals.
- :func:`calibrate_profile`: all measured inks -> an :class:`InkProfile` plus a fit report; inks
  without measurements keep the base profile's K and S (and the report says so). With
  ``slabs`` (free-standing slabs measured in air, the translucency wedge) each ink is fitted by
  :func:`~dreamprint_gui.physics.slab_fit.fit_slabs` (bulk + both faces, uncertainty, per-slab
  residuals). The profile's ``provenance.ink_origin`` marks the fitted inks ``measured``.
- :func:`leave_one_thickness_out`: what can be checked of a fit. One layer with R and T is
  reproduced exactly by construction (two unknowns, two data per wavelength), so its residual says
  nothing; with several thicknesses, each is left out in turn, K and S are fitted to the others
  and the left-out layer's R and T are predicted: the held-out error.

Closed form (Kubelka 1948, eqs. for a layer of known thickness)::

    a = (1 + R^2 - T^2) / (2 R),   b = sqrt(a^2 - 1)
    S = ln((1 - R (a - b)) / T) / (b t),   K = S (a - 1)

It follows from eqs. 3-4 of the paper: ``R/T = sinh(bSt)/b`` and ``1/T = (a sinh + b cosh)/b``
give ``a`` as above and ``exp(bSt) = (1 - R(a - b))/T``.

References
----------
- Kubelka, P. (1948). JOSA 38(5), 448-457.
- More, J. J. (1978). The Levenberg-Marquardt algorithm: implementation and theory.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dreamprint_gui.core.calibration_types import LayerMeasurement, layer_arrays
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.profile import INKS, InkProfile, ink_origins, now_iso
from dreamprint_gui.physics.kubelka_munk import invert_closed_form, reflectance_transmittance
from dreamprint_gui.physics.slab_fit import SlabFit, SlabOptions

__all__ = ["invert_closed_form", "fit_ink", "InkFit", "calibrate_profile", "LayerMeasurement",
           "HeldOut", "leave_one_thickness_out", "exact_by_construction"]

_T_FLOOR = 1e-12  # the smallest transmittance the starts invert (T = 0 has no finite K)
_PRIOR = 1e-4  # weight of the pull towards the start, per unit of ln K or ln S (fit_ink)
_FLOOR = 1e-9  # 1/mm: below this a coefficient is indistinguishable from 0 at mm thicknesses


@dataclass
class InkFit:
    """K, S (1/mm) of one ink and how well they reproduce its measurements."""

    ink: str
    K: NDArray[np.float64]
    S: NDArray[np.float64]
    rms_R: NDArray[np.float64]  # per wavelength, over the layers that measured R
    rms_T: NDArray[np.float64]
    method: str
    layers: list[str] = field(default_factory=list)

    def summary(self) -> dict[str, Any]:
        def stat(x: NDArray) -> float | None:
            x = x[np.isfinite(x)]
            return float(x.max()) if x.size else None

        return {"ink": self.ink, "method": self.method, "layers": self.layers,
                "max_rms_R": stat(self.rms_R), "max_rms_T": stat(self.rms_T)}


def fit_ink(layers: list[LayerMeasurement], n_wavelengths: int) -> InkFit:
    """Fit K, S of one ink to all its layers, wavelength by wavelength.

    One layer with R and T: the closed form is the answer (LM only polishes it). Several layers
    (thicknesses) or noisy data: Levenberg-Marquardt (``scipy.optimize.least_squares``,
    ``method='lm'``) on ``(ln K, ln S)`` minimises the squared R and T residuals of all layers,
    started from the closed-form inversion of the layers that have both (or from a Beer-Lambert
    guess).
    """
    from scipy.optimize import least_squares

    if not layers:
        raise ValueError("no layers to fit")
    ink = layers[0].ink
    t, R, T, hasR, hasT = layer_arrays(layers, n_wavelengths)
    for i, m in enumerate(layers):
        if not m.thickness_mm > 0:
            raise DreamPrintError(f"ink {ink}: thickness must be > 0 mm, got {m.thickness_mm}",
                                  m.source or None)
        if np.isinf(m.thickness_mm) and m.T is not None:
            raise DreamPrintError(f"ink {ink}: an optically thick layer (thickness inf) has no "
                                  "transmittance; give its R only", m.source or None)
        if not (hasR[i].any() or hasT[i].any()):
            raise DreamPrintError(f"ink {ink}: a layer has neither R nor T", m.source or None)
    if not hasT.any():
        raise DreamPrintError(f"ink {ink}: no transmittance measured; K and S cannot be "
                              "separated from reflectance of one thickness alone")
    K = np.empty(n_wavelengths)
    S = np.empty(n_wavelengths)
    both = hasR.all(axis=1) & hasT.all(axis=1) & np.isfinite(t)
    single_exact = len(layers) == 1 and both[0]
    for j in range(n_wavelengths):
        starts = []
        for i in np.flatnonzero(both):
            # T measured as 0 (a filter's blocked band, noise clipped at 0) has no finite
            # inverse: start from the floor the Beer-Lambert guess below uses, T = 1e-12.
            tij = T[i, j] if T[i, j] > 0 else _T_FLOOR
            k0, s0 = invert_closed_form(R[i, j], tij, t[i])
            if np.isfinite(k0) and np.isfinite(s0):
                starts.append((float(k0), float(s0)))
        if starts:
            k0, s0 = np.median(np.asarray(starts), axis=0)
        else:
            sel = hasT[:, j] & (T[:, j] > 0) & np.isfinite(t)
            k0 = float(np.median(-np.log(np.clip(T[sel, j], _T_FLOOR, 1)) / t[sel])) if sel.any() \
                else 1.0
            s0 = 0.1 * k0
        x0 = np.log(np.maximum([k0, s0], _FLOOR))
        if single_exact and starts:
            K[j], S[j] = k0, s0
            continue

        def residuals(x: NDArray, j: int = j, x0: NDArray = x0) -> NDArray:
            r, tt = reflectance_transmittance(np.exp(x[0]), np.exp(x[1]), t)
            # A faint pull towards the start: where the layers are all opaque, R fixes only
            # K/S and T ~ 0 nothing else, so the data leave a flat valley along which LM
            # wandered to K, S ~ 1e9 (refused by the profile); the pull keeps the start's
            # scale there and moves a determined solution by ~ (_PRIOR / slope)^2, nothing.
            return np.concatenate([(r - R[:, j])[hasR[:, j]], (tt - T[:, j])[hasT[:, j]],
                                   _PRIOR * (x - x0)])

        sol = least_squares(residuals, x0, method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15,
                            max_nfev=2000)
        K[j], S[j] = np.exp(sol.x)
    K = np.where(K <= _FLOOR * 1.000001, 0.0, K)
    S = np.where(S <= _FLOOR * 1.000001, 0.0, S)
    Rm, Tm = reflectance_transmittance(K, S, t[:, None])
    with np.errstate(invalid="ignore"):
        rms_R = np.sqrt(np.nanmean(np.where(hasR, (Rm - R) ** 2, np.nan), axis=0)) \
            if hasR.any() else np.full(n_wavelengths, np.nan)
        rms_T = np.sqrt(np.nanmean(np.where(hasT, (Tm - T) ** 2, np.nan), axis=0))
    method = "closed form (Kubelka 1948)" if single_exact else "Levenberg-Marquardt"
    return InkFit(ink, K, S, rms_R, rms_T, method,
                  [f"{m.thickness_mm:g} mm: {m.source}" for m in layers])


def _json_list(x: NDArray) -> list[float | None]:
    return [float(v) if np.isfinite(v) else None for v in x]


def calibrate_profile(measurements: list[LayerMeasurement], base: InkProfile,
                      name: str = "calibrated", slabs: SlabOptions | None = None
                      ) -> tuple[InkProfile, list[InkFit | SlabFit]]:
    """Fit every measured ink; inks without measurements keep ``base``'s K and S.

    ``measurements`` must be on ``base.wavelengths_nm`` (the importer resamples them).
    ``slabs``: the layers are free-standing slabs measured in air (fit with both faces).
    """
    by_ink: dict[str, list[LayerMeasurement]] = {}
    for m in measurements:
        if m.ink not in INKS:
            raise DreamPrintError(f"unknown ink '{m.ink}'; inks are {', '.join(INKS)}",
                                  m.source or None)
        by_ink.setdefault(m.ink, []).append(m)
    if not by_ink:
        raise DreamPrintError("no ink measurements given")
    n = base.wavelengths_nm.size
    K, S = base.K.copy(), base.S.copy()
    fits: list[InkFit | SlabFit] = []
    for ink, layers in by_ink.items():
        fit = slabs.fit(layers, base.wavelengths_nm) if slabs else fit_ink(layers, n)
        i = INKS.index(ink)
        K[i], S[i] = fit.K, fit.S
        fits.append(fit)
    kept = [ink for ink in INKS if ink not in by_ink]
    origin = ink_origins(base)
    origin.update({ink: "measured" for ink in by_ink})
    model = ("Kubelka-Munk two-flux; per-wavelength inversion (closed form, "
             "Levenberg-Marquardt for several layers)")
    if slabs:
        model = ("Kubelka-Munk two-flux bulk of slabs measured in air, Saunderson on both "
                 "faces; per-wavelength robust least squares")
    profile = base.with_settings(
        name=name, K=K, S=S,
        provenance={
            "created": now_iso(),
            "model": model,
            **({"slabs": slabs.record()} if slabs else {}),
            "measurements": {f.ink: f.layers for f in fits},
            "inks_from_base_profile": {ink: base.name for ink in kept},
            "ink_origin": origin,
        },
        residuals={f.ink: _residual_record(f) for f in fits},
    )
    return profile, fits


def _residual_record(f: InkFit | SlabFit) -> dict[str, Any]:
    if isinstance(f, SlabFit):
        return f.residual_record()
    return {"rms_R": _json_list(f.rms_R), "rms_T": _json_list(f.rms_T)}


def exact_by_construction(layers: list[LayerMeasurement]) -> bool:
    """True when the layers are one thickness measured once with both R and T: K and S then
    reproduce them exactly (the closed form), and the fit residual checks nothing."""
    return (len(layers) == 1 and layers[0].R is not None and layers[0].T is not None
            and bool(np.isfinite(layers[0].thickness_mm)))


@dataclass
class HeldOut:
    """The error predicting the layers of one thickness from a fit to the other thicknesses.

    ``rms_R`` / ``rms_T`` are per wavelength (NaN where that thickness has no R / T);
    ``fitted_on`` lists the thicknesses (mm) the fit used.
    """

    ink: str
    thickness_mm: float
    rms_R: NDArray[np.float64]
    rms_T: NDArray[np.float64]
    fitted_on: list[float]

    @staticmethod
    def _overall(x: NDArray) -> float | None:
        x = x[np.isfinite(x)]
        return float(np.sqrt(np.mean(x * x))) if x.size else None

    @property
    def overall_R(self) -> float | None:
        """rms over wavelengths of the held-out R error (None: no R at this thickness)."""
        return self._overall(self.rms_R)

    @property
    def overall_T(self) -> float | None:
        return self._overall(self.rms_T)


def leave_one_thickness_out(layers: list[LayerMeasurement], n_wavelengths: int
                            ) -> tuple[list[HeldOut], list[str]]:
    """Held-out R/T error of one ink: each distinct thickness left out in turn.

    For thickness ``t_k``, K and S are fitted (:func:`fit_ink`) to the layers of every other
    thickness, then R and T of the layers at ``t_k`` are predicted with eqs. 3-4 and compared
    with their measurements (rms over those layers, per wavelength). A thickness whose
    remaining layers have no transmittance cannot be held out (K and S are not separable
    from reflectance of one thickness); it is skipped and named in the returned notes.
    Returns ``([], [why])`` with fewer than two distinct thicknesses.
    """
    if not layers:
        return [], []
    ink = layers[0].ink
    thicknesses = sorted({float(m.thickness_mm) for m in layers})
    if len(thicknesses) < 2:
        return [], [f"{ink}: one thickness measured; nothing to hold out"]
    out: list[HeldOut] = []
    notes: list[str] = []
    for t in thicknesses:
        rest = [m for m in layers if float(m.thickness_mm) != t]
        held = [m for m in layers if float(m.thickness_mm) == t]
        if not any(m.T is not None for m in rest):
            notes.append(f"{ink}: {t:g} mm not held out (the other thicknesses have no "
                         "transmittance)")
            continue
        fit = fit_ink(rest, n_wavelengths)
        tt, R, T, hasR, hasT = layer_arrays(held, n_wavelengths)
        Rm, Tm = reflectance_transmittance(fit.K, fit.S, tt[:, None])
        with np.errstate(invalid="ignore"):
            rms_R = np.sqrt(np.nanmean(np.where(hasR, (Rm - R) ** 2, np.nan), axis=0)) \
                if hasR.any() else np.full(n_wavelengths, np.nan)
            rms_T = np.sqrt(np.nanmean(np.where(hasT, (Tm - T) ** 2, np.nan), axis=0)) \
                if hasT.any() else np.full(n_wavelengths, np.nan)
        out.append(HeldOut(ink, t, rms_R, rms_T,
                           sorted({float(m.thickness_mm) for m in rest})))
    return out, notes
