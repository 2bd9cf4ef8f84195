"""CGATS.17 / ISO 28178 spectral measurement files: reader and writer.

Defines :func:`read_cgats` (text -> :class:`~.model.RawSpectra`) and :func:`write_cgats`.

Written to the published specification (ANSI CGATS.17-2009, ISO 28178:2009 "Exchange formats
for colour and process control data using XML or ASCII text"), because no maintained Python
reader handles the spectral variants: colour-science's ``read_sds_from_xrite_file`` (the only
one) splits lines on whitespace (quoted names with spaces break it), takes the sample name from
the second column and the spectral columns from the end of the line, ignores keywords,
``NUMBER_OF_SETS`` and truncation, and gives no line numbers. The tests cross-check this reader
against it on the X-Rite sample it was written for.

What the specification and the common writers give, and how it is read:

- Structure: an optional file identifier line (``CGATS.17``, ``CTI3``, ``SPECT``...), keyword
  lines ``NAME value`` (values quoted or not; ``KEYWORD "NAME"`` declares a private keyword),
  ``#`` comments, ``NUMBER_OF_FIELDS`` / ``BEGIN_DATA_FORMAT`` ... ``END_DATA_FORMAT`` (field
  names), ``NUMBER_OF_SETS`` / ``BEGIN_DATA`` ... ``END_DATA`` (one set per line). Several
  tables may follow each other (ArgyllCMS); the first one holding spectra is read. Tabs or
  spaces, CRLF or LF, quoted strings with blanks all tolerated; decimal commas accepted.
- Spectral fields, wide layout: ``SPECTRAL_NM380`` (i1Profiler), ``SPEC_380`` (ArgyllCMS),
  ``nm380`` (X-Rite Spectrolino/ColorPort), ``SPECTRAL_PCT380`` / ``SPECTRAL_DEC380``,
  ``R_380``, ``380_NM``. Long layout: ``SPECTRAL_NM`` (wavelength) with ``SPECTRAL_PCT``
  (percent) or ``SPECTRAL_DEC`` (decimal) on one row per sample and wavelength (the field
  definitions of CGATS.5 / ISO 13655 Annex). Samples are named by ``SAMPLE_NAME``, else
  ``SAMPLE_ID`` / ``SampleID``, else their row.
- Scale: ``SPECTRAL_PCT`` fields are percent, ``SPECTRAL_DEC`` fractions; otherwise the
  ``SPECTRAL_NORM`` keyword (ArgyllCMS writes 100 for percent) or, when absent, detection from
  the values: i1Profiler writes ``SPECTRAL_NM`` fields as fractions in some versions and as
  0-100 in others without saying which (see model.PERCENT_THRESHOLD).
- Quantity (:func:`cgats_quantity`): ``MEAS_TYPE`` ``REFLECTIVE`` / ``TRANSMISSIVE`` /
  ``EMISSIVE`` (ArgyllCMS), another measurement keyword saying transmittance / reflectance /
  emission, or a display ``DEVICE_CLASS``; otherwise reflectance, the CGATS default (spectral
  fields are reflectance factors unless the file says otherwise), which a caller stating
  transmittance overrules.
- ``SPECTRAL_BANDS``, ``SPECTRAL_START_NM``, ``SPECTRAL_END_NM`` are checked against the fields;
  ``NUMBER_OF_FIELDS`` / ``NUMBER_OF_SETS`` against what was read (a truncated file is an error).
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.spectra.model import RawSample, RawSpectra, Sample, parse_float

__all__ = ["read_cgats", "write_cgats", "looks_like_cgats", "wavelength_of_field"]

_WIDE = re.compile(
    r"^(?:(?P<prefix>SPECTRAL_NM|SPECTRAL_PCT|SPECTRAL_DEC|SPECTRAL|SPEC|SPECTRUM|NM|R)_?"
    r"(?P<wl>\d+(?:\.\d+)?)|(?P<wl2>\d+(?:\.\d+)?)_?NM)$", re.IGNORECASE)
_NAME_FIELDS = ("SAMPLE_NAME", "SAMPLE_ID", "SAMPLEID", "SAMPLE_LOC", "ID")
# The predefined data format identifiers of CGATS.17 (as Little CMS's cmscgats.c lists them),
# by which a plain CSV header is recognised as naming CGATS fields.
CGATS_FIELDS = frozenset({
    "SAMPLE_ID", "SAMPLE_NAME", "STRING", "CMYK_C", "CMYK_M", "CMYK_Y", "CMYK_K", "D_RED",
    "D_GREEN", "D_BLUE", "D_VIS", "D_MAJOR_FILTER", "RGB_R", "RGB_G", "RGB_B", "SPECTRAL_NM",
    "SPECTRAL_PCT", "SPECTRAL_DEC", "XYZ_X", "XYZ_Y", "XYZ_Z", "XYY_X", "XYY_Y", "XYY_CAPY",
    "LAB_L", "LAB_A", "LAB_B", "LAB_C", "LAB_H", "LAB_DE", "LAB_DE_94", "LAB_DE_CMC",
    "LAB_DE_2000", "MEAN_DE", "STDEV_X", "STDEV_Y", "STDEV_Z", "STDEV_L", "STDEV_A", "STDEV_B",
    "STDEV_DE", "CHI_SQD_PAR"})
_CGATS_SPECTRAL = re.compile(r"^SPECTRAL_(?:NM|PCT|DEC)_?\d", re.IGNORECASE)


_PLAIN_NM = re.compile(r"^(\d+(?:\.\d+)?)\s*(?:nm)?$", re.IGNORECASE)


def wavelength_of_field(cell: str) -> float | None:
    """The wavelength in nm a column heading names (``380``, ``380nm``, ``nm380``,
    ``SPECTRAL_NM380``, ``SPEC_380``, ``R380``, ``380_NM``), else ``None``: the one rule for
    spectral headings of the project's own CSV layouts."""
    c = cell.strip()
    m = _WIDE.match(c) or _PLAIN_NM.match(c)
    if m is None:
        return None
    return float(next(g for g in m.groups() if g is not None and g[0].isdigit()))


