"""A printed chart's files: its recipes and, when measured, each patch's reflectance.

:func:`read_chart` is the one reader of a chart, called by ``calibrate --chart``,
``proof --chart``, the calibration wizard and the chart benchmarks. Recipes are read by
:func:`~dreamprint_gui.io.recipes.read_recipes` (every recipe layout it takes: a header of inks,
cells naming their ink ``k50,c0,...``, one mixture per cell; percent or fractions); the
reflectance by :func:`~dreamprint_gui.io.spectra.read_spectra` (every measurement format
``dreamprint spectra`` reads: CGATS, CSV with CGATS field names such as ``SPECTRAL_NM380`` with
``LAB_L``... columns beside them, plain CSV rows or columns, percent or fractions), one
spectrum per recipe in the same order, resampled onto the profile's grid.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.recipes import read_recipes
from dreamprint_gui.io.spectra import read_spectra

__all__ = ["ChartFiles", "read_chart"]


@dataclass(frozen=True)
class ChartFiles:
    """Recipes (n, 6) in ``INKS`` order and reflectance (n, n_wl) on ``wavelengths_nm`` as
    fractions, or ``None`` when the chart was given without measurements."""

    recipes: NDArray[np.float64]
    reflectance: NDArray[np.float64] | None
    wavelengths_nm: NDArray[np.float64]


def read_chart(recipes: str | os.PathLike, reflectance: str | os.PathLike | None,
               wavelengths_nm: ArrayLike, *, max_patches: int | None = None) -> ChartFiles:
    """Read and check a chart's recipes and measured reflectance (one-line errors)."""
    wl = np.asarray(wavelengths_nm, dtype=np.float64)
    c = read_recipes(recipes)
    if max_patches is not None and len(c) > max_patches:
        raise DreamPrintError(f"{len(c)} recipes; at most {max_patches}", recipes)
    R = None
    if reflectance is not None:
        sf = read_spectra(reflectance, quantity="reflectance")
        if sf.problems:
            raise DreamPrintError(sf.problems[0], reflectance)
        if len(sf.samples) != len(c):
            raise DreamPrintError(f"{len(sf.samples)} measured spectra but {len(c)} recipes in "
                                  f"{os.fspath(recipes)}; one spectrum per recipe, in the same "
                                  "order", reflectance)
        R = np.stack([sf.resample(i, wl) for i in range(len(sf.samples))])
    return ChartFiles(c, R, wl)
