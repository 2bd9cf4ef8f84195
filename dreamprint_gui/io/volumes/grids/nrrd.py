"""NRRD ``.nrrd`` / ``.nhdr`` reader written to the NRRD format 5 specification
(teem.sourceforge.net/nrrd/format.html), including detached data files: a single file, a
``LIST [subdim]`` and a ``<format> <min> <max> <step> [<subdim>]`` pattern.

Defines :func:`read_nrrd` -> (values (z, y, x[, C]) array, origin xyz, spacing xyz).

Why not a library: VTK's vtkNrrdReader rejects spec-conforming file lists and can crash the
process on them; pynrrd does not read file lists.  Sizes are checked against the bytes on disk
before anything is allocated, and compressed data is inflated only up to the size the header
announces.
"""

from __future__ import annotations

import bz2
import re
import zlib
from pathlib import Path

import numpy as np

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes.dense import check_claimed_size

__all__ = ["read_nrrd"]

_TYPES = {
    "int8": "i1", "signed char": "i1", "int8_t": "i1",
    "uchar": "u1", "unsigned char": "u1", "uint8": "u1", "uint8_t": "u1",
    "short": "i2", "short int": "i2", "signed short": "i2", "signed short int": "i2",
    "int16": "i2", "int16_t": "i2",
    "ushort": "u2", "unsigned short": "u2", "unsigned short int": "u2", "uint16": "u2",
    "uint16_t": "u2",
    "int": "i4", "signed int": "i4", "int32": "i4", "int32_t": "i4",
    "uint": "u4", "unsigned int": "u4", "uint32": "u4", "uint32_t": "u4",
    "longlong": "i8", "long long": "i8", "long long int": "i8", "signed long long": "i8",
    "signed long long int": "i8", "int64": "i8", "int64_t": "i8",
    "ulonglong": "u8", "unsigned long long": "u8", "unsigned long long int": "u8",
    "uint64": "u8", "uint64_t": "u8",
    "float": "f4", "double": "f8",
}


def _vec(text: str) -> list[float] | None:
    text = text.strip()
    if text == "none":
        return None
    m = re.fullmatch(r"\(([^)]*)\)", text)
    if not m:
        raise ValueError(text)
    return [float(v) for v in m.group(1).split(",")]


def _parse_header(lines: list[str], path: Path) -> dict:
    fields: dict[str, str] = {}
    for n, line in enumerate(lines, start=2):
        if not line.strip() or line.startswith("#"):
            continue
        if ":=" in line:
            continue                                    # key/value pairs: free-form metadata
        if ": " not in line:
            raise DreamPrintError(f"malformed NRRD field: {line.strip()!r}", path, n)
        k, v = line.split(": ", 1)
        fields[k.strip().lower()] = v.strip()
    return fields


def _inflate(raw: bytes, encoding: str, need: int, path: Path) -> bytes:
    if encoding in ("gzip", "gz"):
        d = zlib.decompressobj(zlib.MAX_WBITS | 32)
        out = d.decompress(raw, need)
    elif encoding in ("bzip2", "bz2"):
        d = bz2.BZ2Decompressor()
        out = d.decompress(raw, need)
    else:
        raise DreamPrintError(f"unsupported NRRD encoding {encoding!r}", path)
    return out


