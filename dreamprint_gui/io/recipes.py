"""Recipe CSV files: which fraction of each ink a printed mixture holds.

One reader, :func:`read_recipes`, for ``predict --mix-file``, ``calibrate --chart``,
``proof --chart``, the calibration wizard and the benchmarks. Layouts read (absent inks are 0,
ink names C, M, Y, K, W, Cl in any case):

- a header row naming inks, one row per mixture (``C,M,Y,K,W`` / ``0.5,0,0,0.5,0``); columns
  named ``id``, ``name``, ``sample`` or ``patch`` are ignored;
- cells that name their ink (``k50,c0,m50,y0,w0``, also ``K=50`` or ``K:50``), with the
  header (each cell's ink must be its column's) or without it (the first row's cells name the
  columns);
- one mixture per cell (``"0, 50, 0, 50, 0"``), the first cell of the first row listing the
  inks in that order (``"C, M, Y, K, W"``); the mixtures are read row by row, left to right.

Each mixture sums to 1 (fractions) or to 100 (percent; a ``%`` after a number is allowed).

:func:`read_csv_rows` is the CSV reading (line numbers, comments, blank rows) the project's own
CSV layouts share.
"""

from __future__ import annotations

import csv
import io
import re
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.profile import INKS
from dreamprint_gui.io.spectra.model import parse_float
from dreamprint_gui.io.spectra.plain_csv import csv_delimiter

__all__ = ["read_recipes", "read_csv_rows"]

_LABEL_COLUMNS = {"id", "name", "sample", "sample_id", "sample_name", "patch"}
_INK_BY_NAME = {ink.lower(): ink for ink in INKS}
# an ink name, an optional '=' or ':', a number, an optional '%'
_NAMED_CELL = re.compile(r"^\s*([A-Za-z]+)\s*[=:]?\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
                         r"\s*%?)\s*$")
_LIST_SPLIT = re.compile(r"[\s,;/]+")


def read_csv_rows(path: Path, min_rows: int = 2) -> list[tuple[int, list[str]]]:
    """Non-blank, non-comment rows of a CSV file with their line numbers (header first); the
    delimiter is the spectra readers' (:func:`.spectra.plain_csv.csv_delimiter`: comma,
    semicolon or tab)."""
    try:
        text = Path(path).read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise DreamPrintError("no such file", path) from None
    except UnicodeDecodeError:
        raise DreamPrintError("not a text CSV file", path) from None
    except IsADirectoryError:
        raise DreamPrintError("is a folder, not a CSV file", path) from None
    except OSError as exc:
        raise DreamPrintError(f"cannot read it: {exc.strerror or exc}", path) from None
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    delim = csv_delimiter(lines) or ","
    out = []
    for n, row in enumerate(csv.reader(io.StringIO(text), delimiter=delim), start=1):
        if not row or all(not c.strip() for c in row) or row[0].lstrip().startswith("#"):
            continue
        out.append((n, [c.strip() for c in row]))
    if len(out) < min_rows:
        raise DreamPrintError("needs a header row and at least one data row" if min_rows > 1
                              else "has no data rows", path)
    return out


def _number(cell: str, path: Path, line: int, what: str) -> float:
    if cell == "":
        return 0.0
    try:
        v = parse_float(cell.rstrip("%"))  # also a decimal comma (0,5) as in a ';' file
    except ValueError:
        raise DreamPrintError(f"{what}: {cell!r} is not a number", path, line) from None
    if not np.isfinite(v):
        raise DreamPrintError(f"{what}: {cell!r} is not finite", path, line)
    return v


def _named(cell: str) -> tuple[str, str] | None:
    """(ink, number text) of a cell that names its ink (``k50``), else ``None``."""
    m = _NAMED_CELL.match(cell)
    if m and m.group(1).lower() in _INK_BY_NAME:
        return _INK_BY_NAME[m.group(1).lower()], m.group(2)
    return None


def _ink_list(cell: str) -> list[str] | None:
    """Inks of a cell listing two or more of them (``"C, M, Y, K, W"``), else ``None``."""
    names = [n for n in _LIST_SPLIT.split(cell.strip()) if n]
    if len(names) >= 2 and all(n.lower() in _INK_BY_NAME for n in names):
        return [_INK_BY_NAME[n.lower()] for n in names]
    return None


