"""Compiled forward model of the colour of C, M, Y, K, W mixtures, with its Jacobian.

Defines
-------
- :class:`ForwardModel`: the profile's K, S, observer weights and colour-space constants packed
  as arrays for the numba kernels; :func:`forward_model` builds it.
- :func:`mixtures_xyz`: XYZ of many mixtures (vectorised, numba), equal to
  :func:`dreamprint_gui.physics.mixture.mixture_colour` to ~1e-15 (same formulas, same order).
- numba helpers used by the optimiser: ``spectrum_and_jacobian`` (R + T at the profile's
  reference thickness and its derivative by concentration), ``xyz_to_lab_jac``,
  ``xyz_to_srgb_jac`` (CIELAB / encoded sRGB and their derivatives).

The colour is paper eq. 7 on R + T (eqs. 3-5) at ``profile.colour_thickness_mm``; for the default
R_inf the Jacobian is analytic, for a finite reference thickness it is a forward difference (only
the optimiser's step uses it; the residual is exact).

References: CIE 015:2018 (CIELAB); IEC 61966-2-1 (sRGB transfer function).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba as nb
import numpy as np
from numpy.typing import ArrayLike, NDArray

from dreamprint_gui.core.profile import InkProfile
from dreamprint_gui.physics.colorimetry import observer_for
from dreamprint_gui.physics.kubelka_munk import layer_rt

__all__ = ["ForwardModel", "forward_model", "mixtures_xyz", "mixtures_lab", "mixtures_srgb"]

N_COLOUR_INKS = 5
_LAB_EPS = 216.0 / 24389.0
_LAB_KAPPA = 24389.0 / 27.0


@dataclass(frozen=True)
class ForwardModel:
    """Arrays the compiled kernels need; ``K``, ``S`` of the five colour inks (5, n_wl)."""

    K: NDArray[np.float64]
    S: NDArray[np.float64]
    K_clear: NDArray[np.float64]
    S_clear: NDArray[np.float64]
    weights: NDArray[np.float64]  # (n_wl, 3) CMF x D65, Y(white) = 1
    white: NDArray[np.float64]  # (3,) XYZ of the perfect reflector
    xyz_to_rgb: NDArray[np.float64]  # (3, 3) to linear sRGB
    thickness_mm: float  # inf = R_inf


def forward_model(profile: InkProfile) -> ForwardModel:
    obs = observer_for(profile.wavelengths_nm)
    K = np.ascontiguousarray(profile.K[:N_COLOUR_INKS], dtype=np.float64)
    S = np.ascontiguousarray(profile.S[:N_COLOUR_INKS], dtype=np.float64)
    return ForwardModel(K, S, np.ascontiguousarray(profile.K[N_COLOUR_INKS]),
                        np.ascontiguousarray(profile.S[N_COLOUR_INKS]),
                        np.ascontiguousarray(obs.weights, dtype=np.float64),
                        np.asarray(obs.white_XYZ, dtype=np.float64),
                        np.ascontiguousarray(obs.xyz_to_linear_srgb, dtype=np.float64),
                        float(profile.colour_thickness_mm))


@nb.njit(cache=True, fastmath=False)
def _layer_rt(k: float, s: float, t: float) -> float:
    """R + T of one wavelength (eqs. 3-4, R_inf at t = inf; colour is eq. 7 on R + T)."""
    r, tr = layer_rt(k, s, t)
    return r + tr


@nb.njit(cache=True)
def spectrum_xyz(c, K, S, W, t, xyz):
    """XYZ of one mixture c (5,) into xyz (3,)."""
    n_ink, n_wl = K.shape
    xyz[0] = 0.0
    xyz[1] = 0.0
    xyz[2] = 0.0
    for j in range(n_wl):
        k = 0.0
        s = 0.0
        for i in range(n_ink):
            k += c[i] * K[i, j]
            s += c[i] * S[i, j]
        r = _layer_rt(k, s, t)
        xyz[0] += r * W[j, 0]
        xyz[1] += r * W[j, 1]
        xyz[2] += r * W[j, 2]


@nb.njit(cache=True)
def spectrum_xyz_jac(c, K, S, W, t, xyz, jac, tmp):
    """XYZ of one mixture and d XYZ / d c (3, 5) into ``jac``; ``tmp`` is scratch (5,)."""
    n_ink, n_wl = K.shape
    if not math.isinf(t):
        spectrum_xyz(c, K, S, W, t, xyz)
        h = 1e-7
        shifted = np.empty(3)
        for i in range(n_ink):
            for m in range(n_ink):
                tmp[m] = c[m]
            tmp[i] += h
            spectrum_xyz(tmp, K, S, W, t, shifted)
            for a in range(3):
                jac[a, i] = (shifted[a] - xyz[a]) / h
        return
    for a in range(3):
        xyz[a] = 0.0
        for i in range(n_ink):
            jac[a, i] = 0.0
    for j in range(n_wl):
        k = 0.0
        s = 0.0
        for i in range(n_ink):
            k += c[i] * K[i, j]
            s += c[i] * S[i, j]
        beta = math.sqrt(k * k + 2.0 * k * s)
        d = s + k + beta
        if d <= 0.0:
            continue
        r = s / d
        # R_inf = S / (S + K + beta), beta = sqrt(K^2 + 2KS)
        # d beta / d K = (K + S) / beta is unbounded as K -> 0 with S > 0; the floor keeps the
        # Gauss-Newton matrix finite there (the residual itself is exact).
        bs = max(beta, 1e-12)
        dr_dk = -s * (1.0 + (k + s) / bs) / (d * d)
        dr_ds = (d - s * (1.0 + k / bs)) / (d * d)
        w0 = W[j, 0]
        w1 = W[j, 1]
        w2 = W[j, 2]
        xyz[0] += r * w0
        xyz[1] += r * w1
        xyz[2] += r * w2
        for i in range(n_ink):
            g = dr_dk * K[i, j] + dr_ds * S[i, j]
            jac[0, i] += g * w0
            jac[1, i] += g * w1
            jac[2, i] += g * w2


@nb.njit(cache=True)
def _lab_f(t):
    if t > _LAB_EPS:
        return t ** (1.0 / 3.0)
    return (_LAB_KAPPA * t + 16.0) / 116.0


@nb.njit(cache=True)
def _lab_df(t):
    if t > _LAB_EPS:
        return (1.0 / 3.0) * max(t, 1e-300) ** (-2.0 / 3.0)
    return _LAB_KAPPA / 116.0


@nb.njit(cache=True)
def xyz_to_lab_jac(xyz, jxyz, white, out, jout):
    """CIELAB of xyz into out (3,), and d Lab / d c = d Lab / d XYZ @ jxyz into jout (3, n)."""
    fx = _lab_f(xyz[0] / white[0])
    fy = _lab_f(xyz[1] / white[1])
    fz = _lab_f(xyz[2] / white[2])
    out[0] = 116.0 * fy - 16.0
    out[1] = 500.0 * (fx - fy)
    out[2] = 200.0 * (fy - fz)
    dx = _lab_df(xyz[0] / white[0]) / white[0]
    dy = _lab_df(xyz[1] / white[1]) / white[1]
    dz = _lab_df(xyz[2] / white[2]) / white[2]
    for i in range(jxyz.shape[1]):
        gx = dx * jxyz[0, i]
        gy = dy * jxyz[1, i]
        gz = dz * jxyz[2, i]
        jout[0, i] = 116.0 * gy
        jout[1, i] = 500.0 * (gx - gy)
        jout[2, i] = 200.0 * (gy - gz)


@nb.njit(cache=True)
def _srgb_oetf(v):
    if v <= 0.0031308:
        return 12.92 * v
    return 1.055 * v ** (1.0 / 2.4) - 0.055


@nb.njit(cache=True)
def _srgb_doetf(v):
    if v <= 0.0031308:
        return 12.92
    return 1.055 / 2.4 * v ** (1.0 / 2.4 - 1.0)


@nb.njit(cache=True)
def xyz_to_srgb_jac(xyz, jxyz, m, out, jout):
    """Encoded (unclipped) sRGB of xyz into out, and its Jacobian by concentration into jout."""
    for a in range(3):
        lin = m[a, 0] * xyz[0] + m[a, 1] * xyz[1] + m[a, 2] * xyz[2]
        out[a] = _srgb_oetf(lin)
        d = _srgb_doetf(lin)
        for i in range(jxyz.shape[1]):
            jout[a, i] = d * (m[a, 0] * jxyz[0, i] + m[a, 1] * jxyz[1, i] + m[a, 2] * jxyz[2, i])


@nb.njit(cache=True, parallel=True)
def _xyz_many(conc, K, S, W, t, out):
    for n in nb.prange(conc.shape[0]):
        spectrum_xyz(conc[n], K, S, W, t, out[n])


def mixtures_xyz(model: ForwardModel, conc5: ArrayLike) -> NDArray[np.float64]:
    """XYZ (eq. 7 at the profile's reference thickness) of mixtures ``conc5`` (..., 5)."""
    c = np.asarray(conc5, dtype=np.float64)
    flat = np.ascontiguousarray(c.reshape(-1, N_COLOUR_INKS))
    out = np.empty((flat.shape[0], 3))
    _xyz_many(flat, model.K, model.S, model.weights, model.thickness_mm, out)
    return out.reshape(c.shape[:-1] + (3,))


def mixtures_lab(model: ForwardModel, conc5: ArrayLike) -> NDArray[np.float64]:
    import colour

    return colour.XYZ_to_Lab(mixtures_xyz(model, conc5), illuminant=colour.XYZ_to_xy(model.white))


def mixtures_srgb(model: ForwardModel, conc5: ArrayLike) -> NDArray[np.float64]:
    import colour

    return colour.models.eotf_inverse_sRGB(mixtures_xyz(model, conc5) @ model.xyz_to_rgb.T)
