"""Plain delimited text spectra (CSV, semicolon, tab or blank separated): reader and writers.

Defines :func:`read_plain_csv`, :func:`write_csv_columns` and :func:`write_csv_rows`.

Two orientations, with or without a header row and ``#`` comment lines:

- *columns*: a wavelength per row, the first column the wavelength, one column per sample
  (``wavelength,cyan,magenta`` / ``380,0.12,0.55``, or a bare ``x,y`` table);
- *rows*: a sample per row, one column per wavelength, named in the header (``380``, ``380nm``,
  ``nm380``), the first column the sample name (optional).

colour-science's ``read_spectral_data_from_csv_file`` is not used: it reads only the columns
orientation with a comma, turns unreadable cells silently into NaN through ``numpy.genfromtxt``,
does not skip comment lines and cannot report line numbers.

What the file says is read from its header cells, title rows and comments: ``%T``,
``transmittance``, ``%R``, ``reflectance``, ``Abs``/``absorbance``/``OD``, ``%`` or ``percent``
(a 0-100 scale), ``nm`` / ``um`` / ``µm`` in the wavelength heading, and the explicit
declarations DreamPrint's writers put in comments (``# quantity: transmittance``,
``# scale: fraction``, ``# wavelength unit: nm``). Tables of Kubelka-Munk coefficients
(``Absorption (k)`` / ``Scattering (s)`` blocks) are refused: they are not a measurement.
"""

from __future__ import annotations

import csv
import os
import re
from collections.abc import Sequence

import numpy as np

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.spectra.cgats import names_cgats_fields, read_cgats_rows
from dreamprint_gui.io.spectra.model import (
    QUANTITIES,
    RawSample,
    RawSpectra,
    Sample,
    is_number,
    parse_float,
)

__all__ = ["csv_delimiter", "read_plain_csv", "write_csv_columns", "write_csv_rows",
           "looks_like_cgats_csv", "read_cgats_csv"]

_WL_WORD = re.compile(r"^\s*(wave\s*length|wl\b|lambda|λ|nm\b|um\b|µm\b|wavenumber|x\b)",
                      re.IGNORECASE)
_WL_CELL = re.compile(r"^\s*(?:nm|λ|lambda|wl)?\s*_?(\d+(?:\.\d+)?)\s*(nm|um|µm)?\s*$",
                      re.IGNORECASE)
_KS = re.compile(r"^\s*(absorption|scattering)\s*\(\s*[ks]\s*\)|^\s*saunderson\b",
                 re.IGNORECASE)
_DECL = re.compile(r"^\s*(quantity|scale|wavelength[ _]unit)\s*[:=]\s*(\S+)", re.IGNORECASE)


def _quantity_words(text: str) -> tuple[str | None, bool]:
    """(quantity, percent) suggested by a heading or comment."""
    t = text.lower()
    pct = "%" in t or "percent" in t
    if re.search(r"%\s*t\b|transmittance|transmission", t):
        return "transmittance", pct
    if re.search(r"%\s*r\b|reflectance|reflection", t):
        return "reflectance", pct
    if re.search(r"\babs\b|absorbance|\bod\b|optical density", t):
        return "absorbance", False
    if re.search(r"\bspd\b|spectral power|irradiance|radiance", t):
        return "spd", False
    return None, pct


_QUOTED = re.compile(r'"[^"]*"')


def csv_delimiter(lines: list[str]) -> str | None:
    """The delimiter of delimited text (tab, semicolon, then comma, the first found outside
    quotes on each of the first 20 lines: a spreadsheet in a decimal-comma locale writes
    ``;``), or ``None`` for blank-separated columns. Used by every CSV reader of the project
    (spectra here, recipes and layer measurements through :func:`.recipes.read_csv_rows`)."""
    sample = [_QUOTED.sub("", ln) for ln in lines[:20]]
    for d in ("\t", ";", ","):
        counts = [ln.count(d) for ln in sample]
        if counts and min(counts) > 0:
            return d
    return None


def _wl_value(cell: str) -> tuple[float, str | None] | None:
    m = _WL_CELL.match(cell)
    if not m:
        return None
    unit = (m.group(2) or "").lower().replace("µ", "u") or None
    return float(m.group(1)), unit


def _axis_like(values: Sequence[float]) -> bool:
    """Strictly monotonic and in a spectrophotometer's range (nm, or um below 20)."""
    a = np.asarray(values, dtype=float)
    if a.size < 2 or not np.all(np.isfinite(a)):
        return False
    d = np.diff(a)
    mono = bool(np.all(d > 0) or np.all(d < 0))
    return mono and (bool(np.all((a >= 100) & (a <= 20000))) or bool(np.all((a > 0.1) & (a < 20))))


