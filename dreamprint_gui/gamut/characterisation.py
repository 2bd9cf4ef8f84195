"""CGATS characterisation file of the print: RGB -> predicted XYZ, CIELAB and spectra (issue 48).

Defines :func:`write_characterisation` (and :func:`characterisation_text`): the patches of an
n^3 lattice of the RGB cube with what DreamPrint predicts their print to be, for tools that
build their own profiles (ArgyllCMS ``colprof``, i1Profiler, basICColor). Per patch:

- ``RGB_R``, ``RGB_G``, ``RGB_B``: the device RGB, 0-100 (ArgyllCMS) or 0-255 (i1Profiler);
- ``XYZ_X``, ``XYZ_Y``, ``XYZ_Z`` (0-100) and ``LAB_L``, ``LAB_A``, ``LAB_B``: ICC-absolute
  D50 colorimetry, the numbers the ICC profile's A2B tables hold before the media-white scaling
  (:meth:`.print_pcs.PrintPCS.absolute_xyz`: the D65 colour, Bradford-adapted to D50);
- the spectrum the colour comes from (R + T of the layer at the profile's reference thickness,
  eq. 7): ``SPEC_<nm>`` in percent (ArgyllCMS ``.ti3``) or ``SPECTRAL_NM<nm>`` as fractions
  (i1Profiler's CGATS.17). A tool that recomputes XYZ from the spectra under D50 gets D50
  colorimetry rather than the adapted D65 colorimetry of the XYZ columns.

Layouts: a ``.ti3`` file is written as ArgyllCMS's CTI3 (``DEVICE_CLASS "OUTPUT"``,
``COLOR_REP "RGB_XYZ"``, the keywords its ``profcheck`` and ``colprof`` read); any other name
as i1Profiler's CGATS.17 measurement export. Written to those layouts' published descriptions
(ArgyllCMS's ti3 format page; ANSI CGATS.17): a plain text table, no library needed beyond the
atomic write of :func:`.icc.write_atomically`.
"""

from __future__ import annotations

import os
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from dreamprint_gui.core.profile import InkProfile
from dreamprint_gui.gamut.icc import rgb_cube, write_atomically
from dreamprint_gui.gamut.print_pcs import PrintPCS, lab_d50
from dreamprint_gui.gamut.tables import lookup
from dreamprint_gui.physics.mixture import predict

__all__ = ["write_characterisation", "characterisation_text", "layout_for"]


def layout_for(path: str | os.PathLike) -> str:
    """``"argyll"`` for a ``.ti3`` file, else ``"i1profiler"``."""
    return "argyll" if Path(path).suffix.lower() == ".ti3" else "i1profiler"


def _num(v: float) -> str:
    return f"{v:.6f}"


def characterisation_text(pcs: PrintPCS, profile: InkProfile, patches: int = 9,
                          layout: str = "argyll",
                          description: str = "DreamPrint predicted print") -> str:
    """The file's text (module doc) for an ``patches``^3 lattice of RGB."""
    rgb = rgb_cube(patches)
    pred = predict(profile, lookup(pcs.tables, rgb))
    xyz = pred.XYZ @ pcs.chad.T
    lab = lab_d50(xyz)
    spectra = pred.R + pred.T
    wl = np.asarray(profile.wavelengths_nm, dtype=np.float64)
    argyll = layout == "argyll"
    scale = 100.0 if argyll else 255.0
    spec_names = [("SPEC_" if argyll else "SPECTRAL_NM") + f"{w:g}" for w in wl]
    fields = (["SAMPLE_ID", "RGB_R", "RGB_G", "RGB_B", "XYZ_X", "XYZ_Y", "XYZ_Z", "LAB_L",
               "LAB_A", "LAB_B"] + spec_names)
    now = datetime.now(UTC)
    head = (["CTI3", "", f'DESCRIPTOR "{description}"', 'ORIGINATOR "DreamPrint"',
             f'CREATED "{now:%a %b %d %H:%M:%S %Y}"', 'DEVICE_CLASS "OUTPUT"',
             'COLOR_REP "RGB_XYZ"', 'KEYWORD "SPECTRAL_BANDS"', f'SPECTRAL_BANDS "{wl.size}"',
             'KEYWORD "SPECTRAL_START_NM"', f'SPECTRAL_START_NM "{wl[0]:g}"',
             'KEYWORD "SPECTRAL_END_NM"', f'SPECTRAL_END_NM "{wl[-1]:g}"',
             'KEYWORD "SPECTRAL_NORM"', 'SPECTRAL_NORM "100"'] if argyll else
            ["CGATS.17", 'ORIGINATOR "DreamPrint"', f'DESCRIPTOR "{description}"',
             f'CREATED "{now:%Y-%m-%dT%H:%M:%S}"', 'MEASUREMENT_SOURCE "Illumination=D65 '
             'ObserverAngle=2 (predicted; XYZ and LAB Bradford-adapted to D50)"',
             'KEYWORD "SPECTRAL_NORM"', 'SPECTRAL_NORM "1"'])
    lines = head + ['KEYWORD "ILLUMINANT"', 'ILLUMINANT "D50 (Bradford-adapted from D65)"',
                    f"NUMBER_OF_FIELDS {len(fields)}", "BEGIN_DATA_FORMAT", " ".join(fields),
                    "END_DATA_FORMAT", f"NUMBER_OF_SETS {len(rgb)}", "BEGIN_DATA"]
    spec_scale = 100.0 if argyll else 1.0
    for i in range(len(rgb)):
        row = ([str(i + 1)] + [_num(v * scale) for v in rgb[i]]
               + [_num(v * 100.0) for v in xyz[i]] + [_num(v) for v in lab[i]]
               + [_num(v * spec_scale) for v in spectra[i]])
        lines.append(" ".join(row))
    lines.append("END_DATA")
    return "\n".join(lines) + "\n"


def write_characterisation(path: str | os.PathLike, pcs: PrintPCS, profile: InkProfile,
                           patches: int = 9, description: str = "DreamPrint predicted print"
                           ) -> str:
    """Write the file (layout from the name, :func:`layout_for`) atomically; the layout."""
    layout = layout_for(path)
    text = characterisation_text(pcs, profile, patches, layout, description)
    write_atomically(path, text.encode("ascii"))
    return layout
