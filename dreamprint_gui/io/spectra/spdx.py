"""IES TM-27-14 spectral distribution XML (``.spdx``), read with colour-science.

Defines :func:`looks_like_spdx` and :func:`read_spdx`.

Uses the maintained reader :class:`colour.SpectralDistribution_IESTM2714` (IES TM-27-14,
"IES Standard Format for the Electronic Transfer of Spectral Data"). The element
``SpectralQuantity`` says what the numbers are: ``reflectance`` / ``R-Factor`` and
``transmittance`` / ``T-Factor`` are read as such (TM-27-14 allows them); the radiometric
quantities (``flux``, ``irradiance``, ``radiance``, ``exitance``, ``intensity``, ``relative``,
``counts``...) are a spectral power distribution, which
:func:`~dreamprint_gui.io.spectra.read_spectra` refuses, with that reason, when a reflectance or
transmittance is asked for. ``absorptance`` (1 - R - T) is not a quantity the calibration can
use and is read as unstated.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

import numpy as np

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.spectra.model import RawSample, RawSpectra

__all__ = ["looks_like_spdx", "read_spdx"]


def looks_like_spdx(text_head: str) -> bool:
    return re.search(r"<\s*(\w+:)?IESTM2714\b", text_head) is not None


def read_spdx(path: str) -> RawSpectra:
    import colour

    try:
        sd = colour.SpectralDistribution_IESTM2714(path).read()
    except ET.ParseError as exc:
        line = exc.position[0] if getattr(exc, "position", None) else None
        raise DreamPrintError(f"not well-formed XML ({exc.msg if hasattr(exc, 'msg') else exc})",
                              path, line) from None
    except (ValueError, KeyError, TypeError) as exc:
        raise DreamPrintError(f"not a readable IES TM-27-14 document: {exc}", path) from None
    w = np.asarray(sd.wavelengths, dtype=np.float64)
    v = np.asarray(sd.values, dtype=np.float64)
    if w.size == 0:
        raise DreamPrintError("no SpectralData elements", path)
    sq = (sd.spectral_quantity or "").strip().lower()
    notes = []
    if sq in ("reflectance", "r-factor"):
        quantity = "reflectance"
    elif sq in ("transmittance", "t-factor"):
        quantity = "transmittance"
    elif sq in ("absorptance", "other", ""):
        quantity = None
        notes.append(f"SpectralQuantity '{sd.spectral_quantity}' does not say what a "
                     "spectrum of DreamPrint's kinds this is")
    else:
        quantity = "spd"
    name = sd.name if sd.name and sd.name != "Undefined" else "spectrum"
    meta = {"spectral_quantity": sd.spectral_quantity,
            "manufacturer": sd.header.manufacturer,
            "description": sd.header.description}
    return RawSpectra(format="IES TM-27-14 (spdx)", samples=[RawSample(name, w, v)],
                      quantity=quantity, wavelength_unit="nm", notes=notes, metadata=meta)