def read_plain_csv(text: str, path: str) -> RawSpectra:
    comments, content = _content(text)
    if not content:
        raise DreamPrintError("no data lines (only comments or blank lines)", path)
    delim = csv_delimiter([ln for _, ln in content])
    rows: list[tuple[int, list[str]]] = []
    for lineno, line in content:
        cells = (next(csv.reader([line], delimiter=delim)) if delim else line.split())
        rows.append((lineno, [c.strip() for c in cells]))
    for lineno, cells in rows:
        if cells and _KS.match(cells[0] or next((c for c in cells if c), "")):
            raise DreamPrintError(
                "this file holds Kubelka-Munk absorption (k) and scattering (s) coefficients "
                "(or Saunderson constants), not a measured spectrum", path, lineno)
    width = max(len(c) for _, c in rows)
    empty_cols = [j for j in range(width)
                  if all(j >= len(c) or not c[j] for _, c in rows)]
    if empty_cols:
        rows = [(ln, [x for j, x in enumerate(c) if j not in empty_cols]) for ln, c in rows]
    rows = [(ln, c) for ln, c in rows if any(c)]

    def kind(cells: list[str]) -> str:
        nonempty = [x for x in cells if x]
        if all(is_number(x) for x in nonempty):
            return "num"
        if cells and not is_number(cells[0]) and all(is_number(x) for x in cells[1:] if x) \
                and any(cells[1:]):
            return "named"
        return "text"

    kinds = [kind(c) for _, c in rows]
    n_num, n_named = kinds.count("num"), kinds.count("named")
    if not n_num and not n_named:
        raise DreamPrintError("no numeric data rows", path, rows[0][0])
    dominant = "num" if n_num >= n_named else "named"
    first_data = kinds.index(dominant)
    if dominant == "named" and first_data == 0 and len(rows) > 1:
        vals = [_wl_value(x) for x in rows[0][1][1:]]
        if all(vals) and _axis_like([v[0] for v in vals]):
            first_data = 1  # "sample,380,390,...": the header of a sample-per-row table
    header: list[str] | None = None
    header_line = None
    titles = [c for _, c in rows[:first_data]]
    if first_data > 0:
        header_line, header = rows[first_data - 1]
        titles = titles[:-1]
    data = rows[first_data:]
    for (lineno, cells), k in zip(data, kinds[first_data:], strict=True):
        if k == "text" or (k == "named" and dominant == "num"):
            bad = next(x for x in cells if x and not is_number(x))
            raise DreamPrintError(f"'{bad}' is not a number (a text row inside the data, "
                                  "or a garbled line)", path, lineno)

    # Declarations from comments and titles.
    declared: dict[str, str] = {}
    hints: list[str] = []
    for c in comments:
        m = _DECL.match(c)
        if m:
            declared[m.group(1).lower().replace(" ", "_")] = m.group(2).lower().rstrip(".,;")
        else:
            hints.append(c)
    hints += [" ".join(t) for t in titles]

    orientation = None
    wl_unit = None
    if dominant == "named":
        orientation = "rows"
        if header is None:
            raise DreamPrintError("samples in rows but no header row naming the "
                                  "wavelengths", path, data[0][0])
        name_col = True
    else:
        if header is not None and _WL_WORD.match(header[0]):
            orientation = "columns"
        elif header is not None and all(_wl_value(x) for x in header[1:]) and \
                _axis_like([_wl_value(x)[0] for x in header[1:]]):
            orientation = "rows"
        else:
            col0 = [parse_float(c[0]) for _, c in data if c and c[0]]
            if _axis_like(col0):
                orientation = "columns"
            elif header is None and all(_wl_value(x) for x in data[0][1]) and \
                    _axis_like([_wl_value(x)[0] for x in data[0][1]]):
                header_line, header = data[0]
                data = data[1:]
                orientation = "rows"
            else:
                raise DreamPrintError(
                    "cannot tell where the wavelengths are: neither the first column nor the "
                    "header row is a rising or falling wavelength axis", path,
                    header_line or data[0][0])
        name_col = header is not None and not _wl_value(header[0])
    if not data:
        raise DreamPrintError("no data rows after the header", path, header_line)

    samples: list[RawSample] = []
    quantities: set[str | None] = set()
    percent = False
    if orientation == "columns":
        n = len(header) if header is not None else max(len(c) for _, c in data)
        if header is not None:
            unit_m = re.search(r"\b(nm|um|µm|micrometer|micron|angstrom|å|cm-1|1/cm)\b",
                               header[0].lower())
            if unit_m:
                u = unit_m.group(1)
                wl_unit = ("um" if u in ("um", "µm", "micrometer", "micron") else
                           "angstrom" if u in ("angstrom", "å") else
                           "cm-1" if u in ("cm-1", "1/cm") else "nm")
            elif header[0].lower().startswith("wavenumber"):
                wl_unit = "cm-1"
        if n < 2:
            raise DreamPrintError("one column only: a spectrum needs wavelengths and values",
                                  path, data[0][0])
        matrix = _matrix(data, n, path)
        for j in range(1, n):
            name = header[j] if header is not None and j < len(header) and header[j] else (
                f"sample {j}")
            if header is not None and j < len(header):
                q, p = _quantity_words(header[j])
                quantities.add(q)
                percent = percent or p
            samples.append(RawSample(name, matrix[:, 0].copy(), matrix[:, j].copy(),
                                     data[0][0]))
    else:
        start = 1 if name_col else 0
        wl = [_wl_value(x) for x in header[start:]]
        if not all(wl):
            bad = header[start + [i for i, v in enumerate(wl) if not v][0]]
            raise DreamPrintError(f"header cell '{bad}' is not a wavelength", path,
                                  header_line)
        units = {u for _, u in wl if u}
        wl_unit = units.pop() if len(units) == 1 else None
        axis = np.array([v for v, _ in wl])
        n = len(header)
        for i, (lineno, cells) in enumerate(data, 1):
            if len(cells) != n:
                raise DreamPrintError(f"{len(cells)} cells but the header has {n} (truncated "
                                      "or garbled line)", path, lineno)
            vals = np.array([_cell(x, path, lineno) for x in cells[start:]])
            name = cells[0] if name_col and cells[0] else f"row {i}"
            samples.append(RawSample(name, axis.copy(), vals, lineno))
        if name_col and header[0]:
            q, p = _quantity_words(header[0])
            quantities.add(q)
            percent = percent or p
    for h in hints:
        q, p = _quantity_words(h)
        if q is not None:
            quantities.add(q)
        percent = percent or p
    quantities.discard(None)
    if len(quantities) > 1:
        raise DreamPrintError("the headings name several quantities ("
                              + ", ".join(sorted(quantities)) + "): one file, one quantity",
                              path, header_line)
    quantity = quantities.pop() if quantities else None
    scale = 100.0 if percent and quantity in ("reflectance", "transmittance") else None
    if "quantity" in declared:
        quantity = declared["quantity"]
        if quantity not in QUANTITIES:
            raise DreamPrintError(f"'# quantity: {quantity}' is not one of "
                                  + ", ".join(QUANTITIES), path)
    if "scale" in declared:
        if declared["scale"] not in ("fraction", "percent"):
            raise DreamPrintError("'# scale:' must be fraction or percent", path)
        scale = 100.0 if declared["scale"] == "percent" else 1.0
    if "wavelength_unit" in declared:
        wl_unit = {"nm": "nm", "um": "um", "µm": "um", "angstrom": "angstrom",
                   "cm-1": "cm-1"}.get(declared["wavelength_unit"])
        if wl_unit is None:
            raise DreamPrintError("'# wavelength unit:' must be nm, um, angstrom or cm-1",
                                  path)
    label = "CSV, a wavelength per row" if orientation == "columns" else "CSV, a sample per row"
    return RawSpectra(format=label, samples=samples, quantity=quantity, scale=scale,
                      wavelength_unit=wl_unit, metadata={"orientation": orientation})


