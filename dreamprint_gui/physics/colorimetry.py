"""Colorimetry of spectra on a wavelength grid: XYZ, sRGB, CIELAB and dE2000 (paper eq. 7).

Defines :class:`Observer`, which holds the CIE 1931 2 degree colour matching functions times the
D65 illuminant tabulated on one wavelength grid, so that converting many spectra is a single
matrix product (colour-science's ``msds_to_XYZ(..., method='Integration')`` computes the same sum
but about three times slower; its default ASTM E308 path is ~1000 times slower).

Conventions
-----------
- XYZ is normalised so that a perfect white reflector (R = 1 everywhere) has Y = 1; the white
  point is that of D65 integrated on *this* grid (``Observer.white_XYZ``).
- CIELAB uses that white, so a perfect reflector is exactly L* = 100, a* = b* = 0.
- sRGB: the white is adapted (Bradford) to the sRGB D65 white, so a perfect reflector is
  exactly (1, 1, 1); values are *not* clipped (out-of-gamut colours stay comparable), use
  :func:`clip_unit` for display.

References
----------
- CIE 015:2018 Colorimetry, 4th ed.
- IEC 61966-2-1:1999 (sRGB).
- Sharma, Wu, Dalal (2005). The CIEDE2000 colour-difference formula.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["Observer", "observer_for", "delta_E2000", "clip_unit", "srgb_to_lab"]


@dataclass(frozen=True)
class Observer:
    """CIE 1931 2 degree observer under D65 tabulated on ``wavelengths_nm``."""

    wavelengths_nm: tuple[float, ...]
    weights: NDArray[np.float64] = field(repr=False)  # (n_wl, 3), XYZ per unit reflectance
    white_XYZ: NDArray[np.float64] = field(repr=False)
    xyz_to_linear_srgb: NDArray[np.float64] = field(repr=False)

    def spectra_to_XYZ(self, spectra: ArrayLike) -> NDArray[np.float64]:
        """XYZ (Y of a perfect reflector = 1) of reflectance-like spectra, shape (..., n_wl)."""
        return np.asarray(spectra, dtype=np.float64) @ self.weights

    def XYZ_to_linear_sRGB(self, XYZ: ArrayLike) -> NDArray[np.float64]:
        return np.asarray(XYZ, dtype=np.float64) @ self.xyz_to_linear_srgb.T

    def XYZ_to_sRGB(self, XYZ: ArrayLike) -> NDArray[np.float64]:
        """Gamma-encoded sRGB (IEC 61966-2-1), unclipped."""
        import colour

        return colour.models.eotf_inverse_sRGB(self.XYZ_to_linear_sRGB(XYZ))

    def XYZ_to_Lab(self, XYZ: ArrayLike) -> NDArray[np.float64]:
        import colour

        return colour.XYZ_to_Lab(np.asarray(XYZ, dtype=np.float64),
                                 illuminant=colour.XYZ_to_xy(self.white_XYZ))

    def sRGB_to_XYZ(self, rgb: ArrayLike) -> NDArray[np.float64]:
        """Inverse of :meth:`XYZ_to_sRGB` (sRGB (1, 1, 1) -> the grid's white)."""
        import colour

        linear = colour.models.eotf_sRGB(np.asarray(rgb, dtype=np.float64))
        return linear @ np.linalg.inv(self.xyz_to_linear_srgb).T

    def spectra_to_Lab(self, spectra: ArrayLike) -> NDArray[np.float64]:
        return self.XYZ_to_Lab(self.spectra_to_XYZ(spectra))

    def spectra_to_sRGB(self, spectra: ArrayLike) -> NDArray[np.float64]:
        return self.XYZ_to_sRGB(self.spectra_to_XYZ(spectra))


@lru_cache(maxsize=16)
def _observer(wavelengths: tuple[float, ...]) -> Observer:
    import colour

    wl = np.asarray(wavelengths, dtype=np.float64)
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    d65 = colour.SDS_ILLUMINANTS["D65"]
    # The CMFs are tabulated at 1 nm and D65 at 5 nm (1 nm interpolated by colour), so reading
    # them at the grid's wavelengths is a lookup, not an approximation.
    xbar = np.stack([np.interp(wl, cmfs.wavelengths, cmfs.values[:, i]) for i in range(3)], -1)
    e = np.interp(wl, d65.wavelengths, d65.values)
    widths = np.gradient(wl) if wl.size > 1 else np.ones(1)
    w = xbar * (e * widths)[:, None]
    w /= w[:, 1].sum()
    white = w.sum(axis=0)
    srgb = colour.models.RGB_COLOURSPACE_sRGB
    cat = colour.adaptation.matrix_chromatic_adaptation_VonKries(
        white, colour.xy_to_XYZ(srgb.whitepoint), transform="Bradford")
    m = srgb.matrix_XYZ_to_RGB @ cat
    # IEC 61966-2-1 rounds its matrix to 4 decimals; rescale the rows so that the white maps to
    # exactly (1, 1, 1) instead of 1 +- 1e-4.
    m = m / (m @ white)[:, None]
    return Observer(tuple(wavelengths), w, white, m)


def observer_for(wavelengths_nm: ArrayLike) -> Observer:
    """The (cached) observer tabulated on a wavelength grid in nm."""
    return _observer(tuple(float(x) for x in np.asarray(wavelengths_nm).ravel()))


def delta_E2000(Lab1: ArrayLike, Lab2: ArrayLike) -> NDArray[np.float64]:
    """CIEDE2000 colour difference (vectorised, colour-science)."""
    import colour

    return np.asarray(colour.delta_E(np.asarray(Lab1, float), np.asarray(Lab2, float),
                                     method="CIE 2000"))


def srgb_to_lab(rgb: ArrayLike, observer: Observer) -> NDArray[np.float64]:
    """CIELAB of encoded sRGB colours, relative to the observer's white."""
    return observer.XYZ_to_Lab(observer.sRGB_to_XYZ(rgb))


def clip_unit(x: ArrayLike) -> NDArray[np.float64]:
    """Clip to [0, 1] for display or 8-bit output."""
    return np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
