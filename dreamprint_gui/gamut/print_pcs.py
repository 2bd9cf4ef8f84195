"""The colour a job prints for an RGB, in the ICC profile connection space (issue 48).

Defines
-------
- :class:`PrintPCS`: DreamPrint's forward model of a print (RGB -> the table's inks under its
  intent -> eq. 7 colour at the profile's reference thickness, :func:`.tables.printed_xyz`)
  expressed as ICC colorimetry:

  1. ``XYZ_D65``: the print's colour under the observer's D65 (white reflector Y = 1).
  2. ``XYZ_abs = M_chad XYZ_D65``: ICC-absolute PCS colorimetry, adapted to the PCS illuminant
     D50 by the linearised Bradford transform ICC.1:2022 Annex E prescribes, ``M_chad =
     M_BFD^-1 diag(LMS_D50 / LMS_D65) M_BFD`` (stored as the ``chad`` tag).
  3. ``XYZ_rel = XYZ_abs * D50 / W_media`` per component (ICC.1 6.3.2.2, media-relative
     colorimetry), with the media white ``W_media`` (the ``wtpt`` tag) the printable white: the
     printable mixture of highest luminance, the white the ``relative`` intent prints for RGB
     (1, 1, 1) (:class:`.mapping.RelativeMap`). A 3-D print has no paper; this white bounds
     every printable colour (relative L* <= 100, which a CIELAB PCS cannot exceed), whereas the
     colorimetric intent's print of (1, 1, 1), a more neutral but darker mixture, is exceeded
     by up to 3 L*.
  4. CIELAB of ``XYZ_rel`` relative to the PCS white D50 (0.9642, 1, 0.8249).

- :func:`encode_lab` / :func:`decode_lab`: CIELAB as the 16-bit numbers of a version 2
  ``lut16Type`` (L* 0..100 -> 0..0xFF00, a*, b* -128..127.996 -> 0..0xFFFF) or a version 4
  ``lutAtoBType`` table (L* 0..100 -> 0..0xFFFF, a*, b* -128..127 -> 0..0xFFFF), ICC.1 Tables
  12 and 13 / ICC.1:2001-04 Table 44.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dreamprint_gui.core.profile import InkProfile
from dreamprint_gui.gamut.forward import ForwardModel, forward_model
from dreamprint_gui.gamut.mapping import RelativeMap
from dreamprint_gui.gamut.tables import ColourTables, printed_xyz

__all__ = ["PrintPCS", "ICC_D50", "encode_lab", "decode_lab", "lab_d50", "xyz_d50"]

# The PCS illuminant as ICC headers store it (s15Fixed16 of 0.9642, 1.0, 0.8249).
ICC_D50 = np.array([0.9642, 1.0, 0.8249])


def lab_d50(xyz: ArrayLike) -> NDArray[np.float64]:
    """CIELAB (CIE 015:2018) of XYZ relative to the PCS white :data:`ICC_D50`."""
    import colour

    return colour.XYZ_to_Lab(np.asarray(xyz, float), illuminant=colour.XYZ_to_xy(ICC_D50))


def xyz_d50(lab: ArrayLike) -> NDArray[np.float64]:
    import colour

    return colour.Lab_to_XYZ(np.asarray(lab, float), illuminant=colour.XYZ_to_xy(ICC_D50))


def encode_lab(lab: ArrayLike, version: int) -> NDArray[np.uint16]:
    """16-bit PCS CIELAB of a LUT tag (module doc), rounded and clipped to the encoding."""
    lab = np.asarray(lab, dtype=np.float64)
    if version == 2:
        v = np.stack([lab[..., 0] * 652.80, (lab[..., 1] + 128.0) * 256.0,
                      (lab[..., 2] + 128.0) * 256.0], axis=-1)
    else:
        v = np.stack([lab[..., 0] * 655.35, (lab[..., 1] + 128.0) * 257.0,
                      (lab[..., 2] + 128.0) * 257.0], axis=-1)
    return np.clip(np.round(v), 0, 65535).astype(np.uint16)


def decode_lab(v: ArrayLike, version: int) -> NDArray[np.float64]:
    """CIELAB of 16-bit PCS numbers (the inverse of :func:`encode_lab`)."""
    v = np.asarray(v, dtype=np.float64)
    if version == 2:
        return np.stack([v[..., 0] / 652.80, v[..., 1] / 256.0 - 128.0,
                         v[..., 2] / 256.0 - 128.0], axis=-1)
    return np.stack([v[..., 0] / 655.35, v[..., 1] / 257.0 - 128.0,
                     v[..., 2] / 257.0 - 128.0], axis=-1)


@dataclass(frozen=True)
class PrintPCS:
    """A job's print of device RGB in ICC PCS terms (module doc); ``tables`` fix the intent."""

    tables: ColourTables
    model: ForwardModel
    chad: NDArray[np.float64]  # (3, 3) D65 (the observer's white) -> D50
    media_white: NDArray[np.float64]  # ICC-absolute XYZ (D50-adapted) of the printable white

    @classmethod
    def for_tables(cls, profile: InkProfile, tables: ColourTables) -> PrintPCS:
        import colour

        model = forward_model(profile)
        chad = colour.adaptation.matrix_chromatic_adaptation_VonKries(
            model.white, ICC_D50, transform="Bradford")
        white = RelativeMap.for_model(model).print_white @ chad.T
        return cls(tables, model, chad, white)

    def xyz_d65(self, rgb: ArrayLike) -> NDArray[np.float64]:
        """Step 1: the print's XYZ under D65 (white reflector Y = 1)."""
        return printed_xyz(self.tables, self.model, np.asarray(rgb, np.float64))

    def absolute_xyz(self, rgb: ArrayLike) -> NDArray[np.float64]:
        """Step 2: ICC-absolute (D50-adapted) XYZ of the print."""
        return self.xyz_d65(rgb) @ self.chad.T

    def relative_xyz_from_absolute(self, xyz_abs: ArrayLike) -> NDArray[np.float64]:
        """Step 3: media-relative XYZ."""
        return np.asarray(xyz_abs, np.float64) * (ICC_D50 / self.media_white)

    def relative_lab(self, rgb: ArrayLike) -> NDArray[np.float64]:
        """Step 4: media-relative PCS CIELAB of the print (what the A2B tables hold)."""
        return lab_d50(self.relative_xyz_from_absolute(self.absolute_xyz(rgb)))

    def absolute_lab(self, rgb: ArrayLike) -> NDArray[np.float64]:
        """ICC-absolute PCS CIELAB of the print (what an absolute colorimetric transform gives)."""
        return lab_d50(self.absolute_xyz(rgb))
