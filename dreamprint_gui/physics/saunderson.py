"""Saunderson surface correction: what an instrument measures from a layer's internal R and T.

``R_m = k1 + (1 - k1)(1 - k2) R / (1 - k2 R)`` and ``T_m = (1 - k1)(1 - k2) T / (1 - k2 R)``;
k1 is the external (specular) reflectance of the surface, k2 the internal reflectance of
diffuse light at it (about 0.04 and 0.6 for a resin of refractive index 1.5).

Off by default: the paper's eq. 7 uses the model's R + T directly.

A free-standing slab measured in air has that surface on both faces. :func:`slab_apply` adds the
back face to the bulk first (the adding rule for diffuse fluxes), then the front face::

    R_b = R + k2 T^2 / (1 - k2 R),           T_b = (1 - k2) T / (1 - k2 R)
    R_m = k1 + (1 - k1)(1 - k2) R_b / (1 - k2 R_b),   T_m = (1 - k1) T_b / (1 - k2 R_b)

(a lossless bulk, R = 0 and T = 1, gives R_m + T_m = 1); :func:`slab_remove` is its exact
inverse (R_b is linear in R once T is eliminated). :func:`fresnel_k1` and
:func:`diffuse_internal_k2` give k1 and k2 from the refractive index: k1 the normal-incidence
Fresnel reflectance ``((n - 1)/(n + 1))^2``, k2 the Fresnel reflectance averaged over a
Lambertian (cosine-weighted) hemisphere inside, ``1 - (1 - r_e)/n^2`` with r_e the same average
outside (0.040 and 0.596 at n = 1.5). Fresnel's equations are written out here (numpy only):
no maintained library exposes the hemispherical average.

Reference: Saunderson, J. L. (1942). Calculation of the color of pigmented plastics.
JOSA 32(12), 727-736.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["apply", "remove", "slab_apply", "slab_remove", "fresnel_k1",
           "diffuse_internal_k2"]


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


def slab_apply(R: ArrayLike, T: ArrayLike, k1: float, k2: float
               ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Measured (R_m, T_m) of a slab in air from its bulk's internal (R, T): both faces."""
    _check(k1, k2)
    R = np.asarray(R, dtype=np.float64)
    T = np.asarray(T, dtype=np.float64)
    d = 1.0 - k2 * R
    Rb = R + k2 * T * T / d
    Tb = (1.0 - k2) * T / d
    db = 1.0 - k2 * Rb
    return k1 + (1.0 - k1) * (1.0 - k2) * Rb / db, (1.0 - k1) * Tb / db


def slab_remove(R_m: ArrayLike, T_m: ArrayLike, k1: float, k2: float
                ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The bulk's internal (R, T) from a slab's measured (R_m, T_m): inverse of
    :func:`slab_apply` (front face removed as :func:`remove`, then the back face:
    ``R = (R_b - k2 c)/(1 - k2^2 c)`` with ``c = (T_b/(1 - k2))^2``)."""
    _check(k1, k2)
    R_m = np.asarray(R_m, dtype=np.float64)
    T_m = np.asarray(T_m, dtype=np.float64)
    x = R_m - k1
    Rb = x / ((1.0 - k1) * (1.0 - k2) + k2 * x)
    Tb = T_m * (1.0 - k2 * Rb) / (1.0 - k1)
    c = (Tb / (1.0 - k2)) ** 2
    R = (Rb - k2 * c) / (1.0 - k2 * k2 * c)
    return R, Tb * (1.0 - k2 * R) / (1.0 - k2)


def _fresnel_unpolarised(cos_i: NDArray[np.float64], n: float) -> NDArray[np.float64]:
    """Fresnel reflectance of unpolarised light arriving at cos_i from the medium of index 1
    onto index n (n < 1: from inside a denser medium); 1 beyond the critical angle."""
    sin_t2 = (1.0 - cos_i * cos_i) / (n * n)
    tir = sin_t2 >= 1.0
    cos_t = np.sqrt(np.clip(1.0 - sin_t2, 0.0, 1.0))
    rs = (cos_i - n * cos_t) / (cos_i + n * cos_t)
    rp = (n * cos_i - cos_t) / (n * cos_i + cos_t)
    return np.where(tir, 1.0, 0.5 * (rs * rs + rp * rp))


def fresnel_k1(n: float) -> float:
    """k1: the normal-incidence Fresnel reflectance ``((n - 1)/(n + 1))^2`` of a surface."""
    if not 1.0 <= n <= 3.0:
        raise ValueError(f"refractive index must lie in [1, 3], got {n}")
    return ((n - 1.0) / (n + 1.0)) ** 2


def diffuse_internal_k2(n: float) -> float:
    """k2: reflectance of Lambertian light inside a medium of index n at its surface,
    ``2 int_0^1 r(mu) mu dmu`` over the internal angles (total reflection included), computed
    as ``1 - (1 - r_e)/n^2`` from the external average r_e (reciprocity; Judd 1942)."""
    if not 1.0 <= n <= 3.0:
        raise ValueError(f"refractive index must lie in [1, 3], got {n}")
    mu, w = np.polynomial.legendre.leggauss(200)
    mu = 0.5 * (mu + 1.0)
    r_e = float(np.sum(w * _fresnel_unpolarised(mu, n) * mu))  # 2 int r mu dmu, w sums to 2
    return 1.0 - (1.0 - r_e) / (n * n)
