"""Appearance of ink mixtures: spectra, colour (eq. 7) and density (eqs. 8-9) in one call.

:func:`predict` is what ``dreamprint predict``, the tables, the preview and the reports all use,
so that a colour means the same everywhere: R + T of the mixture at the profile's reference
thickness (``colour_thickness_mm``, R_inf by default) under D65 with the CIE 1931 2 degree
observer, and the scalar density sigma of eq. 9 at the profile's layer thickness.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dreamprint_gui.core.profile import InkProfile
from dreamprint_gui.physics import saunderson as _saunderson
from dreamprint_gui.physics.colorimetry import Observer, observer_for
from dreamprint_gui.physics.density import scalar_sigma
from dreamprint_gui.physics.kubelka_munk import mix, reflectance_transmittance

__all__ = ["Prediction", "predict", "mixture_colour"]


@dataclass(frozen=True)
class Prediction:
    """Predicted appearance of mixtures; leading shape that of the concentrations."""

    wavelengths_nm: NDArray[np.float64]
    R: NDArray[np.float64]
    T: NDArray[np.float64]
    XYZ: NDArray[np.float64]
    Lab: NDArray[np.float64]
    sRGB: NDArray[np.float64]
    sigma_per_mm: NDArray[np.float64]
    thickness_mm: float

    def record(self, i: int | tuple = ()) -> dict:
        """JSON-ready dict of one mixture (``i`` indexes the leading dimensions)."""
        return {
            "wavelengths_nm": self.wavelengths_nm.tolist(),
            "thickness_mm": None if math.isinf(self.thickness_mm) else self.thickness_mm,
            "R": self.R[i].tolist(),
            "T": self.T[i].tolist(),
            "XYZ": self.XYZ[i].tolist(),
            "Lab": self.Lab[i].tolist(),
            "sRGB": self.sRGB[i].tolist(),
            "sigma_per_mm": float(self.sigma_per_mm[i]),
        }


def _concentrations(profile: InkProfile, c: ArrayLike) -> NDArray[np.float64]:
    c = np.asarray(c, dtype=np.float64)
    n = len(profile.inks)
    if c.shape[-1] == n - 1:  # C, M, Y, K, W without Clear
        c = np.concatenate([c, np.zeros(c.shape[:-1] + (1,))], axis=-1)
    if c.shape[-1] != n:
        raise ValueError(f"concentrations need {n} (or {n - 1}) inks on the last axis")
    return c


def mixture_colour(profile: InkProfile, concentrations: ArrayLike,
                   thickness_mm: float | None = None,
                   observer: Observer | None = None) -> NDArray[np.float64]:
    """XYZ of mixtures (eq. 7 on R + T) at ``thickness_mm`` (default: the profile's reference)."""
    t = profile.colour_thickness_mm if thickness_mm is None else thickness_mm
    obs = observer or observer_for(profile.wavelengths_nm)
    K, S = mix(_concentrations(profile, concentrations), profile.K, profile.S)
    R, T = reflectance_transmittance(K, S, t)
    return obs.spectra_to_XYZ(R + T)


def predict(profile: InkProfile, concentrations: ArrayLike, thickness_mm: float | None = None,
            saunderson: tuple[float, float] | None = None) -> Prediction:
    """Spectra, colour and density of mixtures.

    Parameters
    ----------
    concentrations : array_like, shape (..., 6) in ``INKS`` order (or (..., 5) without Clear)
    thickness_mm : float, optional
        Layer thickness for R, T and the colour; ``inf`` for an optically thick layer. Default:
        the profile's ``colour_thickness_mm``.
    saunderson : (k1, k2), optional
        Predict what an instrument measures (surface reflections); off by default.
    """
    t = profile.colour_thickness_mm if thickness_mm is None else float(thickness_mm)
    c = _concentrations(profile, concentrations)
    K, S = mix(c, profile.K, profile.S)
    R, T = reflectance_transmittance(K, S, t)
    if saunderson is not None:
        R, T = _saunderson.apply(R, T, *saunderson)
    obs = observer_for(profile.wavelengths_nm)
    XYZ = obs.spectra_to_XYZ(R + T)
    sigma = scalar_sigma(K, S, profile.layer_thickness_mm, profile.density_t_max_mm,
                         profile.density_samples)
    return Prediction(profile.wavelengths_nm, R, T, XYZ, obs.XYZ_to_Lab(XYZ),
                      obs.XYZ_to_sRGB(XYZ), np.asarray(sigma), t)
