"""JCAMP-DX 4.24 UV/VIS spectra: reader (all XYDATA compressions) and a compressing writer.

Defines :func:`looks_like_jcamp`, :func:`read_jcamp`, :func:`write_jcamp` and the ASDF codec
:func:`decode_asdf_line` / :func:`encode_difdup`.

References: R. S. McDonald, P. A. Wilks, "JCAMP-DX: A Standard Form for Exchange of Infrared
Spectra in Computer Readable Form", Appl. Spectrosc. 42 (1988) 151 (labelled data records,
``(X++(Y..Y))`` tables, the ASCII squeezed difference form: SQZ, DIF and DUP characters, the
Y-value check); P. Lampen et al., "JCAMP-DX for UV/VIS spectroscopy" / JCAMP-DX 4.24, Appl.
Spectrosc. 48 (1994) 1545 (``##DATA TYPE=UV/VIS SPECTRUM``, ``YUNITS`` TRANSMITTANCE,
ABSORBANCE, REFLECTANCE, LOG(EPSILON), ``##XYPOINTS=(XY..XY)``, ``LINK`` blocks).

Why not the ``jcamp`` package (1.3.2, installed, the maintained Python reader): checked on files
compressed here to the specification, it raises ``IndexError`` on a DUP count that follows an
SQZ value (e.g. ``@T``, legal and common for flat baselines), misreads DUP counts of two or more
digits (``%S1`` = eleven zero differences), only *prints* failed Y-value and
X checks and length mismatches (a damaged file reads silently wrong) and gives no line numbers.
Its output is used in the tests as an independent cross-check on files it does read.

Reading rules:

- labels compare without blanks, ``-``, ``/``, ``_`` and case (as the specification says);
  ``$$`` starts a comment; a value may continue over lines.
- ``##XYDATA=(X++(Y..Y))``: X of each point from ``FIRSTX``, ``LASTX`` and ``NPOINTS``; the X at
  the start of each line is checked against it (a missing or garbled line is an error); ordinates
  are AFFN or ASDF; in DIF form a line's first ordinate repeats the previous line's last one (the
  Y check) and must equal it; the count must equal ``NPOINTS``. ``##XYPOINTS=(XY..XY)``: pairs;
  ``?`` is a missing value. Both are scaled by ``XFACTOR`` / ``YFACTOR``.
- several blocks (a ``LINK`` compound file, or blocks one after another) are several samples,
  named by their ``TITLE``; ``PEAK TABLE`` and ``NTUPLES`` blocks are refused.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Sequence

import numpy as np

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.spectra.model import RawSample, RawSpectra, Sample

__all__ = ["looks_like_jcamp", "read_jcamp", "write_jcamp", "decode_asdf_line",
           "encode_difdup"]

_SQZ = {"@": 0, **{c: i + 1 for i, c in enumerate("ABCDEFGHI")},
        **{c: -(i + 1) for i, c in enumerate("abcdefghi")}}
_DIF = {"%": 0, **{c: i + 1 for i, c in enumerate("JKLMNOPQR")},
        **{c: -(i + 1) for i, c in enumerate("jklmnopqr")}}
_DUP = {c: i + 1 for i, c in enumerate("STUVWXYZs")}
_COMPRESSED = set(_SQZ) | set(_DIF) | set(_DUP)
# DUP counts expand text into many values: a damaged count must not allocate without bound.
MAX_POINTS = 10_000_000
_AFFN = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([Ee][+-]?\d+)?")
_DIGITS = re.compile(r"\d*\.?\d*")


def looks_like_jcamp(text_head: str) -> bool:
    return re.search(r"^\s*##\s*(TITLE|JCAMP\s*-?\s*DX)\s*=", text_head,
                     re.MULTILINE | re.IGNORECASE) is not None


def _label(raw: str) -> str:
    return re.sub(r"[\s\-/_]", "", raw).upper()


class _Token:
    __slots__ = ("kind", "text")

    def __init__(self, kind: str, text: str) -> None:
        self.kind, self.text = kind, text


def _lex(line: str, lineno: int, path: str) -> list[_Token]:
    """Split one data line into AFFN / SQZ / DIF / DUP tokens (digits kept as text)."""
    toks: list[_Token] = []
    # A line using only AFFN may carry exponents (1.5E+03): there, E/e are not SQZ characters.
    affn = not any(c in _COMPRESSED and c not in "Ee" for c in line)
    i, n = 0, len(line)
    while i < n:
        c = line[i]
        if c in " \t,;":
            i += 1
            continue
        if c == "?":
            toks.append(_Token("missing", "?"))
            i += 1
            continue
        if c.isdigit() or c in "+-." or (affn and c in "Ee"):
            m = _AFFN.match(line, i)
            if not m:
                raise DreamPrintError(f"cannot read '{line[i:i + 12]}' as a number", path,
                                      lineno)
            toks.append(_Token("abs", m.group(0)))
            i = m.end()
            continue
        if c in _SQZ or c in _DIF or c in _DUP:
            m = _DIGITS.match(line, i + 1)
            digits = m.group(0)
            if c in _SQZ:
                toks.append(_Token("abs", f"{'-' if _SQZ[c] < 0 else ''}{abs(_SQZ[c])}{digits}"))
            elif c in _DIF:
                toks.append(_Token("dif", f"{'-' if _DIF[c] < 0 else ''}{abs(_DIF[c])}{digits}"))
            else:
                if "." in digits:
                    raise DreamPrintError(f"DUP count '{c}{digits}' is not whole", path, lineno)
                toks.append(_Token("dup", f"{_DUP[c]}{digits}"))
            i = m.end()
            continue
        raise DreamPrintError(f"unexpected character '{c}' in the data", path, lineno)
    return toks


def decode_asdf_line(line: str, lineno: int = 0, path: str = "", limit: int = MAX_POINTS
                     ) -> tuple[float, list[float], bool]:
    """Decode one ``(X++(Y..Y))`` line: (X, ordinates, whether the last ordinate was DIF).

    More than ``limit`` ordinates (a damaged DUP count) is an error.
    """
    toks = _lex(line, lineno, path)
    if not toks or toks[0].kind != "abs":
        raise DreamPrintError("a data line must start with its X value", path, lineno)
    x = float(toks[0].text)
    ys: list[float] = []
    last: _Token | None = None
    for t in toks[1:]:
        if t.kind == "abs":
            ys.append(float(t.text))
        elif t.kind == "missing":
            ys.append(math.nan)
        elif t.kind == "dif":
            if not ys:
                raise DreamPrintError("a DIF value with no value before it", path, lineno)
            ys.append(ys[-1] + float(t.text))
        else:
            if last is None or last.kind == "dup":
                raise DreamPrintError("a DUP count with nothing to repeat", path, lineno)
            count = int(t.text)
            if count < 1:
                raise DreamPrintError("a DUP count of zero", path, lineno)
            if len(ys) + count - 1 > limit:
                raise DreamPrintError(f"DUP count {count} makes more ordinates than NPOINTS",
                                      path, lineno)
            for _ in range(count - 1):
                ys.append(ys[-1] + float(last.text) if last.kind == "dif" else ys[-1])
            continue
        last = t
    ended_dif = last is not None and last.kind == "dif"
    return x, ys, ended_dif


def _blocks(text: str, path: str) -> list[tuple[int, dict[str, tuple[str, int]], list]]:
    """Blocks of (first line, labelled records {label: (value, line)}, data lines)."""
    blocks = []
    cur: dict[str, tuple[str, int]] | None = None
    data: list[tuple[int, str]] = []
    start = 0
    in_data = False
    last_label = None
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = raw.split("$$", 1)[0].rstrip()
        s = line.strip()
        if s.startswith("##"):
            if "=" not in s:
                raise DreamPrintError(f"labelled record without '=': '{s[:40]}'", path, lineno)
            lab, val = s[2:].split("=", 1)
            lab = _label(lab)
            val = val.strip()
            if lab == "END" and cur is None:
                continue  # the end of a LINK compound file
            if lab == "TITLE":
                if cur is not None and cur.get("DATATYPE", ("",))[0].upper() != "LINK":
                    raise DreamPrintError("a new ##TITLE before the previous block's ##END=",
                                          path, lineno)
                cur, data, start, in_data = {}, [], lineno, False
            elif cur is None:
                raise DreamPrintError("the file must start with ##TITLE=", path, lineno)
            cur[lab] = (val, lineno)
            last_label = lab
            in_data = lab in ("XYDATA", "XYPOINTS", "PEAKTABLE", "DATATABLE")
            if lab == "END":
                if any(k in cur for k in ("XYDATA", "XYPOINTS", "PEAKTABLE", "NTUPLES",
                                          "DATATABLE")):
                    blocks.append((start, cur, data))
                cur = None
                continue
        elif not s:
            continue
        elif cur is None:
            continue  # text between blocks
        elif in_data:
            data.append((lineno, s))
        elif last_label is not None:
            v, ln = cur[last_label]
            cur[last_label] = (v + "\n" + s, ln)
    if cur is not None:
        raise DreamPrintError("the file ends without ##END= (truncated?)", path,
                              len(text.splitlines()))
    return blocks


def _num(rec: dict, key: str, path: str, default: float | None = None) -> float:
    if key not in rec:
        if default is None:
            raise DreamPrintError(f"##{key}= is missing", path)
        return default
    val, line = rec[key]
    try:
        return float(val.replace(",", ".") if val.count(",") == 1 and "." not in val else val)
    except ValueError:
        raise DreamPrintError(f"##{key}={val} is not a number", path, line) from None


def _quantity(yunits: str) -> tuple[str | None, float | None]:
    u = re.sub(r"[\s_]", "", yunits.upper())
    if "EPSILON" in u:
        return "log_epsilon", None
    if u.startswith("%T") or "PERCENTTRANS" in u or u == "TRANSMITTANCE(%)":
        return "transmittance", 100.0
    if u.startswith("%R") or "PERCENTREFL" in u:
        return "reflectance", 100.0
    if u.startswith("TRANSMITTANCE") or u == "T":
        return "transmittance", None
    if u.startswith("REFLECTANCE") or u == "R":
        return "reflectance", None
    if u.startswith("ABSORBANCE") or u in ("A", "ABS", "OD", "OPTICALDENSITY"):
        return "absorbance", None
    return None, None


def _x_unit(xunits: str) -> str | None:
    u = re.sub(r"\s", "", xunits.upper())
    if "NANOMET" in u or "(NM)" in u or u == "NM":
        return "nm"
    if "MICROMET" in u or u in ("UM", "MICRONS") or "(UM)" in u or "µM" in u:
        return "um"
    if "1/CM" in u or "CM-1" in u or "CM^-1" in u or "WAVENUMBER" in u:
        return "cm-1"
    if "ANGSTROM" in u:
        return "angstrom"
    return None


def _xydata(rec: dict, data: list, path: str) -> tuple[np.ndarray, np.ndarray]:
    firstx, lastx = _num(rec, "FIRSTX", path), _num(rec, "LASTX", path)
    npoints = int(_num(rec, "NPOINTS", path))
    if npoints > MAX_POINTS:
        raise DreamPrintError(f"NPOINTS={npoints} is beyond any spectrometer (limit "
                              f"{MAX_POINTS})", path, rec["NPOINTS"][1])
    xf, yf = _num(rec, "XFACTOR", path, 1.0), _num(rec, "YFACTOR", path, 1.0)
    if npoints < 2:
        raise DreamPrintError(f"NPOINTS is {npoints}", path, rec["NPOINTS"][1])
    dx = (lastx - firstx) / (npoints - 1)
    ys: list[float] = []
    prev_dif = False
    for lineno, line in data:
        x, vals, ended_dif = decode_asdf_line(line, lineno, path, npoints + 1 - len(ys))
        first_index = len(ys)
        if prev_dif:
            if not vals:
                raise DreamPrintError("a data line without ordinates", path, lineno)
            if vals[0] != ys[-1]:
                raise DreamPrintError(
                    f"Y check failed: the line starts with {vals[0]:g} but the previous line "
                    f"ended with {ys[-1]:g} (a corrupted line)", path, lineno)
            vals = vals[1:]
            first_index -= 1
        expect = firstx + first_index * dx
        if abs(x * xf - expect) > 0.5 * abs(dx) + 1e-9 * abs(expect):
            raise DreamPrintError(
                f"X check failed: the line starts at X={x * xf:g} but point "
                f"{first_index + 1} is at {expect:g} (a missing or garbled line)", path, lineno)
        ys.extend(vals)
        prev_dif = ended_dif
        if len(ys) > npoints:
            raise DreamPrintError(f"more ordinates than NPOINTS={npoints}", path, lineno)
    if len(ys) != npoints:
        line = data[-1][0] if data else rec["XYDATA"][1]
        raise DreamPrintError(f"{len(ys)} ordinates read but NPOINTS is {npoints} "
                              "(truncated?)", path, line)
    return firstx + dx * np.arange(npoints), np.array(ys) * yf


def _xypoints(rec: dict, data: list, path: str) -> tuple[np.ndarray, np.ndarray]:
    xf, yf = _num(rec, "XFACTOR", path, 1.0), _num(rec, "YFACTOR", path, 1.0)
    values: list[float] = []
    for lineno, line in data:
        for tok in _lex(line, lineno, path):
            if tok.kind == "abs":
                values.append(float(tok.text))
            elif tok.kind == "missing":
                values.append(math.nan)
            else:
                raise DreamPrintError("compressed characters in an (XY..XY) table", path,
                                      lineno)
    if len(values) % 2:
        raise DreamPrintError("an X without its Y at the end of the table (truncated?)", path,
                              data[-1][0] if data else None)
    arr = np.array(values).reshape(-1, 2)
    if "NPOINTS" in rec and int(_num(rec, "NPOINTS", path)) != arr.shape[0]:
        raise DreamPrintError(f"{arr.shape[0]} points read but NPOINTS is "
                              f"{rec['NPOINTS'][0]} (truncated?)", path, rec["NPOINTS"][1])
    return arr[:, 0] * xf, arr[:, 1] * yf


def read_jcamp(text: str, path: str) -> RawSpectra:
    blocks = _blocks(text, path)
    if not blocks:
        raise DreamPrintError("no block with spectral data (##XYDATA= or ##XYPOINTS=)", path)
    samples, quantities, units, scales = [], set(), set(), set()
    meta = {}
    for start, rec, data in blocks:
        for lab in ("PEAKTABLE", "NTUPLES", "DATATABLE"):
            if lab in rec:
                raise DreamPrintError(f"a ##{lab.replace('TABLE', ' TABLE')}= block is not a "
                                      "measured spectrum DreamPrint can use", path,
                                      rec[lab][1])
        form = re.sub(r"\s", "", (rec.get("XYDATA") or rec.get("XYPOINTS"))[0])
        if "XYDATA" in rec:
            if form.upper() not in ("(X++(Y..Y))", "(X++(R..R))", "(X++(I..I))"):
                raise DreamPrintError(f"XYDATA form {form} is not (X++(Y..Y))", path,
                                      rec["XYDATA"][1])
            x, y = _xydata(rec, data, path)
        else:
            if form.upper() not in ("(XY..XY)", "(XR..XR)", "(XI..XI)"):
                raise DreamPrintError(f"XYPOINTS form {form} is not (XY..XY)", path,
                                      rec["XYPOINTS"][1])
            x, y = _xypoints(rec, data, path)
        yunits = rec.get("YUNITS", ("", start))[0]
        q, scale = _quantity(yunits)
        quantities.add(q)
        scales.add(scale)
        units.add(_x_unit(rec.get("XUNITS", ("", start))[0]))
        samples.append(RawSample(rec["TITLE"][0].strip() or f"block {len(samples) + 1}",
                                 x, y, start))
        if not meta:
            meta = {k.lower(): v for k, (v, _) in rec.items()
                    if k in ("TITLE", "DATATYPE", "ORIGIN", "OWNER", "XUNITS", "YUNITS",
                             "JCAMPDX", "SPECTROMETERDATASYSTEM")}
    if len(quantities) > 1 or len(units) > 1 or len(scales) > 1:
        raise DreamPrintError("the blocks have different X or Y units: one quantity per file",
                              path)
    q = quantities.pop()
    notes = []
    if q is None and meta.get("yunits"):
        notes.append(f"YUNITS '{meta['yunits']}' not recognised")
    return RawSpectra(format="JCAMP-DX " + str(meta.get("jcampdx", "")).strip(),
                      samples=samples, quantity=q, scale=scales.pop(),
                      wavelength_unit=units.pop(), notes=notes, metadata=meta)


def encode_difdup(values: Sequence[int], x_values: Sequence[float],
                  per_line: int = 10) -> list[str]:
    """Lines of ``(X++(Y..Y))`` in DIFDUP form with Y checks (integers in, see spec).

    Each line starts with its X, then the first ordinate in SQZ form, then DIF characters with
    DUP counts for repeats; each line after the first repeats the previous line's last
    ordinate as its Y check.
    """
    def sqz(v: int) -> str:
        s = str(abs(v))
        return ("@ABCDEFGHI" if v >= 0 else "@abcdefghi")[int(s[0])] + s[1:]

    def dif(d: int) -> str:
        s = str(abs(d))
        return ("%JKLMNOPQR" if d >= 0 else "%jklmnopqr")[int(s[0])] + s[1:]

    def dup(n: int) -> str:
        s = str(n)
        return "STUVWXYZs"[int(s[0]) - 1] + s[1:]

    vals = [int(v) for v in values]
    lines = []
    i = 0
    n = len(vals)
    while i < n:
        start = i if i == 0 else i - 1  # Y check: repeat the previous line's last ordinate
        chunk = vals[start:i + per_line]
        out = [f"{x_values[start]:.10g}", sqz(chunk[0])]
        diffs = [b - a for a, b in zip(chunk, chunk[1:], strict=False)]
        j = 0
        while j < len(diffs):
            k = j
            while k + 1 < len(diffs) and diffs[k + 1] == diffs[j]:
                k += 1
            out.append(dif(diffs[j]) + (dup(k - j + 1) if k > j else ""))
            j = k + 1
        lines.append("".join(out[:1]) + " " + "".join(out[1:]))
        i += per_line
    return lines


def write_jcamp(path: str | os.PathLike, samples: Sequence[Sample], quantity: str, *,
                digits: int = 12) -> None:
    """Write JCAMP-DX 4.24 UV/VIS with ``(X++(Y..Y))`` in DIFDUP form (one block per sample,
    a LINK compound file for several).

    Samples must be on uniform wavelength grids (the table's X is implicit). Ordinates are
    integers times ``YFACTOR`` = 10^-digits x the largest magnitude, so the round trip error is
    below 10^-digits relative to it.
    """
    yunits = {"reflectance": "REFLECTANCE", "transmittance": "TRANSMITTANCE",
              "absorbance": "ABSORBANCE", "log_epsilon": "LOG(EPSILON)", "spd": "ARBITRARY UNITS"}
    if quantity not in yunits:
        raise DreamPrintError(f"JCAMP-DX cannot state {quantity}", path)
    blocks = []
    for s in samples:
        w, v = s.wavelengths_nm, s.values
        if w.size < 2 or not np.allclose(np.diff(w), (w[-1] - w[0]) / (w.size - 1),
                                         rtol=1e-9, atol=0):
            raise DreamPrintError(f"sample '{s.name}' is not on a uniform grid: (X++(Y..Y)) "
                                  "needs one", path)
        if not np.all(np.isfinite(v)):
            raise DreamPrintError(f"sample '{s.name}' has non-finite values", path)
        top = float(np.max(np.abs(v))) or 1.0
        yfactor = float(f"{top * 10.0 ** -digits:.6e}")
        ints = np.rint(v / yfactor).astype(np.int64)
        body = encode_difdup(ints.tolist(), w.tolist())
        blocks.append([
            f"##TITLE={s.name}", "##JCAMP-DX=4.24", "##DATA TYPE=UV/VIS SPECTRUM",
            "##ORIGIN=DreamPrint", "##OWNER=public domain",
            "##XUNITS=NANOMETERS", f"##YUNITS={yunits[quantity]}",
            "##XFACTOR=1", f"##YFACTOR={yfactor!r}",
            f"##FIRSTX={float(w[0])!r}", f"##LASTX={float(w[-1])!r}", f"##NPOINTS={w.size}",
            f"##FIRSTY={float(v[0])!r}", "##XYDATA=(X++(Y..Y))", *body, "##END="])
    if len(blocks) == 1:
        lines = blocks[0]
    else:
        lines = ["##TITLE=DreamPrint spectra", "##JCAMP-DX=4.24", "##DATA TYPE=LINK",
                 f"##BLOCKS={len(blocks)}"]
        for i, b in enumerate(blocks, 1):
            lines += [b[0], b[1], f"##BLOCK_ID={i}", *b[2:]]
        lines.append("##END=")
    with open(path, "w", encoding="utf-8", newline="\n") as f:
        f.write("\n".join(lines) + "\n")
