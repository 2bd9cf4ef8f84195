"""Saunderson surface correction: what an instrument measures from a layer's internal R and T.

``R_m = k1 + (1 - k1)(1 - k2) R / (1 - k2 R)`` and ``T_m = (1 - k1)(1 - k2) T / (1 - k2 R)``;
k1 is the external (specular) reflectance of the surface, k2 the internal reflectance of
diffuse light at it (about 0.04 and 0.6 for a resin of refractive index 1.5).

Off by default: the paper's eq. 7 uses the model's R + T directly.

Reference: Saunderson, J. L. (1942). Calculation of the color of pigmented plastics.
JOSA 32(12), 727-736.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["apply", "remove"]


def _check(k1: float, k2: float) -> None:
    if not (0.0 <= k1 < 1.0 and 0.0 <= k2 < 1.0):
        raise ValueError(f"Saunderson coefficients must lie in [0, 1): k1={k1}, k2={k2}")


def apply(R: ArrayLike, T: ArrayLike, k1: float, k2: float
          ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Measured (R_m, T_m) from internal (R, T)."""
    _check(k1, k2)
    R = np.asarray(R, dtype=np.float64)
    T = np.asarray(T, dtype=np.float64)
    d = 1.0 - k2 * R
    g = (1.0 - k1) * (1.0 - k2)
    return k1 + g * R / d, g * T / d


def remove(R_m: ArrayLike, T_m: ArrayLike, k1: float, k2: float
           ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Internal (R, T) from measured (R_m, T_m): the inverse of :func:`apply`."""
    _check(k1, k2)
    R_m = np.asarray(R_m, dtype=np.float64)
    T_m = np.asarray(T_m, dtype=np.float64)
    g = (1.0 - k1) * (1.0 - k2)
    x = R_m - k1
    R = x / (g + k2 * x)
    return R, T_m * (1.0 - k2 * R) / g