def names_cgats_fields(cells: Sequence[str]) -> bool:
    """Whether a header row names its columns with CGATS spectral field names: two or more
    ``SPECTRAL_NM380``-style cells, or spectral cells (``nm380``, ``R380``...) beside a
    predefined CGATS field such as ``SAMPLE_ID`` or ``LAB_L``."""
    cells = [c.strip() for c in cells]
    if sum(1 for c in cells if _CGATS_SPECTRAL.match(c)) >= 2:
        return True
    return (sum(1 for c in cells if _WIDE.match(c)) >= 2
            and any(c.upper() in CGATS_FIELDS for c in cells))


def read_cgats_rows(fields: list[str], rows: list[tuple[int, list[str]]], path: str,
                    keywords: dict[str, str] | None = None) -> RawSpectra | None:
    """Spectra of a table given as CGATS fields and data rows (from any container: a CGATS
    file, or a CSV whose header uses CGATS field names); ``None`` when it has no spectral
    fields."""
    return _table_spectra(_Table(ident=None, keywords=dict(keywords or {}), fields=fields,
                                 rows=rows, data_line=rows[0][0] if rows else 0), path)


def looks_like_cgats(text_head: str) -> bool:
    return re.search(r"^\s*BEGIN_DATA_FORMAT\b", text_head, re.MULTILINE) is not None


@dataclass
class _Table:
    ident: str | None
    keywords: dict[str, str] = field(default_factory=dict)
    n_fields: tuple[int, int] | None = None  # (value, line)
    n_sets: tuple[int, int] | None = None
    fields: list[str] = field(default_factory=list)
    rows: list[tuple[int, list[str]]] = field(default_factory=list)
    data_line: int = 0


