"""Spectrophotometer measurement import: every file an operator's instrument writes.

Public API (see each module for the format's specification and choices):

- :func:`read_spectra` (detect.py) -> :class:`SpectraFile` (model.py) with
  :meth:`SpectraFile.sample` and :meth:`SpectraFile.resample` / :meth:`Sample.resample`.
- :func:`write_spectra` - the writable formats: ``csv-columns``, ``csv-rows``, ``cgats``,
  ``jcamp-dx``.
- :func:`~dreamprint_gui.io.spectra.calibration_set.load_calibration_set` - the calibration set
  TOML (docs/calibration-set.md).

Formats: CGATS.17 (cgats.py: i1Profiler, ArgyllCMS, X-Rite Spectrolino), Agilent Cary CSV
(cary.py), JCAMP-DX 4.24 (jcampdx.py), plain CSV in both orientations (plain_csv.py), IES
TM-27-14 (spdx.py).
"""

from __future__ import annotations

import os
from collections.abc import Sequence

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.spectra.cgats import write_cgats
from dreamprint_gui.io.spectra.detect import detect_format, read_spectra
from dreamprint_gui.io.spectra.jcampdx import write_jcamp
from dreamprint_gui.io.spectra.model import QUANTITIES, Sample, SpectraFile
from dreamprint_gui.io.spectra.plain_csv import write_csv_columns, write_csv_rows

__all__ = ["read_spectra", "detect_format", "write_spectra", "Sample", "SpectraFile",
           "QUANTITIES", "WRITERS"]

WRITERS = {"csv-columns": write_csv_columns, "csv-rows": write_csv_rows,
           "cgats": write_cgats, "jcamp-dx": write_jcamp}


def write_spectra(path: str | os.PathLike, samples: SpectraFile | Sequence[Sample], *,
                  quantity: str | None = None, format: str = "csv-columns") -> None:
    """Write spectra (fractions for reflectance/transmittance) in one of :data:`WRITERS`."""
    if isinstance(samples, SpectraFile):
        quantity = quantity or samples.quantity
        samples = samples.samples
    if quantity not in QUANTITIES:
        raise DreamPrintError(f"say what the spectra are (one of {', '.join(QUANTITIES)})",
                              path)
    if format not in WRITERS:
        raise DreamPrintError(f"unknown format '{format}' (one of {', '.join(WRITERS)})", path)
    WRITERS[format](path, list(samples), quantity)