def _content(text: str) -> tuple[list[str], list[tuple[int, str]]]:
    comments: list[str] = []
    content: list[tuple[int, str]] = []
    for lineno, line in enumerate(text.splitlines(), 1):
        s = line.strip()
        if not s:
            continue
        if s.startswith("#"):
            comments.append(s.lstrip("#").strip())
        else:
            content.append((lineno, line))
    return comments, content


def looks_like_cgats_csv(text_head: str) -> bool:
    """A delimited table whose header names CGATS fields (``SAMPLE_ID,SPECTRAL_NM380,...``)."""

    _, content = _content(text_head)
    if not content:
        return False
    delim = csv_delimiter([ln for _, ln in content[:20]])
    if delim is None:
        return False
    header = next(csv.reader([content[0][1]], delimiter=delim))
    return names_cgats_fields(header)


def read_cgats_csv(text: str, path: str) -> RawSpectra:
    """A sample per row, columns named with CGATS field names (``SAMPLE_ID``, ``SAMPLE_NAME``,
    ``SPECTRAL_NM380`` ... or ``SPECTRAL_PCT380`` / ``SPECTRAL_DEC380``, ``LAB_L`` ... beside
    them), as spreadsheets and colour tools export a CGATS table: the fields mean what CGATS.17
    says (wavelengths from the spectral field names, percent for ``SPECTRAL_PCT``, reflectance
    unless the file says otherwise), columns that are not spectral are ignored. A ``#
    quantity: ...`` / ``# scale: ...`` comment states what CGATS's default would not.
    """

    comments, content = _content(text)
    delim = csv_delimiter([ln for _, ln in content[:20]]) or ","
    rows = [(ln, [c.strip() for c in next(csv.reader([line], delimiter=delim))])
            for ln, line in content]
    (header_line, fields), data = rows[0], rows[1:]
    while fields and not fields[-1]:        # a trailing delimiter on every line
        fields = fields[:-1]
        data = [(ln, c[:-1] if len(c) > len(fields) and not c[-1] else c) for ln, c in data]
    if not data:
        raise DreamPrintError("no data rows after the header", path, header_line)
    declared = {m.group(1).lower().replace(" ", "_"): m.group(2).lower().rstrip(".,;")
                for c in comments if (m := _DECL.match(c))}
    raw = read_cgats_rows(fields, data, path)
    if raw is None:
        raise DreamPrintError("the header names no spectral fields", path, header_line)
    if "quantity" in declared:
        q = declared["quantity"]
        if q not in QUANTITIES:
            raise DreamPrintError(f"'# quantity: {q}' is not one of " + ", ".join(QUANTITIES),
                                  path)
        raw.quantity, raw.implied = q, False
        raw.notes = [n for n in raw.notes if "CGATS default" not in n]
        raw.metadata.pop("quantity_basis", None)
    if "scale" in declared:
        if declared["scale"] not in ("fraction", "percent"):
            raise DreamPrintError("'# scale:' must be fraction or percent", path)
        raw.scale = 100.0 if declared["scale"] == "percent" else 1.0
    raw.format = "CSV with CGATS field names"
    return raw