def _tokens(line: str, lineno: int, path: str) -> list[str]:
    """Whitespace-separated tokens; double-quoted strings kept whole; ``#`` starts a comment."""
    out: list[str] = []
    i, n = 0, len(line)
    while i < n:
        c = line[i]
        if c in " \t\r\f\v":
            i += 1
        elif c == "#":
            break
        elif c == '"':
            # A doubled quote inside a string stands for one quote character.
            buf, j = [], i + 1
            while True:
                k = line.find('"', j)
                if k < 0:
                    raise DreamPrintError("unterminated quoted string", path, lineno)
                buf.append(line[j:k])
                if line.startswith('""', k):
                    buf.append('"')
                    j = k + 2
                    continue
                break
            out.append("".join(buf))
            i = k + 1
        else:
            j = i
            while j < n and line[j] not in " \t\r\f\v\"":
                j += 1
            out.append(line[i:j])
            i = j
    return out


def _int_kw(tokens: list[str], lineno: int, path: str) -> tuple[int, int]:
    if len(tokens) < 2 or not re.fullmatch(r"\+?\d+", tokens[1]):
        raise DreamPrintError(f"{tokens[0]} needs a whole number", path, lineno)
    return int(tokens[1]), lineno


def _parse_tables(text: str, path: str) -> list[_Table]:
    tables: list[_Table] = []
    cur: _Table | None = None
    state = "header"
    last = 0
    for lineno, line in enumerate(text.splitlines(), 1):
        last = lineno
        toks = _tokens(line, lineno, path)
        if not toks:
            continue
        head = toks[0].upper()
        if state == "format":
            if head == "END_DATA_FORMAT":
                state = "header"
            else:
                cur.fields.extend(toks)
            continue
        if state == "data":
            if head == "END_DATA":
                state = "header"
                tables.append(cur)
                cur = None
            else:
                cur.rows.append((lineno, toks))
            continue
        if cur is None:
            cur = _Table(ident=None)
            if len(toks) == 1 and head not in ("BEGIN_DATA_FORMAT", "BEGIN_DATA"):
                cur.ident = toks[0]
                continue
        if head == "BEGIN_DATA_FORMAT":
            state = "format"
        elif head == "BEGIN_DATA":
            if not cur.fields:
                raise DreamPrintError("BEGIN_DATA before any BEGIN_DATA_FORMAT", path, lineno)
            state, cur.data_line = "data", lineno
        elif head in ("END_DATA", "END_DATA_FORMAT"):
            raise DreamPrintError(f"{toks[0]} without its BEGIN", path, lineno)
        elif head == "NUMBER_OF_FIELDS":
            cur.n_fields = _int_kw(toks, lineno, path)
        elif head == "NUMBER_OF_SETS":
            cur.n_sets = _int_kw(toks, lineno, path)
        elif head == "KEYWORD":
            continue
        else:
            cur.keywords[head] = " ".join(toks[1:])
    if state == "format":
        raise DreamPrintError("the file ends inside BEGIN_DATA_FORMAT (truncated?)", path, last)
    if state == "data":
        raise DreamPrintError("the file ends inside the data: no END_DATA (truncated?)", path,
                              last)
    return tables


def _field_index(fields: list[str], names: Sequence[str]) -> int | None:
    upper = [f.upper() for f in fields]
    for name in names:
        if name in upper:
            return upper.index(name)
    return None


def _number(tok: str, fieldname: str, lineno: int, path: str) -> float:
    if tok in ("?", "", "-") or tok.upper() in ("N/A", "NA"):
        return math.nan
    try:
        return parse_float(tok)
    except ValueError:
        raise DreamPrintError(f"{fieldname}: '{tok}' is not a number", path, lineno) from None


