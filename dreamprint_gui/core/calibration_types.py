"""What calibration consumes: measured layers of one ink, already on the profile's grid."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from dreamprint_gui.core.errors import DreamPrintError

__all__ = ["LayerMeasurement", "layer_arrays"]


@dataclass(frozen=True)
class LayerMeasurement:
    """Reflectance and transmittance (fractions, 0-1) of one ink layer of known thickness.

    ``R`` and ``T`` are on the profile's wavelength grid (the importer resamples them); either
    may be ``None`` when only one was measured at this thickness. ``source`` says where each came
    from (file and sample name), for provenance and error messages.
    """

    ink: str
    thickness_mm: float
    R: NDArray[np.float64] | None
    T: NDArray[np.float64] | None
    source: str = ""


def layer_arrays(layers: list[LayerMeasurement], n_wl: int
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
                            NDArray[np.bool_], NDArray[np.bool_]]:
    """The layers as arrays for a fit: thicknesses (n,), R and T (n, n_wl) with NaN where not
    measured, and where each was measured. Raises naming the source when a measurement is not
    on the ``n_wl`` wavelengths of the profile's grid."""
    t = np.array([m.thickness_mm for m in layers], dtype=np.float64)
    R = np.full((len(layers), n_wl), np.nan)
    T = np.full((len(layers), n_wl), np.nan)
    for i, m in enumerate(layers):
        for arr, data in ((R, m.R), (T, m.T)):
            if data is not None:
                d = np.asarray(data, dtype=np.float64)
                if d.shape != (n_wl,):
                    raise DreamPrintError(f"ink {m.ink}: a measurement has {d.size} "
                                          f"wavelengths, the profile grid {n_wl}",
                                          m.source or None)
                arr[i] = d
    return t, R, T, np.isfinite(R), np.isfinite(T)