def _one_per_cell(rows: list[tuple[int, list[str]]], inks: list[str], path: Path
                  ) -> tuple[NDArray, list[int]]:
    """Mixtures written one per cell (``"0, 50, 0, 50, 0"``), row by row, left to right."""
    out, lines = [], []
    for line, row in rows[1:]:
        for cell in row:
            if not cell:
                continue
            parts = [p for p in _LIST_SPLIT.split(cell) if p]
            if len(parts) != len(inks):
                raise DreamPrintError(f"mixture '{cell}' has {len(parts)} values, the first "
                                      f"cell lists {len(inks)} inks ({', '.join(inks)})",
                                      path, line)
            c = np.zeros(len(INKS))
            for ink, p in zip(inks, parts, strict=True):
                c[INKS.index(ink)] = _number(p, path, line, f"ink {ink}")
            out.append(c)
            lines.append(line)
    if not out:
        raise DreamPrintError("no mixtures after the row listing the inks", path, rows[0][0])
    return np.array(out), lines


def _table(rows: list[tuple[int, list[str]]], path: Path) -> tuple[NDArray, list[int]]:
    """A column per ink, named by a header row or by the cells themselves (``k50``)."""
    header_line, first = rows[0]
    named_first = [_named(c) for c in first if c]
    headerless = bool(named_first) and all(n is not None for n in named_first)
    columns: list[tuple[int, str]] = []
    if headerless:
        columns = [(j, n[0]) for j, c in enumerate(first) if c and (n := _named(c))]
        data = rows
    else:
        for j, name in enumerate(first):
            key = name.strip().lower()
            if key in _INK_BY_NAME:
                columns.append((j, _INK_BY_NAME[key]))
            elif key not in _LABEL_COLUMNS:
                raise DreamPrintError(f"column '{name}' is not an ink ({', '.join(INKS)})",
                                      path, header_line)
        data = rows[1:]
    if not columns:
        raise DreamPrintError(f"the header names no ink ({', '.join(INKS)})", path, header_line)
    seen = [ink for _, ink in columns]
    if len(set(seen)) != len(seen):
        dup = next(i for i in seen if seen.count(i) > 1)
        raise DreamPrintError(f"ink {dup} has two columns", path, header_line)
    width = len(first)
    c = np.zeros((len(data), len(INKS)))
    for r, (line, row) in enumerate(data):
        while len(row) > width and not row[-1]:
            row = row[:-1]
        if len(row) != width:
            raise DreamPrintError(f"{len(row)} fields, the header has {width}", path, line)
        for j, ink in columns:
            cell = row[j]
            named = _named(cell)
            if named is not None:
                if named[0] != ink:
                    raise DreamPrintError(f"cell '{cell}' names ink {named[0]} in the column "
                                          f"of ink {ink}", path, line)
                cell = named[1]
            c[r, INKS.index(ink)] = _number(cell, path, line, f"ink {ink}")
    return c, [line for line, _ in data]


def read_recipes(path: Path | str) -> NDArray[np.float64]:
    """Concentrations (n, 6) in ``INKS`` order from a recipes CSV in any layout above."""
    path = Path(path)
    rows = read_csv_rows(path, min_rows=1)
    inks = _ink_list(rows[0][1][0]) if rows[0][1] else None
    if inks is not None and not any(rows[0][1][1:]):
        c, lines = _one_per_cell(rows, inks, path)
    else:
        c, lines = _table(rows, path)
    if not len(c):
        raise DreamPrintError("needs a header row and at least one data row", path)
    if np.any(c < 0):
        r = int(np.argwhere(c < 0)[0][0])
        raise DreamPrintError("negative concentration", path, lines[r])
    sums = c.sum(axis=1)
    percent = np.abs(sums - 100.0) <= 1e-4
    c[percent] /= 100.0
    sums[percent] /= 100.0
    bad = np.flatnonzero(np.abs(sums - 1.0) > 1e-4)
    if bad.size:
        r = int(bad[0])
        raise DreamPrintError(f"concentrations sum to {sums[r]:g}, not 1 (or 100 %)", path,
                              lines[r])
    return c / sums[:, None]
