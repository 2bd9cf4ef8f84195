"""Printer profiles: voxel grid, tray, slice layout and the RGB code of each material.

Defines
-------
- :class:`PrinterProfile`: voxel size per axis (mm; z = layer thickness), tray size, the slice
  image layout (which axis runs along an image row, row flip), PNG mode, per-material name and
  RGB code in :data:`~dreamprint_gui.core.profile.INKS` order, and the code of an empty voxel.
- :func:`load_printer`: a built-in name (``resources/printers/<name>.toml``) or a user TOML file.
- :func:`builtin_printers`: names of the shipped profiles.
- :func:`check_tray`: refuse a job larger than the tray before any work.
- :data:`EMPTY_LABEL`: the label (6) of an empty voxel; labels 0..5 are the inks C, M, Y, K, W, Cl.

File format (TOML, ``format = "dreamprint-printer"``, ``format_version = 1``): see the shipped
files in ``resources/printers/``. Built-ins: ``j850-paper`` (the DreamPrinting paper's voxel
0.084 x 0.028 x 0.014 mm) and ``voxelprint-14um`` / ``voxelprint-27um`` (GrabCAD Voxel Print
for J750/J850: 600 x 300 dpi in X x Y, 14 or 27 um layers, tray 490 x 390 x 200 mm). Default
material codes: the Vero colour codes of Stratasys' Voxel Print legend (cited in the files).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import tomllib
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.profile import INKS
from dreamprint_gui.core.resources import resource_path

__all__ = ["PrinterProfile", "load_printer", "builtin_printers", "check_tray", "EMPTY_LABEL",
           "DEFAULT_PRINTER", "printer_from_dict", "material_legend", "PRINTER_NAMES",
           "printer_choice"]

FORMAT = "dreamprint-printer"
FORMAT_VERSION = 1
EMPTY_LABEL = len(INKS)  # 6: after the six inks
DEFAULT_PRINTER = "voxelprint-27um"
# Human names of the built-in printers (the ids stay in files and on the command line).
PRINTER_NAMES = {"j850-paper": "Stratasys J850, DreamPrinting paper voxel (84 x 28 x 14 um)",
                 "voxelprint-14um": "Stratasys J750/J850 Voxel Print, 14 um layers",
                 "voxelprint-27um": "Stratasys J750/J850 Voxel Print, 27 um layers (default)"}


@dataclass(frozen=True)
class PrinterProfile:
    """A printer's voxel grid and slice encoding. ``material_rgb`` rows follow ``INKS``."""

    name: str
    voxel_mm: tuple[float, float, float]
    tray_mm: tuple[float, float, float]
    material_names: tuple[str, ...]
    material_rgb: tuple[tuple[int, int, int], ...]
    empty_rgb: tuple[int, int, int] = (255, 255, 255)
    image_columns: str = "x"
    flip_rows: bool = False
    png_mode: str = "rgb"
    description: str = ""
    source: str = ""
    path: str | None = None
    title: str = ""  # a printer file's human name (optional ``title``); ``name`` is the id
    # per material (INKS order) the colour the screen shows it in (``display_rgb``, default
    # its code): legibility only, never written into a slice
    material_display_rgb: tuple[tuple[int, int, int], ...] | None = None

    @property
    def display_name(self) -> str:
        """The printer as an operator names it: its file's ``title``, else the built-in
        printer's name (:data:`PRINTER_NAMES`), else its id."""
        return self.title or PRINTER_NAMES.get(self.name, self.name)

    @property
    def layer_thickness_mm(self) -> float:
        return self.voxel_mm[2]

    def palette(self) -> np.ndarray:
        """(7, 3) uint8: the RGB code of labels 0..5 (INKS) and 6 (empty)."""
        return np.array([*self.material_rgb, self.empty_rgb], dtype=np.uint8)

    def display_palette(self) -> np.ndarray:
        """(7, 3) uint8: the colour the screen shows labels 0..5 and 6 (empty) in: each
        material's ``display_rgb`` (default its code). For display only: slices carry
        :meth:`palette`."""
        shown = self.material_display_rgb or self.material_rgb
        return np.array([*shown, self.empty_rgb], dtype=np.uint8)

    def slice_images(self, labels: np.ndarray) -> np.ndarray:
        """The slice image(s) of labels (..., ny, nx): this printer's column axis and row
        order (a view, no copy)."""
        img = labels if self.image_columns == "x" else labels.swapaxes(-1, -2)
        return img[..., ::-1, :] if self.flip_rows else img

    def pixels_per_metre(self) -> tuple[int, int]:
        """Pixels per metre along a slice image's x (columns) and y (rows), rounded (the
        PNG pHYs chunk's unit): 600 dpi -> 23622 (599.999 dpi)."""
        col = 0 if self.image_columns == "x" else 1
        return (round(1000.0 / self.voxel_mm[col]), round(1000.0 / self.voxel_mm[1 - col]))

    @property
    def volume_per_voxel_mm3(self) -> float:
        return float(self.voxel_mm[0] * self.voxel_mm[1] * self.voxel_mm[2])

    def to_json_dict(self) -> dict[str, Any]:
        d = asdict(self)
        shown = self.material_display_rgb or self.material_rgb
        d["materials"] = {ink: {"name": n, "rgb": list(rgb)} for ink, n, rgb in
                          zip(INKS, self.material_names, self.material_rgb, strict=True)}
        for ink, code, disp in zip(INKS, self.material_rgb, shown, strict=True):
            if disp != code:
                d["materials"][ink]["display_rgb"] = list(disp)
        for k in ("material_names", "material_rgb", "path", "material_display_rgb"):
            d.pop(k)
        d["voxel_mm"] = list(self.voxel_mm)
        d["tray_mm"] = list(self.tray_mm)
        d["empty_rgb"] = list(self.empty_rgb)
        return d

    def fingerprint(self) -> str:
        blob = json.dumps(self.to_json_dict(), sort_keys=True).encode()
        return hashlib.sha256(blob).hexdigest()[:16]


