"""DreamPrint's own CSV layout for ink layer measurements (docs/measurements-csv.md).

Header ``ink,quantity,thickness_mm,<wavelength nm>...`` (headings ``380``, ``380nm`` or
``SPECTRAL_NM380``: :func:`~dreamprint_gui.io.spectra.cgats.wavelength_of_field`); one row
per measured spectrum: ``quantity`` is ``R`` (reflectance) or ``T`` (transmittance), values
are fractions (0-1) or percent (read as percent when any value of the file exceeds 1.5). An R
row and a T row of the same ink and thickness form one layer. Rows are resampled onto the
profile's grid.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dreamprint_gui.core.calibration_types import LayerMeasurement
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.profile import INKS
from dreamprint_gui.core.spectral_grid import resample
from dreamprint_gui.io.recipes import read_csv_rows
from dreamprint_gui.io.spectra.cgats import wavelength_of_field

__all__ = ["read_measurements_csv", "write_measurements_csv"]


def read_measurements_csv(path: Path, wavelengths_nm: NDArray) -> list[LayerMeasurement]:
    rows = read_csv_rows(path)
    hline, header = rows[0]
    if [h.lower() for h in header[:3]] != ["ink", "quantity", "thickness_mm"]:
        raise DreamPrintError("header must start with ink,quantity,thickness_mm", path, hline)
    named = [wavelength_of_field(h) for h in header[3:]]
    if any(w is None for w in named):
        bad = header[3 + named.index(None)]
        raise DreamPrintError(f"header cell '{bad}' after thickness_mm is not a wavelength "
                              "(380, 380nm or SPECTRAL_NM380)", path, hline)
    wl = np.array(named, dtype=np.float64)
    if wl.size < 3 or np.any(np.diff(wl) <= 0):
        raise DreamPrintError("need at least 3 increasing wavelengths in the header", path, hline)
    entries = []
    inks = {i.lower(): i for i in INKS}
    for line, row in rows[1:]:
        if len(row) != len(header):
            raise DreamPrintError(f"{len(row)} cells, the header has {len(header)}", path, line)
        ink = inks.get(row[0].lower())
        if ink is None:
            raise DreamPrintError(f"unknown ink '{row[0]}' ({', '.join(INKS)})", path, line)
        q = row[1].upper()
        if q not in ("R", "T"):
            raise DreamPrintError(f"quantity must be R or T, got '{row[1]}'", path, line)
        try:
            t = float(row[2])
            values = np.array([float(c) for c in row[3:]])
        except ValueError:
            raise DreamPrintError("a cell is not a number", path, line) from None
        if not t > 0:
            raise DreamPrintError(f"thickness must be > 0 mm, got {row[2]}", path, line)
        if not np.all(np.isfinite(values)):
            raise DreamPrintError("non-finite value", path, line)
        entries.append((line, ink, q, t, values))
    percent = max(float(e[4].max()) for e in entries) > 1.5
    layers: dict[tuple[str, float], dict] = {}
    for line, ink, q, t, values in entries:
        v = values / 100.0 if percent else values
        bad = np.flatnonzero((v < 0) | (v > 1.0 + 1e-9))
        if bad.size:
            k = int(bad[0])
            raise DreamPrintError(f"{ink} {q} = {v[k]:g} at {wl[k]:g} nm is outside 0-1", path,
                                  line)
        v = resample(wl, v, wavelengths_nm, source=f"{path}:{line}")
        slot = layers.setdefault((ink, t), {"R": None, "T": None, "lines": []})
        if slot[q] is not None:
            raise DreamPrintError(f"a second {q} row for {ink} at {t:g} mm", path, line)
        slot[q] = v
        slot["lines"].append(line)
    return [LayerMeasurement(ink, t, d["R"], d["T"],
                             f"{path} line(s) {','.join(map(str, d['lines']))}")
            for (ink, t), d in layers.items()]


def write_measurements_csv(path: Path, wavelengths_nm: NDArray,
                           layers: list[LayerMeasurement]) -> None:
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(["ink", "quantity", "thickness_mm", *[f"{x:g}" for x in wavelengths_nm]])
        for m in layers:
            for q, v in (("R", m.R), ("T", m.T)):
                if v is not None:
                    w.writerow([m.ink, q, repr(m.thickness_mm), *[repr(float(x)) for x in v]])
