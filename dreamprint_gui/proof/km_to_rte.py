"""Kubelka-Munk K, S -> radiative-transfer sigma_a, sigma_s and phase function (print proof).

Defines :func:`rte_coefficients`, :func:`parse_phase` and the constants of the relation.

The relation used (diffuse illumination, the regime the KM coefficients of the inks were fitted
in)::

    K = 2 sigma_a,        S = (3/4) sigma_s (1 - g)      =>
    sigma_a = K / 2,      sigma_s = 4 S / 3  with an isotropic phase function (g = 0).

The factor 2 is the mean path-length increase of diffuse light (each KM flux travels on average
twice the layer's thickness); 3/4 comes from matching KM to the diffusion approximation of the
RTE. Gate (1974) derived this pair for diffuse incidence, and Thennadil (2008), comparing it with
exact RTE solutions over a wide range of optical properties, found it the accurate one for
diffuse light (the variants with an absorption term in S, Star et al. 1988 and Brinkworth 1972,
were not). The inks' K and S carry no anisotropy: only the reduced scattering coefficient
``sigma_s' = sigma_s (1 - g)`` is determined by them. With a Henyey-Greenstein phase function
of asymmetry ``g`` (``--phase hg:G``; published PolyJet fits use g about 0.4) the reduced
coefficient is kept fixed (the similarity relation, which is exact in the diffusion regime KM
describes)::

    sigma_a = K / 2,      sigma_s = 4 S / (3 (1 - g)),    phase HG(g)

so a thick patch under diffuse light keeps its KM colour while light entering along one
direction (a key light, a thin layer) keeps its forward bias. ``isotropic`` is ``hg:0``.

Checked in ``tests/proof/test_km_to_rte.py`` against an independent Monte Carlo solution
of the plane-parallel RTE (diffuse incidence, isotropic scattering) for slabs of White, Cyan,
Black and Clear at 0.1-5 mm: R within 0.02 of KM (White R_inf 0.640 vs 0.637; 0.1 mm: 0.251
vs 0.231), T within 0.02 except thin strongly absorbing layers (Cyan, Black at 0.1 mm: T 0.12,
0.06 against KM's 0.06, 0.02: diffuse light through an absorber is 2 E3(sigma_a t), not
exp(-2 sigma_a t)).

References
----------
- Gate, L. F. (1974). Comparison of the photon diffusion model and Kubelka-Munk equation with
  the exact solution of the radiative transport equation. Appl. Opt. 13(2), 236-238.
- Thennadil, S. N. (2008). Relationship between the Kubelka-Munk scattering and radiative
  transfer coefficients. JOSA A 25(7), 1480-1485.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["rte_coefficients", "parse_phase", "phase_name", "K_PER_SIGMA_A", "S_PER_SIGMA_S",
           "PHASE", "MAX_ABS_G"]

K_PER_SIGMA_A = 2.0
S_PER_SIGMA_S = 0.75
PHASE = "isotropic"


MAX_ABS_G = 0.95


def rte_coefficients(K: ArrayLike, S: ArrayLike, g: float = 0.0
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(sigma_a, sigma_s)`` in 1/mm of KM coefficients ``K``, ``S`` in 1/mm (broadcast), for
    a Henyey-Greenstein phase function of asymmetry ``g`` (0: isotropic)."""
    K = np.asarray(K, dtype=np.float64)
    S = np.asarray(S, dtype=np.float64)
    return K / K_PER_SIGMA_A, S / (S_PER_SIGMA_S * (1.0 - float(g)))


def parse_phase(text: str) -> float:
    """The asymmetry g of ``isotropic`` (0) or ``hg:G`` (``|G| <= MAX_ABS_G``); ValueError with
    a one-line message otherwise."""
    t = str(text).strip().lower()
    if t == "isotropic":
        return 0.0
    if t.startswith("hg:"):
        try:
            g = float(t[3:])
        except ValueError:
            g = math.nan
        if math.isfinite(g) and abs(g) <= MAX_ABS_G:
            return g
        raise ValueError(f"phase '{text}': G of hg:G must be a number in "
                         f"[-{MAX_ABS_G}, {MAX_ABS_G}]")
    raise ValueError(f"unknown phase function '{text}' (use isotropic or hg:G, e.g. hg:0.4)")


def phase_name(g: float) -> str:
    return "isotropic" if g == 0 else f"hg:{g:g}"