def read_nrrd(path: Path):
    """Read a NRRD image; returns (values (nz, ny, nx[, C]), origin xyz, spacing xyz)."""
    with open(path, "rb") as f:
        head = f.read(1 << 20)
    if not head.startswith(b"NRRD000"):
        raise DreamPrintError("not a NRRD file (no NRRD000x magic)", path)
    # the header ends at the first empty line (attached data follows it)
    m = re.search(rb"\r?\n\r?\n", head)
    header_bytes = head if m is None else head[:m.start()]
    data_start = len(head) if m is None else m.end()
    lines = header_bytes.decode("latin-1").splitlines()[1:]
    # "data file: LIST" is followed by the file names, one per line, up to the end of header
    list_files: list[str] = []
    for i, line in enumerate(lines):
        low = line.lower()
        if low.startswith(("data file:", "datafile:")) and line.split(":", 1)[1].split()[:1] \
                == ["LIST"]:
            list_files = [x.strip() for x in lines[i + 1:] if x.strip()]
            lines = lines[:i + 1]
            break
    f = _parse_header(lines, path)
    try:
        dtype = np.dtype(_TYPES[f["type"].lower()])
        dim = int(f["dimension"])
        sizes = [int(v) for v in f["sizes"].split()]
    except KeyError as exc:
        raise DreamPrintError(f"NRRD header lacks or misstates the required field {exc}",
                              path) from None
    except ValueError:
        raise DreamPrintError("NRRD header has a non-numeric dimension or sizes", path) from None
    if len(sizes) != dim or any(s < 1 for s in sizes):
        raise DreamPrintError(f"NRRD sizes {sizes} do not match dimension {dim}", path)
    if dim not in (3, 4):
        raise DreamPrintError(f"a {dim}-D NRRD is not a volume (need 3 axes, or 4 with "
                              "components first)", path)
    ncomp = sizes[0] if dim == 4 else 1
    spatial = sizes[1:] if dim == 4 else sizes
    if dtype.itemsize > 1:
        endian = f.get("endian", "little").lower()
        dtype = dtype.newbyteorder("<" if endian == "little" else ">")
    n_values = int(np.prod(sizes, dtype=object))
    need = n_values * dtype.itemsize
    encoding = f.get("encoding", "raw").lower()
    if encoding not in ("raw", "gzip", "gz", "bzip2", "bz2", "ascii", "text", "txt"):
        raise DreamPrintError(f"unsupported NRRD encoding {encoding!r}", path)

    # data files
    datafile = f.get("data file", f.get("datafile"))
    subdim = dim
    files: list[Path]
    if datafile is None:
        files = [path]
    else:
        words = datafile.split()
        if words[0] == "LIST":
            files = [path.parent / n for n in list_files]
            subdim = int(words[1]) if len(words) > 1 else dim - 1
        elif len(words) >= 4 and "%" in words[0]:
            lo, hi, step = (int(w) for w in words[1:4])
            if step == 0 or (hi - lo) / step < 0 or abs((hi - lo) // step) > 1_000_000:
                raise DreamPrintError(f"bad NRRD data file pattern {datafile!r}", path)
            subdim = int(words[4]) if len(words) > 4 else dim - 1
            try:
                files = [path.parent / (words[0] % i) for i in range(lo, hi + 1 if step > 0
                                                                     else hi - 1, step)]
            except (TypeError, ValueError):
                raise DreamPrintError(f"bad NRRD data file pattern {words[0]!r}", path) \
                    from None
        else:
            files = [path.parent / datafile]
    if not 1 <= subdim <= dim:
        raise DreamPrintError(f"NRRD data file subdim {subdim} out of range", path)
    per_file = int(np.prod(sizes[:subdim], dtype=object)) * dtype.itemsize
    if per_file * len(files) != need:
        raise DreamPrintError(f"{len(files)} data files of {sizes[:subdim]} values do not make "
                              f"the {sizes} image", path)
    for p in files:
        if not p.is_file():
            raise DreamPrintError("NRRD data file missing", p)
    available = sum(p.stat().st_size for p in files)
    check_claimed_size(n_values, dtype.itemsize, available, path)
    if encoding == "raw" and need > available:
        raise DreamPrintError(f"truncated: {need:,} bytes of data announced, {available:,} on "
                              "disk", path)

    byte_skip = int(f.get("byte skip", f.get("byteskip", "0")))
    line_skip = int(f.get("line skip", f.get("lineskip", "0")))
    out = np.empty(n_values, dtype)
    pos = 0
    for p in files:
        if p == path:
            with open(path, "rb") as fh:
                fh.seek(data_start)
                raw = fh.read()
        else:
            raw = p.read_bytes()
        for _ in range(line_skip):
            nl = raw.find(b"\n")
            raw = raw[nl + 1:] if nl >= 0 else b""
        count = per_file // dtype.itemsize
        if encoding in ("ascii", "text", "txt"):
            vals = np.array(raw.split()[:count], dtype=float) if raw else np.zeros(0)
            if len(vals) < count:
                raise DreamPrintError("truncated ASCII NRRD data", p)
            out[pos:pos + count] = vals
        else:
            if encoding == "raw":
                chunk = raw[-per_file:] if byte_skip == -1 else raw[byte_skip:byte_skip + per_file]
            else:
                skip = max(byte_skip, 0)
                chunk = _inflate(raw, encoding, per_file + skip, p)[skip:]
            if len(chunk) < per_file:
                raise DreamPrintError("truncated NRRD data", p)
            out[pos:pos + count] = np.frombuffer(chunk, dtype, count)
        pos += count

    # geometry: spacings or space directions (axis-aligned only), origin from space origin
    spacing = [1.0, 1.0, 1.0]
    origin = [0.0, 0.0, 0.0]
    try:
        if "space directions" in f:
            dirs = [_vec(t) for t in re.findall(r"\([^)]*\)|none", f["space directions"])]
            dirs = [d for d in dirs if d is not None]
            if len(dirs) != 3:
                raise ValueError
            m3 = np.array(dirs)
            if not np.allclose(m3 - np.diag(np.diag(m3)), 0, atol=1e-9 * np.abs(m3).max()):
                raise DreamPrintError("rotated NRRD space directions: resample it axis-aligned "
                                      "first", path)
            spacing = [abs(float(v)) for v in np.diag(m3)]
        elif "spacings" in f:
            sp = [float(v) for v in f["spacings"].split() if v.lower() != "nan"]
            spacing = sp[-3:] if len(sp) >= 3 else spacing
        if "space origin" in f:
            origin = _vec(f["space origin"])[:3]
        elif "axis mins" in f:
            am = [float(v) for v in f["axis mins"].split() if v.lower() != "nan"]
            origin = am[-3:] if len(am) >= 3 else origin
    except (ValueError, TypeError):
        raise DreamPrintError("malformed NRRD geometry fields", path) from None
    nx, ny, nz = spatial
    if ncomp > 1:
        values = out.reshape(nz, ny, nx, ncomp)
    else:
        values = out.reshape(nz, ny, nx)
    return values, origin, spacing
