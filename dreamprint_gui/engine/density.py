"""Density of a mixture: exponential fit of T(t) per wavelength and the scalar sigma (eqs. 8-9).

Defines
-------
- :func:`fit_sigma_per_wavelength`: ``sigma_hat(lambda) = argmin_sigma sum_t (exp(-sigma t) -
  T(lambda, t))^2`` over ``n_samples`` thicknesses uniform in ``[0, t_max]`` (paper eq. 8, the
  integral approximated by the paper's own 100-sample rule).
- :func:`scalar_sigma`: the mixture's single sigma (paper eq. 9, sign corrected).
- :func:`exp_fit_errors`: the paper's Table 1 metrics.

Paper eq. 9 is printed as ``sigma_C = ln(mean_lambda exp(-sigma_hat(lambda * dt))) / dt``. Two
misprints: the argument is ``sigma_hat(lambda) * dt`` and the log needs a minus sign (the mean
transmittance of one layer is < 1, so the printed form gives a negative density). Implemented:
``sigma_C = -ln(mean_lambda exp(-sigma_hat(lambda) dt)) / dt``, the extinction of a grey medium
that lets through, over one layer dt, the same wavelength-averaged fraction of light.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .kubelka_munk import attenuation, reflectance_transmittance

__all__ = ["fit_sigma_per_wavelength", "scalar_sigma", "exp_fit_errors", "sigma_from_sigma_hat"]

DEFAULT_T_MAX_MM = 5.0
DEFAULT_SAMPLES = 100
_CHUNK_VALUES = 4_000_000


def _thicknesses(t_max: float, n: int) -> NDArray[np.float64]:
    return np.linspace(0.0, t_max, n)


def fit_sigma_per_wavelength(
    K: ArrayLike, S: ArrayLike, t_max: float = DEFAULT_T_MAX_MM, n_samples: int = DEFAULT_SAMPLES,
    iterations: int = 30,
) -> NDArray[np.float64]:
    """Least-squares extinction ``sigma_hat`` (1/mm) of ``exp(-sigma t)`` to KM ``T(t)`` (eq. 8).

    Vectorised over the broadcast shape of K and S. Solved by a safeguarded Newton iteration on
    ``u = ln sigma`` started between the two physical bounds of the answer: the initial slope
    ``K + S`` of T at t = 0 and the asymptotic attenuation ``sqrt(K^2 + 2KS)``. ``sigma = 0``
    where K = 0 and S = 0.
    """
    K = np.asarray(K, dtype=np.float64)
    S = np.asarray(S, dtype=np.float64)
    K, S = np.broadcast_arrays(K, S)
    t = _thicknesses(t_max, n_samples)
    k, s = K.ravel(), S.ravel()
    out = np.empty(k.size)
    step = max(1, _CHUNK_VALUES // n_samples)  # bounded memory for millions of mixtures
    for a in range(0, k.size, step):
        kk, ss = k[a:a + step], s[a:a + step]
        _, T = reflectance_transmittance(kk[:, None], ss[:, None], t)
        out[a:a + step] = _fit_exp(T, t, kk + ss, attenuation(kk, ss), iterations)
    return out.reshape(K.shape)


def _fit_exp(T: NDArray, t: NDArray, upper: NDArray, lower: NDArray, iterations: int) -> NDArray:
    empty = upper <= 0.0
    sigma0 = np.sqrt(np.maximum(upper, 1e-300) * np.maximum(lower, 1e-300))
    sigma0 = np.where(lower > 0, sigma0, np.maximum(upper, 1e-12))
    u = np.log(np.maximum(sigma0, 1e-12))

    def objective(u_: NDArray) -> NDArray:
        r = np.exp(-np.exp(u_)[..., None] * t) - T
        return np.einsum("...i,...i->...", r, r)

    f = objective(u)
    for _ in range(iterations):
        sig = np.exp(u)[..., None]
        e = np.exp(-sig * t)
        r = e - T
        de = -sig * t * e  # d e / d u
        d2e = -sig * t * e * (1.0 - sig * t)
        g = np.einsum("...i,...i->...", r, de)
        h = np.einsum("...i,...i->...", de, de) + np.einsum("...i,...i->...", r, d2e)
        gn = np.einsum("...i,...i->...", de, de)
        # Newton where the curvature is positive, Gauss-Newton otherwise; step capped in ln.
        step = -g / np.where(h > 0, h, np.maximum(gn, 1e-300))
        step = np.clip(np.nan_to_num(step), -2.0, 2.0)
        for _halve in range(8):
            trial = u + step
            f_trial = objective(trial)
            better = f_trial <= f
            if np.all(better | (np.abs(step) < 1e-15)):
                break
            step = np.where(better, step, 0.5 * step)
        trial = u + step
        f_trial = objective(trial)
        accept = f_trial <= f
        u = np.where(accept, trial, u)
        f = np.where(accept, f_trial, f)
        if np.all(np.abs(step) < 1e-13):
            break
    return np.where(empty, 0.0, np.exp(u))


def sigma_from_sigma_hat(sigma_hat: ArrayLike, dt: float) -> NDArray[np.float64]:
    """Scalar density from per-wavelength extinctions (paper eq. 9, sign corrected).

    ``sigma = -ln(mean_lambda exp(-sigma_hat(lambda) dt)) / dt``; the last axis is wavelength.
    """
    sh = np.asarray(sigma_hat, dtype=np.float64)
    if dt <= 0:
        raise ValueError("the layer thickness dt must be > 0")
    mean_t = np.mean(np.exp(-sh * dt), axis=-1)
    return -np.log(mean_t) / dt


def scalar_sigma(K: ArrayLike, S: ArrayLike, dt: float, t_max: float = DEFAULT_T_MAX_MM,
                 n_samples: int = DEFAULT_SAMPLES) -> NDArray[np.float64]:
    """Scalar density (1/mm) of mixtures with K, S of shape (..., n_wavelengths) (eqs. 8-9)."""
    return sigma_from_sigma_hat(fit_sigma_per_wavelength(K, S, t_max, n_samples), dt)


def exp_fit_errors(K: ArrayLike, S: ArrayLike, t_max: float = DEFAULT_T_MAX_MM,
                   n_samples: int = DEFAULT_SAMPLES) -> tuple[NDArray, NDArray]:
    """The paper's Table 1 for inks with K, S of shape (..., n_wavelengths).

    Returns ``(mean, worst)``: the mean absolute error ``|exp(-sigma_hat t) - T(t)|`` over the
    sampled thicknesses and all wavelengths, and the same mean over thicknesses at the worst
    wavelength. Fractions (multiply by 100 for the paper's percent).
    """
    K = np.asarray(K, dtype=np.float64)
    S = np.asarray(S, dtype=np.float64)
    t = _thicknesses(t_max, n_samples)
    sigma_hat = fit_sigma_per_wavelength(K, S, t_max, n_samples)
    _, T = reflectance_transmittance(K[..., None], S[..., None], t)
    err = np.abs(np.exp(-sigma_hat[..., None] * t) - T).mean(axis=-1)
    return err.mean(axis=-1), err.max(axis=-1)
