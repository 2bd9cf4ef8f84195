"""Wavelength grids and explicit resampling of spectra between them.

A profile carries its own grid (the paper's is 380-750 nm at 10 nm; the default inks are
tabulated at 380-730 nm). Data on another grid is resampled with colour-science's
interpolators, following CIE 167:2005: Sprague (1880) on uniformly spaced data, cubic spline
otherwise (and linear for fewer than six points, where neither applies). Values outside the
data's range are refused unless the caller explicitly allows a stated extrapolation, in which
case the nearest end value is held (constant extrapolation, as colour-science does).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dreamprint_gui.core.errors import DreamPrintError

__all__ = ["uniform_grid", "is_uniform", "resample", "PAPER_GRID"]


def uniform_grid(start: float, end: float, step: float) -> NDArray[np.float64]:
    """Wavelengths ``start, start + step, ..., end`` in nm."""
    n = int(round((end - start) / step)) + 1
    return start + step * np.arange(n, dtype=np.float64)


PAPER_GRID = uniform_grid(380.0, 750.0, 10.0)


def is_uniform(wavelengths: ArrayLike, rtol: float = 1e-6) -> bool:
    w = np.asarray(wavelengths, dtype=np.float64)
    if w.size < 3:
        return True
    d = np.diff(w)
    return bool(np.all(np.abs(d - d[0]) <= rtol * abs(d[0])))


def resample(
    wavelengths: ArrayLike, values: ArrayLike, target: ArrayLike, *,
    extrapolate_nm: float = 0.0, source: str | None = None,
) -> NDArray[np.float64]:
    """Resample spectra ``values`` (..., n) given at ``wavelengths`` (n,) onto ``target``.

    Parameters
    ----------
    extrapolate_nm
        How far beyond the data's range (at either end) the target may reach; 0 refuses any
        extrapolation. Beyond the data the end value is held.
    source
        File name for the error message.

    Raises
    ------
    DreamPrintError
        When the target is not covered (the message gives both ranges).
    """
    import colour

    w = np.asarray(wavelengths, dtype=np.float64)
    v = np.asarray(values, dtype=np.float64)
    tgt = np.asarray(target, dtype=np.float64)
    order = np.argsort(w)
    w, v = w[order], v[..., order]
    tol = 1e-9 + extrapolate_nm
    if tgt.min() < w[0] - tol or tgt.max() > w[-1] + tol:
        raise DreamPrintError(
            f"the data covers {w[0]:g}-{w[-1]:g} nm but {tgt.min():g}-{tgt.max():g} nm is "
            f"needed; allow an extrapolation of at least "
            f"{max(w[0] - tgt.min(), tgt.max() - w[-1]):g} nm to hold the end values", source)
    if w.shape == tgt.shape and np.allclose(w, tgt, rtol=0, atol=1e-9):
        return v.copy()
    inside = np.clip(tgt, w[0], w[-1])
    flat = v.reshape(-1, w.size)
    if w.size < 6:
        interpolator = colour.algebra.LinearInterpolator
    elif is_uniform(w):
        interpolator = colour.algebra.SpragueInterpolator
    else:
        interpolator = colour.algebra.CubicSplineInterpolator
    out = np.stack([interpolator(w, row)(inside) for row in flat])
    return out.reshape(v.shape[:-1] + tgt.shape)