def _table_spectra(t: _Table, path: str) -> RawSpectra | None:
    fields = t.fields
    upper = [f.upper() for f in fields]
    wide = [(i, m) for i, f in enumerate(fields) if (m := _WIDE.match(f))]
    long_val = _field_index(fields, ("SPECTRAL_PCT", "SPECTRAL_DEC"))
    long_wl = _field_index(fields, ("SPECTRAL_NM",))
    if not wide and (long_val is None or long_wl is None):
        return None

    if t.n_fields is not None and t.n_fields[0] != len(fields):
        raise DreamPrintError(f"NUMBER_OF_FIELDS is {t.n_fields[0]} but the data format names "
                              f"{len(fields)} fields", path, t.n_fields[1])
    for lineno, toks in t.rows:
        if len(toks) != len(fields):
            raise DreamPrintError(f"{len(toks)} values on this line but the data format has "
                                  f"{len(fields)} fields (truncated or garbled line)",
                                  path, lineno)
    if t.n_sets is not None and t.n_sets[0] != len(t.rows):
        raise DreamPrintError(f"NUMBER_OF_SETS is {t.n_sets[0]} but {len(t.rows)} data "
                              "line(s) were read (truncated file?)", path, t.n_sets[1])

    name_i = _field_index(fields, _NAME_FIELDS)
    kw = t.keywords
    scale: float | None = None
    samples: list[RawSample] = []

    if wide:
        prefixes = {(m.group("prefix") or "NM").upper() for _, m in wide}
        if len(prefixes) > 1:
            raise DreamPrintError("spectral fields of several kinds in one table: "
                                  + ", ".join(sorted(prefixes)), path, t.data_line)
        prefix = prefixes.pop()
        wl = np.array([float(m.group("wl") or m.group("wl2")) for _, m in wide])
        cols = [i for i, _ in wide]
        if prefix == "SPECTRAL_PCT":
            scale = 100.0
        elif prefix == "SPECTRAL_DEC":
            scale = 1.0
        for row_no, (lineno, toks) in enumerate(t.rows, 1):
            name = toks[name_i] if name_i is not None else f"sample {row_no}"
            vals = np.array([_number(toks[c], fields[c], lineno, path) for c in cols])
            samples.append(RawSample(name, wl.copy(), vals, lineno))
        _check_bands(kw, wl, path, t.data_line)
    else:
        scale = 100.0 if upper[long_val] == "SPECTRAL_PCT" else 1.0
        groups: dict[str, tuple[int, list[float], list[float]]] = {}
        for lineno, toks in t.rows:
            name = toks[name_i] if name_i is not None else "sample 1"
            g = groups.setdefault(name, (lineno, [], []))
            g[1].append(_number(toks[long_wl], "SPECTRAL_NM", lineno, path))
            g[2].append(_number(toks[long_val], fields[long_val], lineno, path))
        samples = [RawSample(n, np.array(w), np.array(v), ln)
                   for n, (ln, w, v) in groups.items()]

    if scale is None and "SPECTRAL_NORM" in kw:
        try:
            scale = parse_float(kw["SPECTRAL_NORM"])
        except ValueError:
            raise DreamPrintError(f"SPECTRAL_NORM '{kw['SPECTRAL_NORM']}' is not a number",
                                  path) from None
        if not (math.isfinite(scale) and scale > 0):
            raise DreamPrintError(f"SPECTRAL_NORM {scale} must be positive", path)
    quantity, implied, notes = cgats_quantity(kw)
    raw_meta = {k.lower(): v for k, v in kw.items()}
    if implied and quantity == "reflectance" and not notes:
        raw_meta["quantity_basis"] = "CGATS default"
        notes.append("quantity: reflectance (CGATS default: spectral fields hold reflectance "
                     "factors unless the file says otherwise)")

    writer = t.ident or "CGATS"
    if "SPECTROLINO" in kw.get("INSTRUMENTATION", "").upper():
        writer = "X-Rite Spectrolino export"
    elif "I1PROFILER" in kw.get("ORIGINATOR", "").upper().replace(" ", ""):
        writer = "X-Rite i1Profiler"
    elif t.ident and t.ident.upper() in ("CTI3", "CTI2", "CTI1", "SPECT", "CCSS"):
        writer = f"ArgyllCMS {t.ident}"
    label = "CGATS.17" if writer.upper() in ("CGATS", "CGATS.17") else f"CGATS.17 ({writer})"
    return RawSpectra(format=label, samples=samples, quantity=quantity, implied=implied,
                      scale=scale, wavelength_unit="nm", notes=notes, metadata=raw_meta)


