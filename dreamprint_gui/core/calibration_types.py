"""What calibration consumes: measured layers of one ink, already on the profile's grid."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["LayerMeasurement"]


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
