"""Kubelka-Munk K, S -> radiative-transfer sigma_a, sigma_s and phase function (print proof).

Defines :func:`rte_coefficients` (the proof's conversion), :func:`gate_coefficients` (the
textbook relation it corrects), :data:`MAP_GEOMETRY`, and re-exports :func:`parse_phase`.

Why a correction. The inks' K and S (built-in, ``calibrate``, ``calibrate --chart``) are fitted
so that Kubelka-Munk's ``R_inf(K/S)`` equals an instrument's reading of an optically thick
patch; the proof renders the radiative transfer equation (RTE). The textbook relation (Gate
1974; Thennadil 2008, diffuse incidence)::

    sigma_a = K / 2,      sigma_s = 4 S / (3 (1 - g))                                  (gate)

matches KM's hemispherical fluxes (a slab's R and T within 0.02, ``test_km_to_rte.py``), but an
instrument reads one direction: the RTE's radiance at 8 degrees off the normal of a thick White
patch is up to 0.06 below ``R_inf`` (the exit radiance is not Lambertian), and on 70 real printed
mixtures the chart proof with this relation was 3.07 mean dE2000 where KM of the same K and S
was 0.87. So the proof's conversion keeps the reading instead (``rte_coefficients``): per
mixture and band,

    1. ``x = K / S``, the target ``R = R_inf(x) = 1 + x - sqrt(x^2 + 2 x)`` (eq. 7's limit);
    2. the albedo ``omega`` whose thick patch reads ``R`` at the instrument geometry, through the
       proof's surface and phase function: the inverse of :mod:`.thick_patch`'s curve (the
       exact H-function solution for isotropic scattering without a surface, else a curve
       rendered once by the proof's own renderer and cached);
    3. the scale from Gate's relation: the transport extinction
       ``sigma_a + sigma_s (1 - g) = K / 2 + 4 S / 3`` is kept (the diffusion length and the
       mean free path of the transport stay Gate's), split by ``omega``::

           sigma_s = t omega / ((1 - omega) + (1 - g) omega),
           sigma_a = t (1 - omega) / ((1 - omega) + (1 - g) omega),   t = K / 2 + 4 S / 3.

Both limits are Gate's exactly: a pure absorber (S = 0: omega = 0, sigma_a = K / 2; the Clear
ink, the straight-through light) and a lossless scatterer (K = 0: omega = 1,
sigma_s (1 - g) = 4 S / 3). The map is homogeneous of degree 1 in (K, S), so a cell part empty
(air) keeps its albedo. It is applied to a mixture's K and S (mixed linearly first, paper eq. 5,
as the tables do), not per ink, so every thick mixture renders its KM ``R_inf`` whatever its
recipe (``tests/proof/test_chart.py``), which is the colour the job's tables
(:mod:`dreamprint_gui.gamut.forward`) promise. What it leaves free is only what a thick patch
cannot show: thin layers and edges (translucency), measured in ``tests/proof/test_km_to_rte.py``.

Where the curve cannot reach a reading, the albedo is clamped: a surface's own reflection at
d:8 (specular included, 0.04 for n 1.5) is a floor no darker reading can go below, and the
``matte`` BSDF's energy loss a ceiling.

The instrument geometry (``d:8`` or ``45:0``) is the chart proof's ``--geometry``; the object
proof uses :data:`MAP_GEOMETRY` (d:8).

References
----------
- Chandrasekhar, S. (1960). Radiative Transfer. Dover, ch. IV-V (H-function).
- Gate, L. F. (1974). Comparison of the photon diffusion model and Kubelka-Munk equation with
  the exact solution of the radiative transport equation. Appl. Opt. 13(2), 236-238.
- Thennadil, S. N. (2008). Relationship between the Kubelka-Munk scattering and radiative
  transfer coefficients. JOSA A 25(7), 1480-1485.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dreamprint_gui.proof.optics import MAX_ABS_G, Optics, parse_phase, phase_name
from dreamprint_gui.proof.thick_patch import ThickCurve, thick_curve

__all__ = ["rte_coefficients", "gate_coefficients", "describe_conversion",
           "km_target_reflectance", "parse_phase", "phase_name", "K_PER_SIGMA_A",
           "S_PER_SIGMA_S", "PHASE", "MAX_ABS_G", "MAP_GEOMETRY"]

K_PER_SIGMA_A = 2.0
S_PER_SIGMA_S = 0.75
PHASE = "isotropic"
MAP_GEOMETRY = "d:8"


def gate_coefficients(K: ArrayLike, S: ArrayLike, g: float = 0.0
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Gate's ``(sigma_a, sigma_s)`` in 1/mm of KM ``K``, ``S`` in 1/mm (broadcast), for a
    Henyey-Greenstein phase function of asymmetry ``g`` (0: isotropic)."""
    K = np.asarray(K, dtype=np.float64)
    S = np.asarray(S, dtype=np.float64)
    return K / K_PER_SIGMA_A, S / (S_PER_SIGMA_S * (1.0 - float(g)))


def km_target_reflectance(K: ArrayLike, S: ArrayLike) -> NDArray[np.float64]:
    """KM's ``R_inf`` of ``K``, ``S`` (0 where S = 0, 1 where K = 0 < S), computed stably as
    ``1 / (1 + x + sqrt(x^2 + 2 x))``."""
    K = np.asarray(K, dtype=np.float64)
    S = np.asarray(S, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        x = K / S
        R = 1.0 / (1.0 + x + np.sqrt(x * x + 2.0 * x))
    return np.where(S > 0, R, 0.0)


def rte_coefficients(K: ArrayLike, S: ArrayLike, optics: Optics | float = 0.0,
                     geometry: str = MAP_GEOMETRY, curve: ThickCurve | None = None
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(sigma_a, sigma_s)`` in 1/mm of mixtures' KM ``K``, ``S`` (1/mm, broadcast) such that
    an optically thick patch reads KM's ``R_inf`` at ``geometry`` through ``optics`` (an
    :class:`~.optics.Optics`, or a phase asymmetry g without a surface); steps above.
    ``curve`` overrides the thick-patch curve (tests)."""
    o = optics if isinstance(optics, Optics) else Optics("none", g=float(optics))
    c = curve if curve is not None else thick_curve(o, geometry)
    K = np.asarray(K, dtype=np.float64)
    S = np.asarray(S, dtype=np.float64)
    K, S = np.broadcast_arrays(K, S)
    omega = c.albedo_for(km_target_reflectance(K, S))
    omega = np.where((K <= 0) & (S > 0), 1.0, omega)    # lossless: no absorption at all
    t = K / K_PER_SIGMA_A + S / S_PER_SIGMA_S
    g = float(o.g)
    den = (1.0 - omega) + (1.0 - g) * omega
    return t * (1.0 - omega) / den, t * omega / den


def describe_conversion(optics: Optics, geometry: str = MAP_GEOMETRY) -> dict:
    """What ``proof.json`` and ``chart_proof.json`` say about the conversion."""
    return {"rule": "per mixture and band, the albedo whose optically thick patch reads KM's "
                    "R_inf(K/S) at the geometry through the surface and phase; transport "
                    "extinction sigma_a + sigma_s (1 - g) = K / 2 + 4 S / 3 (Gate's) kept",
            "geometry": geometry, "phase": optics.describe()["phase"], "g": optics.g,
            "surface": optics.surface,
            "thick_patch_curve": thick_curve(optics, geometry).source,
            "reference": "Chandrasekhar 1960 (H-function); Gate 1974; Thennadil 2008"}