_STATED = (
    (re.compile(r"TRANSMI(?:SSIVE|SSION|TTANCE|TTED)"), "transmittance"),
    (re.compile(r"REFLECT(?:IVE|ION|ANCE)"), "reflectance"),
    (re.compile(r"\bEMISSIVE\b|\bEMISSION\b|\bIRRADIANCE\b|\bRADIANCE\b|\bILLUMINANT\b"
                r"|SPECTRAL POWER"), "spd"),
)
# Keywords that describe what was measured (ArgyllCMS's MEAS_TYPE first); other keywords
# (ORIGINATOR, MEASUREMENT_SOURCE's "Illumination=D50" ...) name things that are not the
# quantity.
_STATING_KEYWORD = re.compile(r"^(?:MEAS_TYPE|MEASUREMENT_(?:TYPE|MODE|GEOMETRY)|MEAS_MODE|"
                              r"DESCRIPTOR|TABLE_DESCRIPTOR|SAMPLE_TYPE|TARGET_TYPE)$")


def cgats_quantity(kw: dict[str, str]) -> tuple[str, bool, list[str]]:
    """(quantity, implied, notes) of a CGATS table's spectral fields from its keywords.

    A keyword describing the measurement (``MEAS_TYPE`` / ``MEASUREMENT_TYPE`` / ``..._MODE`` /
    ``..._GEOMETRY`` / ``DESCRIPTOR``) that says transmissive/transmittance, reflective or
    emissive states the quantity; so does a display ``DEVICE_CLASS``. Otherwise the spectral
    fields are reflectance factors: CGATS.5 / ISO 13655 define the spectral data of graphic-arts
    measurements as reflectance factor (SPECTRAL_PCT / SPECTRAL_DEC "reflectance/transmittance",
    transmittance only for a transmissive measurement stated as such), and ArgyllCMS reads
    spectral .ti3 values as reflectance "unless the input is marked" otherwise. That default is
    marked ``implied`` so that a caller stating transmittance overrules it.
    """
    keys = sorted((k for k in kw if _STATING_KEYWORD.match(k)), key=lambda k: k != "MEAS_TYPE")
    for k in keys:
        value = kw[k].upper()
        for pattern, q in _STATED:
            if pattern.search(value):
                return q, False, []
    device = kw.get("DEVICE_CLASS", "").upper()
    if device == "DISPLAY":
        return "spd", False, []
    if ("WHITEBASE" in kw.get("MEASUREMENT_SOURCE", "").upper().replace(" ", "")
            or re.fullmatch(r"M[0-3]", kw.get("MEASUREMENT_CONDITION", "").strip().upper())
            or device in ("OUTPUT", "INPUT")):
        # A white base (paper / absolute), the ISO 13655 conditions M0-M3 and ArgyllCMS's
        # printer/scanner charts are reflectance measurements, unless the caller says otherwise.
        return "reflectance", True, ["reflectance, as the measurement conditions imply"]
    return "reflectance", True, []


def _check_bands(kw: dict[str, str], wl: np.ndarray, path: str, line: int) -> None:
    try:
        if "SPECTRAL_BANDS" in kw and int(parse_float(kw["SPECTRAL_BANDS"])) != wl.size:
            raise DreamPrintError(f"SPECTRAL_BANDS is {kw['SPECTRAL_BANDS']} but {wl.size} "
                                  "spectral fields are named", path, line)
        for key, want in (("SPECTRAL_START_NM", wl.min()), ("SPECTRAL_END_NM", wl.max())):
            if key in kw and abs(parse_float(kw[key]) - want) > 0.5:
                raise DreamPrintError(f"{key} is {kw[key]} but the spectral fields span "
                                      f"{wl.min():g}-{wl.max():g} nm", path, line)
    except ValueError:
        raise DreamPrintError("SPECTRAL_BANDS/START_NM/END_NM must be numbers", path,
                              line) from None