def _cell(x: str, path: str, lineno: int) -> float:
    if not x:
        return float("nan")
    try:
        return parse_float(x)
    except ValueError:
        raise DreamPrintError(f"'{x}' is not a number", path, lineno) from None


def _matrix(data: list[tuple[int, list[str]]], n: int, path: str) -> np.ndarray:
    out = np.empty((len(data), n))
    for i, (lineno, cells) in enumerate(data):
        if len(cells) != n:
            raise DreamPrintError(f"{len(cells)} cells but {n} columns expected (truncated or "
                                  "garbled line)", path, lineno)
        if not cells[0]:
            raise DreamPrintError("a row without its wavelength", path, lineno)
        out[i] = [_cell(x, path, lineno) for x in cells]
    return out


def _preamble(quantity: str) -> str:
    lines = ["# DreamPrint spectra", f"# quantity: {quantity}"]
    if quantity in ("reflectance", "transmittance"):
        lines.append("# scale: fraction")
    return "\n".join(lines + ["# wavelength unit: nm"]) + "\n"


def write_csv_columns(path: str | os.PathLike, samples: Sequence[Sample],
                      quantity: str) -> None:
    """A wavelength per row, one column per sample (all samples on one wavelength grid)."""
    if not samples:
        raise DreamPrintError("no samples to write", path)
    wl = samples[0].wavelengths_nm
    for s in samples:
        if not np.array_equal(s.wavelengths_nm, wl):
            raise DreamPrintError(f"sample '{s.name}' is on another wavelength grid: write a "
                                  "sample per row instead", path)
    with open(path, "w", encoding="utf-8", newline="") as f:
        f.write(_preamble(quantity))
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["wavelength_nm"] + [s.name for s in samples])
        for i, x in enumerate(wl):
            w.writerow([repr(float(x))] + [repr(float(s.values[i])) for s in samples])


def write_csv_rows(path: str | os.PathLike, samples: Sequence[Sample], quantity: str) -> None:
    """A sample per row (name first), one column per wavelength named in the header."""
    if not samples:
        raise DreamPrintError("no samples to write", path)
    wl = samples[0].wavelengths_nm
    for s in samples:
        if not np.array_equal(s.wavelengths_nm, wl):
            raise DreamPrintError(f"sample '{s.name}' is on another wavelength grid", path)
    with open(path, "w", encoding="utf-8", newline="") as f:
        f.write(_preamble(quantity))
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["sample"] + [repr(float(x)) for x in wl])
        for s in samples:
            w.writerow([s.name] + [repr(float(v)) for v in s.values])
