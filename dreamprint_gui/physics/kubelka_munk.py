"""Kubelka-Munk two-flux model: reflectance and transmittance of a layer, and ink mixing.

Defines
-------
- :func:`reflectance_transmittance`: R and T of a layer of thickness t (paper eqs. 3-4).
- :func:`reflectance_infinite`: R_inf of an optically thick layer.
- :func:`mix`: K and S of a mixture, linear in the concentrations (paper eq. 5).
- :func:`invert_closed_form`: K and S from one layer's R and T (Kubelka 1948's explicit
  inverse of eqs. 3-4: ``a = (1 + R^2 - T^2)/(2R)``, ``b = sqrt(a^2 - 1)``,
  ``S = ln((1 - R(a - b))/T)/(b t)``, ``K = S(a - 1)``).

All functions broadcast over leading dimensions (mixtures x wavelengths). K and S are in 1/mm
and t in mm; only the products K t and S t matter.

References
----------
- Kubelka, P. (1948). New contributions to the optics of intensely light-scattering
  materials. Part I. JOSA 38(5), 448-457.
- Abdul-Rahman, Chen (2005). Spectral volume rendering based on the Kubelka-Munk theory.
  (The paper's eqs. 3-4.)
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["reflectance_transmittance", "reflectance_infinite", "mix", "attenuation",
           "layer_rt", "invert_closed_form"]

_SMALL_X = 1e-4


def attenuation(K: ArrayLike, S: ArrayLike) -> NDArray[np.float64]:
    """Asymptotic attenuation coefficient ``b S = sqrt(K^2 + 2 K S)`` in 1/mm.

    Written without the ratio K/S so that it stays finite when S -> 0 (then it is K, the
    Beer-Lambert coefficient).
    """
    K = np.asarray(K, dtype=np.float64)
    S = np.asarray(S, dtype=np.float64)
    return np.sqrt(K * K + 2.0 * K * S)


def reflectance_transmittance(
    K: ArrayLike, S: ArrayLike, t: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Reflectance and transmittance of a layer of thickness ``t`` (paper eqs. 3-4).

    ``R = sinh(bSt) / (a sinh(bSt) + b cosh(bSt))``, ``T = b / (a sinh(bSt) + b cosh(bSt))``
    with ``a = (S + K) / S`` and ``b = sqrt(a^2 - 1)``.

    Evaluated in the algebraically equal form (divide by ``b cosh(bSt)`` and multiply by S)::

        x = sqrt(K^2 + 2KS) t,   q = (S + K) t tanh(x)/x + 1
        R = S t tanh(x)/x / q,   T = sech(x) / q

    which has no division by S or b, so the limits are exact and free of NaN or overflow:
    S -> 0 gives R = 0, T = exp(-K t) (Beer-Lambert); K -> 0 gives R = S t / (1 + S t),
    T = 1 / (1 + S t); t -> 0 gives R = 0, T = 1; t = inf gives :func:`reflectance_infinite`
    and T = 0; large b S t saturates to R_inf through tanh.

    Parameters
    ----------
    K, S : array_like
        Absorption and scattering coefficients in 1/mm, >= 0, broadcastable.
    t : array_like
        Layer thickness in mm, >= 0; ``np.inf`` allowed.

    Returns
    -------
    R, T : ndarray
        Broadcast shape of the inputs.
    """
    K = np.asarray(K, dtype=np.float64)
    S = np.asarray(S, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    K, S, t = np.broadcast_arrays(K, S, t)
    beta = attenuation(K, S)
    infinite = np.isinf(t)
    t_fin = np.where(infinite, 0.0, t)
    x = beta * t_fin
    small = x < _SMALL_X
    xs = np.minimum(x, _SMALL_X)
    with np.errstate(invalid="ignore", divide="ignore", under="ignore"):
        # t * tanh(x)/x, bounded by 1/beta: no overflow for any t.
        tt = np.where(small, t_fin * (1.0 - xs * xs / 3.0), np.tanh(x) / np.where(small, 1.0, beta))
        e = np.exp(-x)
        sech = 2.0 * e / (1.0 + e * e)
    q = (S + K) * tt + 1.0
    R = S * tt / q
    T = sech / q
    if np.any(infinite):
        R = np.where(infinite, reflectance_infinite(K, S), R)
        empty = (K == 0.0) & (S == 0.0)  # an infinite layer of nothing transmits all
        T = np.where(infinite, np.where(empty, 1.0, 0.0), T)
    return R, T


@numba.njit(cache=True, nogil=True)
def layer_rt(k: float, s: float, t: float) -> tuple[float, float]:
    """R and T of one wavelength: the compiled scalar twin of :func:`reflectance_transmittance`
    (same stable form and limits), for kernels that loop over mixtures and wavelengths."""
    beta = math.sqrt(k * k + 2.0 * k * s)
    if math.isinf(t):
        d = s + k + beta
        return (s / d if d > 0.0 else 0.0), (1.0 if d == 0.0 else 0.0)
    x = beta * t
    if x < _SMALL_X:
        tt = t * (1.0 - x * x / 3.0)
    else:
        tt = math.tanh(x) / beta
    e = math.exp(-x)
    q = (s + k) * tt + 1.0
    return s * tt / q, 2.0 * e / (1.0 + e * e) / q


def reflectance_infinite(K: ArrayLike, S: ArrayLike) -> NDArray[np.float64]:
    """Reflectance of an optically thick layer, ``R_inf = a - b = 1 + K/S - sqrt((K/S)^2 + 2K/S)``.

    Evaluated as ``S / (S + K + sqrt(K^2 + 2KS))`` (equal to ``1 / (a + b)``), which is 0 for a
    non-scattering medium and 1 for a non-absorbing one. ``K = S = 0`` (nothing there) gives 0.
    """
    K = np.asarray(K, dtype=np.float64)
    S = np.asarray(S, dtype=np.float64)
    denom = S + K + attenuation(K, S)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(denom > 0.0, S / np.where(denom > 0.0, denom, 1.0), 0.0)


def mix(concentrations: ArrayLike, K_inks: ArrayLike, S_inks: ArrayLike
        ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """K and S of mixtures: ``K_C = sum_i c_i K_i``, ``S_C = sum_i c_i S_i`` (paper eq. 5).

    Parameters
    ----------
    concentrations : array_like, shape (..., n_inks)
    K_inks, S_inks : array_like, shape (n_inks, n_wavelengths)

    Returns
    -------
    K, S : ndarray, shape (..., n_wavelengths)
    """
    c = np.asarray(concentrations, dtype=np.float64)
    return c @ np.asarray(K_inks, dtype=np.float64), c @ np.asarray(S_inks, dtype=np.float64)


def invert_closed_form(R: ArrayLike, T: ArrayLike, t: float
                       ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """K and S (1/mm) from R and T (fractions) of one layer of thickness ``t`` mm.

    Exact inverse of :func:`reflectance_transmittance`
    where it exists (``R >= 0, T > 0, R + T <= 1``). With ``R = 0`` the layer does not scatter:
    ``S = 0, K = -ln(T)/t``. Where the data are impossible (R + T > 1, T = 0) the result is NaN;
    the fits (:func:`~dreamprint_gui.physics.calibration.fit_ink`,
    :func:`~dreamprint_gui.physics.slab_fit.fit_slabs`) then start elsewhere.
    """
    R = np.asarray(R, dtype=np.float64)
    T = np.asarray(T, dtype=np.float64)
    if t <= 0:
        raise ValueError("thickness must be > 0")
    with np.errstate(divide="ignore", invalid="ignore"):
        scatters = R > 1e-12
        Rs = np.where(scatters, R, 1.0)
        a = (1.0 + Rs * Rs - T * T) / (2.0 * Rs)
        b = np.sqrt(a * a - 1.0)
        # R (a - b) = R / (a + b) avoids cancellation when a is large (weak scattering).
        S = np.log((1.0 - Rs / (a + b)) / T) / (b * t)
        K = S * (a - 1.0)
        # a -> 1 (no absorption): S t -> R / T and K -> 0, the 0/0 of the general form.
        lossless = np.abs(a - 1.0) < 1e-12
        S = np.where(lossless, Rs / (T * t), S)
        K = np.where(lossless, 0.0, K)
        K = np.where(scatters, K, -np.log(T) / t)
        S = np.where(scatters, S, 0.0)
    bad = (T <= 0) | (R < 0) | (R + T > 1.0 + 1e-12) | ~np.isfinite(K) | ~np.isfinite(S)
    return np.where(bad, np.nan, K), np.where(bad, np.nan, S)