def read_cgats(text: str, path: str) -> RawSpectra:
    """Read the first table holding spectra from CGATS text; see the module docstring."""
    tables = _parse_tables(text, path)
    if not tables:
        raise DreamPrintError("no BEGIN_DATA ... END_DATA table found", path)
    for t in tables:
        raw = _table_spectra(t, path)
        if raw is not None:
            others = sum(1 for u in tables if u is not t)
            if others:
                raw.notes.append(f"{others} other table(s) in the file not read")
            return raw
    raise DreamPrintError("the CGATS data holds no spectral fields (such as SPECTRAL_NM380, "
                          "SPEC_380 or nm380): only colorimetric or device values", path)


def _quote(s: str) -> str:
    return '"' + s.replace('"', '""').replace("\n", " ").replace("\r", " ") + '"'


def write_cgats(path: str | os.PathLike, samples: Sequence[Sample], quantity: str) -> None:
    """Write spectra as CGATS.17 with ``SPECTRAL_NM<wl>`` fields, values as fractions.

    All samples must share one wavelength grid (one table). The quantity is stated with
    ``MEAS_TYPE`` (ArgyllCMS's keyword) and the scale with ``SPECTRAL_NORM 1``. CGATS has no
    absorbance: convert to transmittance first.
    """
    meas = {"reflectance": "REFLECTIVE", "transmittance": "TRANSMISSIVE", "spd": "EMISSIVE"}
    if quantity not in meas:
        raise DreamPrintError(f"CGATS cannot state {quantity}: write reflectance, "
                              "transmittance or a spectral power distribution", path)
    if not samples:
        raise DreamPrintError("no samples to write", path)
    wl = samples[0].wavelengths_nm
    for s in samples:
        if s.wavelengths_nm.shape != wl.shape or not np.array_equal(s.wavelengths_nm, wl):
            raise DreamPrintError(f"sample '{s.name}' is on another wavelength grid: CGATS "
                                  "holds one grid per table", path)
    names = ["SPECTRAL_NM" + repr(float(w)).removesuffix(".0") for w in wl]
    if len(set(names)) != len(names):
        raise DreamPrintError("wavelengths too close to name as CGATS fields", path)
    lines = [
        "CGATS.17",
        'ORIGINATOR "DreamPrint"',
        f"MEAS_TYPE {_quote(meas[quantity])}",
        'KEYWORD "SPECTRAL_BANDS"', f'SPECTRAL_BANDS "{wl.size}"',
        'KEYWORD "SPECTRAL_START_NM"', f'SPECTRAL_START_NM "{float(wl[0])!r}"',
        'KEYWORD "SPECTRAL_END_NM"', f'SPECTRAL_END_NM "{float(wl[-1])!r}"',
        'KEYWORD "SPECTRAL_NORM"', 'SPECTRAL_NORM "1"',
        f"NUMBER_OF_FIELDS {len(names) + 2}",
        "BEGIN_DATA_FORMAT",
        "SAMPLE_ID\tSAMPLE_NAME\t" + "\t".join(names),
        "END_DATA_FORMAT",
        f"NUMBER_OF_SETS {len(samples)}",
        "BEGIN_DATA",
    ]
    for i, s in enumerate(samples, 1):
        lines.append(f"{i}\t{_quote(s.name)}\t" + "\t".join(repr(float(v)) for v in s.values))
    lines.append("END_DATA")
    with open(path, "w", encoding="utf-8", newline="\n") as f:
        f.write("\n".join(lines) + "\n")