def builtin_printers() -> list[str]:
    """Names of the printer profiles shipped in ``resources/printers``."""
    folder = resource_path("printers")
    return sorted(p.stem for p in folder.glob("*.toml"))


def printer_choice(printer: PrinterProfile | str | os.PathLike | None) -> str | None:
    """How a job states a printer: a built-in loaded from its own file by its name, another
    by its file (or, read from no file, its name); a name or path given as text as it is."""
    if printer is None or isinstance(printer, str | os.PathLike):
        return None if printer is None else os.fspath(printer)
    if printer.path is None:
        return printer.name
    builtin = resource_path("printers", f"{Path(printer.path).stem}.toml")
    if Path(printer.path).resolve() == Path(builtin).resolve():
        return Path(printer.path).stem
    return printer.path


def _positive_triple(d: dict, key: str, src: str) -> tuple[float, float, float]:
    v = d.get(key)
    if (not isinstance(v, list) or len(v) != 3
            or not all(isinstance(x, int | float) and not isinstance(x, bool) for x in v)):
        raise DreamPrintError(f"'{key}' must be a list of three numbers (x, y, z)", src)
    if not all(math.isfinite(x) and x > 0 for x in v):
        raise DreamPrintError(f"'{key}' must be positive and finite, got {v}", src)
    return (float(v[0]), float(v[1]), float(v[2]))


def _rgb(v: Any, what: str, src: str) -> tuple[int, int, int]:
    if (not isinstance(v, list) or len(v) != 3
            or not all(isinstance(x, int) and not isinstance(x, bool) and 0 <= x <= 255
                       for x in v)):
        raise DreamPrintError(f"{what} must be three integers 0..255, got {v!r}", src)
    return (v[0], v[1], v[2])


