"""Recipe and spectra-row CSV files used by ``predict --mix-file`` and chart calibration.

Recipes: a header row naming inks (any of C, M, Y, K, W, Cl, case-insensitive; absent inks are
0), one row per mixture, fractions or percent (a row summing to 100 is read as percent).
Other columns named ``id``, ``name`` or ``sample`` are ignored.

Spectra rows: a header of wavelengths in nm (other leading columns such as ``id`` or ``name``
ignored), one row per spectrum, values as fractions or percent (percent when any value > 1.5).
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.profile import INKS

__all__ = ["read_recipes", "read_spectra_rows", "read_csv_rows"]

_LABEL_COLUMNS = {"id", "name", "sample", "sample_id", "sample_name", "patch"}


def read_csv_rows(path: Path) -> list[tuple[int, list[str]]]:
    """Non-blank, non-comment rows of a CSV file with their line numbers (header first)."""
    try:
        text = Path(path).read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise DreamPrintError("no such file", path) from None
    except UnicodeDecodeError:
        raise DreamPrintError("not a text CSV file", path) from None
    out = []
    for n, row in enumerate(csv.reader(io.StringIO(text)), start=1):
        if not row or all(not c.strip() for c in row) or row[0].lstrip().startswith("#"):
            continue
        out.append((n, [c.strip() for c in row]))
    if len(out) < 2:
        raise DreamPrintError("needs a header row and at least one data row", path)
    return out


def _number(cell: str, path: Path, line: int, what: str) -> float:
    if cell == "":
        return 0.0
    try:
        v = float(cell.rstrip("%"))
    except ValueError:
        raise DreamPrintError(f"{what}: {cell!r} is not a number", path, line) from None
    if not np.isfinite(v):
        raise DreamPrintError(f"{what}: {cell!r} is not finite", path, line)
    return v


def read_recipes(path: Path) -> NDArray[np.float64]:
    """Concentrations (n, 6) in ``INKS`` order from a recipes CSV."""
    rows = read_csv_rows(path)
    header_line, header = rows[0]
    lookup = {ink.lower(): ink for ink in INKS}
    columns: list[tuple[int, int]] = []
    for j, name in enumerate(header):
        key = name.strip().lower()
        if key in lookup:
            columns.append((j, INKS.index(lookup[key])))
        elif key not in _LABEL_COLUMNS:
            raise DreamPrintError(f"column '{name}' is not an ink ({', '.join(INKS)})", path,
                                  header_line)
    if not columns:
        raise DreamPrintError(f"the header names no ink ({', '.join(INKS)})", path, header_line)
    c = np.zeros((len(rows) - 1, len(INKS)))
    for r, (line, row) in enumerate(rows[1:]):
        if len(row) != len(header):
            raise DreamPrintError(f"{len(row)} fields, the header has {len(header)}", path, line)
        for j, i in columns:
            cell = row[j]
            c[r, i] = _number(cell, path, line, f"ink {INKS[i]}")
    if np.any(c < 0):
        r = int(np.argwhere(c < 0)[0][0])
        raise DreamPrintError("negative concentration", path, rows[r + 1][0])
    sums = c.sum(axis=1)
    percent = np.abs(sums - 100.0) <= 1e-4
    c[percent] /= 100.0
    sums[percent] /= 100.0
    bad = np.flatnonzero(np.abs(sums - 1.0) > 1e-4)
    if bad.size:
        r = int(bad[0])
        raise DreamPrintError(f"concentrations sum to {sums[r]:g}, not 1 (or 100 %)", path,
                              rows[r + 1][0])
    return c / sums[:, None]


def read_spectra_rows(path: Path) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(wavelengths_nm, spectra (n, n_wl)) from a CSV with a header of wavelengths."""
    rows = read_csv_rows(path)
    header_line, header = rows[0]
    wl_cols: list[tuple[int, float]] = []
    for j, name in enumerate(header):
        try:
            wl_cols.append((j, float(name.lower().removesuffix("nm").strip())))
        except ValueError:
            if wl_cols:
                raise DreamPrintError(f"header cell '{name}' after the wavelengths is not a "
                                      "wavelength", path, header_line) from None
    if len(wl_cols) < 3:
        raise DreamPrintError("the header must list the wavelengths in nm", path, header_line)
    wl = np.array([w for _, w in wl_cols])
    if np.any(np.diff(wl) <= 0):
        raise DreamPrintError("header wavelengths must increase", path, header_line)
    data = np.empty((len(rows) - 1, wl.size))
    for r, (line, row) in enumerate(rows[1:]):
        if len(row) < wl_cols[-1][0] + 1:
            raise DreamPrintError(f"{len(row)} cells, the header has {len(header)}", path, line)
        for k, (j, w) in enumerate(wl_cols):
            if row[j] == "":
                raise DreamPrintError(f"empty value at {w:g} nm", path, line)
            data[r, k] = _number(row[j], path, line, f"{w:g} nm")
    if data.max() > 1.5:
        data = data / 100.0
    if np.any(data < 0) or np.any(data > 1.0 + 1e-9):
        r, k = np.argwhere((data < 0) | (data > 1.0 + 1e-9))[0]
        raise DreamPrintError(f"reflectance {data[r, k]:g} at {wl[k]:g} nm is outside 0-1 "
                              "(0-100 %)", path, rows[r + 1][0])
    return wl, data
