"""Recognise a spectral file by its content and dispatch to its reader.

Defines :func:`read_text` (bounded, encoding-tolerant reading), :func:`detect_format` and
:func:`read_spectra`, the one entry point the CLI, the calibration set and the GUI use.

Detection looks at the text, not at the file name (instruments and operators name files
freely): an ``IESTM2714`` XML root is IES TM-27-14; ``##TITLE=`` / ``##JCAMP-DX=`` records are
JCAMP-DX; a ``BEGIN_DATA_FORMAT`` line is CGATS.17 (X-Rite, i1Profiler, ArgyllCMS); a name
row followed by ``Wavelength (nm),Abs|%T|%R`` is an Agilent Cary export; a delimited table
whose header names CGATS fields (``SAMPLE_ID,SPECTRAL_NM380,...``) is read with CGATS's
meaning of those fields; anything else is read as a plain delimited table.
"""

from __future__ import annotations

import os

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.spectra.cary import looks_like_cary, read_cary
from dreamprint_gui.io.spectra.cgats import looks_like_cgats, read_cgats
from dreamprint_gui.io.spectra.jcampdx import looks_like_jcamp, read_jcamp
from dreamprint_gui.io.spectra.model import RawSpectra, SpectraFile, ValueScale, finish
from dreamprint_gui.io.spectra.plain_csv import looks_like_cgats_csv, read_cgats_csv, read_plain_csv
from dreamprint_gui.io.spectra.spdx import looks_like_spdx, read_spdx

__all__ = ["read_text", "detect_format", "read_spectra", "MAX_BYTES", "FORMATS"]

# Spectral exports are kilobytes; a chart of thousands of patches is a few megabytes. A cap keeps
# a wrong file (an image, a volume) from being read into memory whole.
MAX_BYTES = 64 * 1024 * 1024
FORMATS = ("spdx", "jcamp-dx", "cgats", "cary", "cgats-csv", "csv")


def read_text(path: str | os.PathLike) -> str:
    """The file's text: UTF-8 (with or without BOM), UTF-16 with BOM, else Latin-1."""
    p = os.fspath(path)
    try:
        size = os.path.getsize(p)
        if size > MAX_BYTES:
            raise DreamPrintError(f"{size / 2**20:.0f} MiB is too large for a spectral "
                                  f"measurement export (limit {MAX_BYTES // 2**20} MiB)", p)
        with open(p, "rb") as f:
            data = f.read(MAX_BYTES + 1)
    except FileNotFoundError:
        raise DreamPrintError("no such file", p) from None
    except IsADirectoryError:
        raise DreamPrintError("is a folder, not a file", p) from None
    except PermissionError:
        raise DreamPrintError("permission denied", p) from None
    if not data.strip():
        raise DreamPrintError("the file is empty", p)
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        return data.decode("utf-16")
    if b"\x00" in data[:4096]:
        raise DreamPrintError("a binary file, not a spectral text export", p)
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        return data.decode("latin-1")


def detect_format(text: str) -> str:
    """One of :data:`FORMATS`, from the first lines of ``text``."""
    head = text[:8192]
    if looks_like_spdx(head):
        return "spdx"
    if looks_like_jcamp(head):
        return "jcamp-dx"
    if looks_like_cgats(text[:65536]):
        return "cgats"
    if looks_like_cary(head):
        return "cary"
    if looks_like_cgats_csv(head):
        return "cgats-csv"
    return "csv"


def read_raw(path: str | os.PathLike) -> RawSpectra:
    p = os.fspath(path)
    text = read_text(p)
    fmt = detect_format(text)
    if fmt == "spdx":
        return read_spdx(p)
    if fmt == "jcamp-dx":
        return read_jcamp(text, p)
    if fmt == "cgats":
        return read_cgats(text, p)
    if fmt == "cary":
        return read_cary(text, p)
    if fmt == "cgats-csv":
        return read_cgats_csv(text, p)
    return read_plain_csv(text, p)


def read_spectra(path: str | os.PathLike, *, quantity: str | None = None,
                 file_quantity: str | None = None,
                 value_scale: ValueScale = "auto") -> SpectraFile:
    """Read every spectrum of a measurement file, with units detected and converted.

    Parameters
    ----------
    quantity
        What the caller needs: ``"reflectance"``, ``"transmittance"``, ``"absorbance"``,
        ``"spd"`` (or ``None``: what the file holds). Absorbance is converted to transmittance
        (T = 10^-A) and back; anything else that differs from what the file states is refused.
        A file that does not state its quantity is taken to hold this one.
    file_quantity
        What the file holds when the file itself does not say (an error if it says otherwise).
    value_scale
        ``"auto"`` (the file's statement, else detection), ``"fraction"`` or ``"percent"``.

    Returns
    -------
    SpectraFile
        Reflectance and transmittance as fractions 0-1, wavelengths ascending in nm, and the
        physically impossible values found (``problems``).

    Raises
    ------
    DreamPrintError
        One line naming the file, the line (for parse errors) and the problem.
    """
    p = os.fspath(path)
    raw = read_raw(p)
    return finish(raw, p, quantity=quantity, file_quantity=file_quantity,
                  value_scale=value_scale)
