"""The K/W grey of matching brightness (paper eq. 11) and the 100-entry brightness table.

Defines
-------
- :func:`grey_brightness`: brightness (mean of the encoded sRGB channels, eq. 11's bar r) of the
  grey ``C_X(rho) = rho K + (1 - rho) W`` at the profile's reference thickness (eq. 7).
- :func:`brightness_table`: ``rho_K`` for brightness ``b_j = j / (n - 1)``, ``j = 0..n-1``
  (n = 100, section 4.2), the solution of eq. 11 by bisection on the exact forward model (the
  grey's brightness falls monotonically as black replaces white). Brightness outside the greys'
  range clamps to pure K (darker) or pure W (brighter).
- :func:`rho_k_for`: linear interpolation in that table.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dreamprint_gui.core.profile import INKS, InkProfile
from dreamprint_gui.physics.colorimetry import observer_for
from dreamprint_gui.physics.mixture import mixture_colour

__all__ = ["grey_brightness", "brightness_table", "rho_k_for", "grey_concentrations",
           "BRIGHTNESS_TABLE_SIZE"]

BRIGHTNESS_TABLE_SIZE = 100


def grey_concentrations(rho_k: ArrayLike) -> NDArray[np.float64]:
    """Six-ink concentrations of the virtual grey X: ``rho`` black, ``1 - rho`` white."""
    r = np.asarray(rho_k, dtype=np.float64)
    c = np.zeros(r.shape + (len(INKS),))
    c[..., INKS.index("K")] = r
    c[..., INKS.index("W")] = 1.0 - r
    return c


def grey_brightness(profile: InkProfile, rho_k: ArrayLike) -> NDArray[np.float64]:
    obs = observer_for(profile.wavelengths_nm)
    srgb = obs.XYZ_to_sRGB(mixture_colour(profile, grey_concentrations(rho_k), observer=obs))
    return srgb.mean(axis=-1)


def brightness_table(profile: InkProfile, n: int = BRIGHTNESS_TABLE_SIZE) -> NDArray[np.float64]:
    b = np.linspace(0.0, 1.0, n)
    lo = np.zeros(n)  # rho = 0: pure white, the brightest grey
    hi = np.ones(n)
    for _ in range(52):  # bisection to double precision
        mid = 0.5 * (lo + hi)
        too_bright = grey_brightness(profile, mid) > b
        lo = np.where(too_bright, mid, lo)
        hi = np.where(too_bright, hi, mid)
    return 0.5 * (lo + hi)


def rho_k_for(table: NDArray, brightness: ArrayLike) -> NDArray[np.float64]:
    """``rho_K`` of eq. 11 for target brightness in [0, 1] (linear in the table)."""
    b = np.clip(np.asarray(brightness, dtype=np.float64), 0.0, 1.0)
    return np.interp(b, np.linspace(0.0, 1.0, table.shape[0]), table)
