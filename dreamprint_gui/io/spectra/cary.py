"""Agilent (Varian) Cary UV-Vis / UV-Vis-NIR CSV exports ("Save as CSV" of Cary WinUV Scan).

Defines :func:`looks_like_cary` and :func:`read_cary`.

No maintained Python reader exists (WrightTools has one tied to its own data objects), so this
follows the layout Cary WinUV writes:

- row 1: the sample names, each in the first of a pair of columns (the second is empty);
- row 2: per pair, the X heading (``Wavelength (nm)``; ``Wavenumber (cm-1)`` is also accepted)
  and the Y mode (``Abs``, ``%T``, ``%R``, ``T``, ``R``);
- data rows: per pair, X and Y; samples may have different lengths (their cells then stay
  empty), wavelengths usually descend (scans run from long to short wavelengths);
- a blank row, then the per-sample method and log block (``Collection Time``, ``Y Mode``...,
  ``Method Log``), which is not data and is skipped.

Y modes other than those above (``F(R)``, ``Log(1/R)``, concentration...) are refused with the
mode named. Each sample carries its own Y mode: a file whose samples use different modes (some
in ``%T``, some in ``Abs``) is read with each sample's own quantity and scale (see
:func:`~.model.finish`), so that a calibration picks the samples it needs by name.
"""

from __future__ import annotations

import csv
import re

import numpy as np

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.spectra.model import RawSample, RawSpectra, is_number, parse_float

__all__ = ["looks_like_cary", "read_cary"]

_Y_MODES = {
    "abs": ("absorbance", None), "a": ("absorbance", None), "absorbance": ("absorbance", None),
    "%t": ("transmittance", 100.0), "t": ("transmittance", 1.0),
    "%r": ("reflectance", 100.0), "r": ("reflectance", 1.0),
    "transmittance": ("transmittance", None), "reflectance": ("reflectance", None),
    "%transmittance": ("transmittance", 100.0), "%reflectance": ("reflectance", 100.0),
}


def _x_unit(cell: str) -> str | None:
    c = cell.strip().lower()
    if c.startswith("wavelength"):
        if "µm" in c or "um)" in c or "micro" in c:
            return "um"
        if "å" in c or "angstrom" in c:
            return "angstrom"
        return "nm"
    if c.startswith("wavenumber"):
        return "cm-1"
    return None


def _rows(text: str) -> list[list[str]]:
    return list(csv.reader(text.splitlines()))


def looks_like_cary(text_head: str) -> bool:
    lines = [ln for ln in text_head.splitlines()[:3]]
    if len(lines) < 2:
        return False
    rows = _rows("\n".join(lines[:2]))
    if len(rows) < 2 or len(rows[1]) < 2:
        return False
    names, head = rows
    # Cary's name row puts each name over its (X, Y) column pair, the second cell empty.
    paired = len(names) >= 2 and all(not c.strip() for c in names[1::2])
    return (paired and _x_unit(head[0]) is not None and not is_number(names[0])
            and not names[0].lstrip().startswith("#") and not is_number(head[1]))


def read_cary(text: str, path: str) -> RawSpectra:
    rows = _rows(text)
    if len(rows) < 3:
        raise DreamPrintError("a Cary export needs a name row, a heading row and data "
                              "(truncated?)", path, len(rows) or None)
    names_row, head = rows[0], rows[1]
    pairs = []
    for k in range(0, len(head) - 1, 2):
        if not head[k].strip() and not head[k + 1].strip():
            continue
        unit = _x_unit(head[k])
        if unit is None:
            raise DreamPrintError(f"column {k + 1}: '{head[k]}' is not a wavelength heading",
                                  path, 2)
        mode = head[k + 1].strip()
        if mode.lower() not in _Y_MODES:
            raise DreamPrintError(f"column {k + 2}: Y mode '{mode}' is not a measurement "
                                  "DreamPrint can use (Abs, %T, %R, T or R)", path, 2)
        name = names_row[k].strip() if k < len(names_row) else ""
        pairs.append((k, name or f"sample {len(pairs) + 1}", unit, mode))
    if not pairs:
        raise DreamPrintError("no wavelength/value column pairs in the heading row", path, 2)
    quantities = {_Y_MODES[m.lower()] for _, _, _, m in pairs}
    units = {u for _, _, u, _ in pairs}
    if len(units) > 1:
        raise DreamPrintError("the samples have different X units", path, 2)
    mixed = len(quantities) > 1
    (quantity, scale), = quantities if not mixed else {(None, None)}

    data: list[tuple[list[float], list[float], bool]] = [([], [], False) for _ in pairs]
    ended = [False] * len(pairs)
    end_line = len(rows)
    for r, row in enumerate(rows[2:], start=3):
        if not any(c.strip() for c in row):
            end_line = r
            break
        for p, (k, name, _, _) in enumerate(pairs):
            x = row[k].strip() if k < len(row) else ""
            y = row[k + 1].strip() if k + 1 < len(row) else ""
            if not x and not y:
                ended[p] = True
                continue
            if ended[p]:
                raise DreamPrintError(f"sample '{name}': values after its column ended", path, r)
            if not x or not y:
                raise DreamPrintError(f"sample '{name}': a wavelength without a value "
                                      "(truncated or garbled line)", path, r)
            try:
                data[p][0].append(parse_float(x))
                data[p][1].append(parse_float(y))
            except ValueError:
                raise DreamPrintError(f"sample '{name}': '{x}', '{y}' is not a pair of "
                                      "numbers", path, r) from None
    samples = []
    for (_, name, _, mode), (xs, ys, _) in zip(pairs, data, strict=True):
        if not xs:
            raise DreamPrintError(f"sample '{name}' has no data", path, 3)
        own_q, own_scale = _Y_MODES[mode.lower()] if mixed else (None, None)
        samples.append(RawSample(name, np.array(xs), np.array(ys), 3, quantity=own_q,
                                 scale=own_scale))
    meta = {}
    for row in rows[end_line:]:
        line = ",".join(row)
        m = re.match(r"\s*(Instrument|Y Mode|Collection Time)\s*[: ]\s*(.+?)\s*$", line)
        if m and m.group(1).lower() not in meta:
            meta[m.group(1).lower()] = m.group(2).strip(" ,")
    return RawSpectra(format="Agilent Cary CSV", samples=samples, quantity=quantity,
                      scale=scale, wavelength_unit=units.pop(), metadata=meta)