def printer_from_dict(d: dict[str, Any], src: str = "<printer>") -> PrinterProfile:
    """Validate a parsed printer TOML document; errors name ``src`` and the problem."""
    if d.get("format") != FORMAT:
        raise DreamPrintError(f"not a printer profile (format must be '{FORMAT}')", src)
    if d.get("format_version") != FORMAT_VERSION:
        raise DreamPrintError(f"unsupported format_version {d.get('format_version')!r} "
                              f"(this DreamPrint reads {FORMAT_VERSION})", src)
    name = d.get("name")
    if not isinstance(name, str) or not name:
        raise DreamPrintError("'name' must be a non-empty string", src)
    voxel = _positive_triple(d, "voxel_mm", src)
    tray = _positive_triple(d, "tray_mm", src)
    mats = d.get("materials")
    if not isinstance(mats, dict):
        raise DreamPrintError("missing [materials] table (one entry per ink: "
                              + ", ".join(INKS) + ")", src)
    missing = [i for i in INKS if i not in mats]
    if missing:
        raise DreamPrintError(f"[materials] lacks {', '.join(missing)}: every ink "
                              f"({', '.join(INKS)}) needs a material and an RGB code", src)
    unknown = sorted(set(mats) - set(INKS))
    if unknown:
        raise DreamPrintError(f"[materials] has unknown inks {unknown} (known: {list(INKS)})", src)
    names, codes, shown = [], [], []
    for ink in INKS:
        m = mats[ink]
        if not isinstance(m, dict):
            raise DreamPrintError(f"[materials.{ink}] must be a table with name and rgb", src)
        names.append(str(m.get("name", ink)))
        codes.append(_rgb(m.get("rgb"), f"materials.{ink}.rgb", src))
        shown.append(_rgb(m["display_rgb"], f"materials.{ink}.display_rgb", src)
                     if "display_rgb" in m else codes[-1])
    empty = _rgb(d.get("empty_rgb", [255, 255, 255]), "empty_rgb", src)
    allc = [*codes, empty]
    if len(set(allc)) != len(allc):
        raise DreamPrintError("material and empty RGB codes must all be distinct "
                              "(a slice could not be read back otherwise)", src)
    cols = d.get("image_columns", "x")
    if cols not in ("x", "y"):
        raise DreamPrintError(f"image_columns must be 'x' or 'y', got {cols!r}", src)
    mode = d.get("png_mode", "rgb")
    if mode not in ("rgb", "palette"):
        raise DreamPrintError(f"png_mode must be 'rgb' or 'palette', got {mode!r}", src)
    flip = d.get("flip_rows", False)
    if not isinstance(flip, bool):
        raise DreamPrintError("flip_rows must be true or false", src)
    return PrinterProfile(name=name, voxel_mm=voxel, tray_mm=tray, material_names=tuple(names),
                          material_rgb=tuple(codes), empty_rgb=empty, image_columns=cols,
                          flip_rows=flip, png_mode=mode,
                          description=str(d.get("description", "")),
                          source=str(d.get("source", "")), path=None if src.startswith("<")
                          else src, title=str(d.get("title", "")),
                          material_display_rgb=None if shown == codes else tuple(shown))


def load_printer(name_or_path: str | os.PathLike | None = None) -> PrinterProfile:
    """A built-in printer by name (default :data:`DEFAULT_PRINTER`) or a user ``.toml``
    file."""
    if name_or_path is None:
        name_or_path = DEFAULT_PRINTER
    text = os.fspath(name_or_path)
    p = Path(text)
    if p.suffix.lower() != ".toml" and os.sep not in text and "/" not in text:
        names = builtin_printers()
        if text not in names:
            raise DreamPrintError(f"unknown printer '{text}' (built-in: {', '.join(names)}; "
                                  "or give a .toml file)")
        p = resource_path("printers", f"{text}.toml")
    try:
        raw = p.read_bytes()
    except FileNotFoundError:
        raise DreamPrintError("printer profile not found", p) from None
    except OSError as exc:
        raise DreamPrintError(f"cannot read printer profile: {exc.strerror}", p) from None
    try:
        d = tomllib.loads(raw.decode("utf-8"))
    except UnicodeDecodeError:
        raise DreamPrintError("printer profile is not UTF-8 text", p) from None
    except tomllib.TOMLDecodeError as exc:
        raise DreamPrintError(f"invalid TOML: {exc}", p) from None
    return printer_from_dict(d, str(p))


def material_legend(printer: PrinterProfile | None = None, display: bool = False
                    ) -> list[tuple[str, str, tuple[int, int, int]]]:
    """(label, material name, RGB code) of labels 0..6 (INKS, then ``empty``) exactly as the
    slices of ``printer`` (default: the default printer) encode them: ``palette()`` is the one
    definition the PNG writer and the GUI's legend both read. ``display``: the colours the
    screen shows them in instead (``display_palette()``)."""
    p = printer if printer is not None else load_printer()
    pal = p.display_palette() if display else p.palette()
    names = [*p.material_names, "empty (no material)"]
    return [(lab, name, tuple(int(v) for v in pal[i]))
            for i, (lab, name) in enumerate(zip((*INKS, "empty"), names, strict=True))]


def check_tray(shape_xyz: tuple[int, int, int], printer: PrinterProfile) -> None:
    """Raise if a ``shape_xyz`` voxel job does not fit the printer's tray (both sizes named)."""
    size = [n * v for n, v in zip(shape_xyz, printer.voxel_mm, strict=True)]
    tray = printer.tray_mm
    if any(s > t * (1 + 1e-9) for s, t in zip(size, tray, strict=True)):
        raise DreamPrintError(
            "the job is larger than the printer's tray: job "
            f"{size[0]:.1f} x {size[1]:.1f} x {size[2]:.1f} mm, tray ({printer.name}) "
            f"{tray[0]:.1f} x {tray[1]:.1f} x {tray[2]:.1f} mm (x, y, z)")
