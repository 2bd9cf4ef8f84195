"""The Clear ink's plausible low bound: what a modelled Clear's error could be at best.

Method step: the ink model's inputs (paper section 4.2). Until an operator has measured the
Clear (``dreamprint target wedge``, ``calibrate --slabs``), its K and S are modelled
(``resources/profiles/SOURCES.md``: K = 0.03 + 0.25 exp(-(lambda - 380)/25) /mm, S = 0.002
/mm). The bound comes from the public data ``MEASURED.md`` ("Clear ink optics") gathers: a
clear acrylic absorbs 0.001-0.008 /mm over 400-730 nm (Plexiglas, the floor) and printed
VeroClear plausibly 0.002-0.1 /mm over 450-730 nm, a photopolymer's edge rising steeply below
420 nm (a clear resin with its UV absorber: 26, 12 and 1.9 /mm at 380, 400 and 420 nm, a fall
by e every 11 nm between 400 and 420). The low bound is 0.002 /mm with the modelled Clear's
0.25 /mm at 380 nm falling by e every 10 nm, so that it is 0.002-0.0022 over 450-730 nm::

    K_low(lambda) = 0.002 + 0.25 exp(-(lambda - 380 nm) / 10 nm)   [1/mm]

and keeps the profile's S (no public figure bounds the Clear's scattering). The proof renders the
same labels with it (``proof --clear-low-bound``): the error that goes away is the share of the
print's error that rests on the guess.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dreamprint_gui.core.profile import INKS, InkProfile, ink_origins

__all__ = ["CLEAR_LOW_K_FLAT", "clear_low_bound_K", "clear_low_bound", "clear_is_modelled",
           "describe_low_bound"]

CLEAR_LOW_K_FLAT = 0.002   # 1/mm, 450-730 nm (MEASURED.md "Clear ink optics")
_EDGE_K, _EDGE_NM, _EDGE_WIDTH_NM = 0.25, 380.0, 10.0
_CL = INKS.index("Cl")


def clear_low_bound_K(wavelengths_nm: ArrayLike) -> NDArray[np.float64]:
    """K_low(lambda) in 1/mm (module docstring)."""
    wl = np.asarray(wavelengths_nm, dtype=np.float64)
    return CLEAR_LOW_K_FLAT + _EDGE_K * np.exp(-(wl - _EDGE_NM) / _EDGE_WIDTH_NM)


def clear_is_modelled(profile: InkProfile) -> bool:
    """True when the profile's Clear K and S are assumed, not fitted (``provenance.ink_origin``,
    :func:`~dreamprint_gui.core.profile.ink_origins`)."""
    return ink_origins(profile)["Cl"] == "modelled"


def clear_low_bound(profile: InkProfile) -> InkProfile:
    """``profile`` with the Clear's K at its low bound (never above the profile's own)."""
    K = profile.K.copy()
    K[_CL] = np.minimum(K[_CL], clear_low_bound_K(profile.wavelengths_nm))
    return profile.with_settings(name=f"{profile.name} (Clear at its low bound)", K=K)


def describe_low_bound() -> str:
    """The bound in words for reports: the formula and its range over 450-730 nm (computed)."""
    lo, hi = clear_low_bound_K(np.array([730.0, 450.0]))
    return (f"K = {CLEAR_LOW_K_FLAT:g} + {_EDGE_K:g} exp(-(lambda - {_EDGE_NM:g})/"
            f"{_EDGE_WIDTH_NM:g}) /mm ({lo:.2g}-{hi:.2g} over 450-730 nm, the low end of printed "
            "VeroClear's plausible 0.002-0.1 /mm, with a resin's steep violet edge, "
            "MEASURED.md), S as the profile's")
