"""The translucency target: flat slabs of each ink at each thickness, as a Voxel Print job.

Method step: ink calibration (paper section 4.2) needs R and T of slabs of known thickness; this
module lays them out (:func:`plan_wedge`) and writes the job (:func:`write_wedge`): the slices
(one PNG per printer layer, the printer's material codes), ``manifest.json`` in the layout
``dreamprint evaluate job`` checks, and the operator's sheet: ``wedge-sheet.csv`` (one row per
slab: ink, nominal and as-printed thickness, position, label), ``wedge-sheet.png`` (a top view
with the labels) and ``slabs-template.toml``, a calibration set (docs/calibration-set.md) with a
layer per slab whose measurement files the operator fills in (docs/translucency.md).

Each slab is ``slab_mm`` square (25 mm: an integrating sphere's 10-25 mm port or a handheld
instrument's 4-8 mm aperture sees only the slab's interior), as many printer layers thick as
round(t / layer) gives (the sheet states the printed thickness). Beside each slab, in the
slices' margin, a White tab as tall as the slab carries its label ("Cl 2 mm") in Black through
all its layers, so the slab can be told after removal from the tray. The label glyphs come
from Pillow's built-in font, drawn at 0.02 mm per pixel and read at the voxel centres.
Everything is written into a temporary folder renamed into place (:class:`JobWriter`).
"""

from __future__ import annotations

import csv
import io
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.printer import EMPTY_LABEL, PrinterProfile, check_tray
from dreamprint_gui.core.profile import INKS
from dreamprint_gui.job.encode.png_slices import encode_labels_pngs
from dreamprint_gui.job.manifest import (
    count_entries,
    grid_entries,
    header,
    labels_entry,
    slices_entry,
)
from dreamprint_gui.job.write import JobWriter, slice_name

__all__ = ["WedgeSlab", "plan_wedge", "write_wedge", "WEDGE_INKS", "WEDGE_THICKNESSES_MM",
           "SLAB_MM", "SHEET_CSV", "SHEET_PNG", "SET_TEMPLATE"]

WEDGE_INKS = ("Cl", "W", "C", "M", "Y", "K")
WEDGE_THICKNESSES_MM = (0.5, 1.0, 2.0, 4.0, 8.0)
SLAB_MM = 25.0
TAB_MM = 6.0      # the label tab's depth beside the slab
GAP_MM = 4.0      # between slabs (and tabs)
SHEET_CSV = "wedge-sheet.csv"
SHEET_PNG = "wedge-sheet.png"
SET_TEMPLATE = "slabs-template.toml"
_W, _K = INKS.index("W"), INKS.index("K")


@dataclass(frozen=True)
class WedgeSlab:
    """One slab: ink, nominal and printed thickness, and its place on the grid (voxels)."""

    ink: str
    nominal_mm: float
    layers: int
    printed_mm: float
    x0: int
    y0: int
    nx: int
    ny: int
    tab_ny: int

    @property
    def label(self) -> str:
        return f"{self.ink} {self.nominal_mm:g} mm"


def plan_wedge(inks: list[str], thicknesses_mm: list[float], printer: PrinterProfile,
               slab_mm: float = SLAB_MM) -> tuple[list[WedgeSlab], tuple[int, int, int]]:
    """Slabs in rows of one ink (columns: thickness) and the job's grid (nx, ny, nz)."""
    if not inks:
        raise DreamPrintError("--inks names no ink")
    for ink in inks:
        if ink not in INKS:
            raise DreamPrintError(f"unknown ink '{ink}'; inks are {', '.join(INKS)}")
    if len(set(inks)) != len(inks):
        raise DreamPrintError("--inks names an ink twice")
    if not thicknesses_mm or any(not (math.isfinite(t) and t > 0) for t in thicknesses_mm):
        raise DreamPrintError("--thickness-mm must be numbers > 0")
    if not slab_mm >= 5.0:
        raise DreamPrintError("--slab-mm must be at least 5 mm (an instrument's aperture)")
    vx, vy, vz = printer.voxel_mm
    printed: dict[int, float] = {}
    for t in thicknesses_mm:
        n = max(1, round(t / vz))
        if n in printed:
            raise DreamPrintError(f"--thickness-mm {printed[n]:g} and {t:g} both print {n} "
                                  f"layer(s), {n * vz:.3f} mm: give distinct thicknesses")
        printed[n] = t
    nxs, nys = round(slab_mm / vx), round(slab_mm / vy)
    tab, gapx, gapy = round(TAB_MM / vy), round(GAP_MM / vx), round(GAP_MM / vy)
    slabs = []
    for r, ink in enumerate(inks):
        for c, t in enumerate(thicknesses_mm):
            layers = max(1, round(t / vz))
            slabs.append(WedgeSlab(ink, float(t), layers, layers * vz, gapx + c * (nxs + gapx),
                                   gapy + r * (nys + tab + gapy), nxs, nys, tab))
    nx = gapx + len(thicknesses_mm) * (nxs + gapx)
    ny = gapy + len(inks) * (nys + tab + gapy)
    nz = max(s.layers for s in slabs)
    check_tray((nx, ny, nz), printer)
    return slabs, (nx, ny, nz)


def _label_mask(text: str, nx: int, ny: int, voxel_mm: tuple[float, float, float]
                ) -> np.ndarray:
    """(ny, nx) bool: the text's glyphs, centred, about 60 % of the tab's depth tall."""
    from PIL import Image, ImageDraw, ImageFont

    px = 0.02  # mm per drawing pixel
    w, h = round(nx * voxel_mm[0] / px), round(ny * voxel_mm[1] / px)
    img = Image.new("L", (w, h), 0)
    draw = ImageDraw.Draw(img)
    font = ImageFont.load_default(size=max(8, round(0.6 * h)))
    box = draw.textbbox((0, 0), text, font=font)
    draw.text(((w - (box[2] - box[0])) / 2 - box[0], (h - (box[3] - box[1])) / 2 - box[1]),
              text, fill=255, font=font)
    a = np.asarray(img)
    cols = ((np.arange(nx) + 0.5) * voxel_mm[0] / px).astype(int)
    rows = ((np.arange(ny) + 0.5) * voxel_mm[1] / px).astype(int)
    # the grid's rows (y) are the slice image's rows: the text reads as the slices show it
    return a[np.ix_(rows, cols)] > 127


def _layer(slabs: list[WedgeSlab], masks: list[np.ndarray], shape: tuple[int, int],
           z: int) -> np.ndarray:
    lab = np.full(shape, EMPTY_LABEL, dtype=np.uint8)
    for s, m in zip(slabs, masks, strict=True):
        if z >= s.layers:
            continue
        lab[s.y0 + s.tab_ny:s.y0 + s.tab_ny + s.ny, s.x0:s.x0 + s.nx] = INKS.index(s.ink)
        lab[s.y0:s.y0 + s.tab_ny, s.x0:s.x0 + s.nx] = np.where(m, _K, _W)
    return lab


def _sheet_rows(slabs: list[WedgeSlab], printer: PrinterProfile) -> list[dict[str, Any]]:
    vx, vy, _ = printer.voxel_mm
    return [{"label": s.label, "ink": s.ink, "nominal_mm": s.nominal_mm, "layers": s.layers,
             "printed_mm": round(s.printed_mm, 4),
             "centre_x_mm": round((s.x0 + s.nx / 2) * vx, 2),
             "centre_y_mm": round((s.y0 + s.tab_ny + s.ny / 2) * vy, 2),
             "size_mm": f"{s.nx * vx:.1f} x {s.ny * vy:.1f}"} for s in slabs]


def _sheet_png(slabs: list[WedgeSlab], printer: PrinterProfile, grid: tuple[int, int, int]
               ) -> bytes:
    """The layout as the slice images show it (4 px per mm): each slab in its material's
    display colour, its label tab above it, its printed thickness and layers."""
    from PIL import Image, ImageDraw, ImageFont

    vx, vy, _ = printer.voxel_mm
    k = 4.0
    W, H = round(grid[0] * vx * k), round(grid[1] * vy * k)
    img = Image.new("RGB", (W, H + 40), (255, 255, 255))
    d = ImageDraw.Draw(img)
    font = ImageFont.load_default(size=14)
    pal = printer.display_palette()
    for s in slabs:
        x0, x1 = s.x0 * vx * k, (s.x0 + s.nx) * vx * k
        ytab = s.y0 * vy * k  # rows as in the slice images: y downwards, the tab above
        ytop = (s.y0 + s.tab_ny) * vy * k
        ybot = (s.y0 + s.tab_ny + s.ny) * vy * k
        d.rectangle([x0, ytop, x1, ybot], fill=tuple(int(v) for v in pal[INKS.index(s.ink)]),
                    outline=(0, 0, 0))
        d.rectangle([x0, ytab, x1, ytop], fill=(255, 255, 255), outline=(0, 0, 0))
        d.text(((x0 + x1) / 2, (ytab + ytop) / 2), s.label, fill=(0, 0, 0), font=font,
               anchor="mm")
        d.text(((x0 + x1) / 2, (ytop + ybot) / 2), f"{s.printed_mm:.3f} mm\n{s.layers} layers",
               fill=(0, 0, 0) if s.ink not in ("K", "C") else (255, 255, 255), font=font,
               anchor="mm", align="center")
    d.text((8, H + 12), f"translucency wedge, {printer.display_name}; laid out as the slice "
           "images show it", fill=(0, 0, 0), font=font)
    buf = io.BytesIO()
    img.save(buf, format="PNG")
    return buf.getvalue()


def _set_template(slabs: list[WedgeSlab]) -> str:
    lines = ["# Calibration set for the translucency wedge (docs/translucency.md).",
             "# Fill in each slab's R and T files (any format `dreamprint spectra` reads),",
             "# uncomment them, then: dreamprint calibrate slabs-template.toml --slabs -o P.json",
             "# thickness_mm is the printed thickness; enter your caliper reading if it differs.",
             'format = "dreamprint-calibration-set"', 'name = "translucency wedge"', ""]
    for s in slabs:
        lines += ["[[layer]]", f'ink = "{s.ink}"', f"thickness_mm = {s.printed_mm:.4f}",
                  f'# R = {{ file = "FILE", sample = "{s.label}" }}',
                  f'# T = {{ file = "FILE", sample = "{s.label}" }}', ""]
    return "\n".join(lines)


def write_wedge(output: str | Path, inks: list[str], thicknesses_mm: list[float],
                printer: PrinterProfile, slab_mm: float = SLAB_MM,
                overwrite: bool = False) -> dict[str, Any]:
    """Write the wedge job into ``output`` (atomically); returns its manifest."""
    started = time.perf_counter()
    slabs, (nx, ny, nz) = plan_wedge(inks, thicknesses_mm, printer, slab_mm)
    masks = [_label_mask(s.label, s.nx, s.tab_ny, printer.voxel_mm) for s in slabs]
    counts = np.zeros(len(INKS) + 1, dtype=np.int64)
    palette = printer.palette()
    with JobWriter(output, overwrite) as w:
        for z in range(nz):
            lab = _layer(slabs, masks, (ny, nx), z)
            counts += np.bincount(lab.ravel(), minlength=counts.size)
            data = encode_labels_pngs(printer.slice_images(lab)[None], palette,
                                      printer.png_mode, printer.pixels_per_metre())[0]
            (w.slices_dir / slice_name(z, nz)).write_bytes(data)
        rows = _sheet_rows(slabs, printer)
        with open(w.tmp / SHEET_CSV, "w", newline="", encoding="utf-8") as f:
            cw = csv.DictWriter(f, fieldnames=list(rows[0]))
            cw.writeheader()
            cw.writerows(rows)
        (w.tmp / SHEET_PNG).write_bytes(_sheet_png(slabs, printer, (nx, ny, nz)))
        (w.tmp / SET_TEMPLATE).write_text(_set_template(slabs), encoding="utf-8")
        manifest = {
            **header(),
            "source": {"path": None, "kind": "translucency wedge", "inks": list(inks),
                       "thickness_mm": list(map(float, thicknesses_mm)), "slab_mm": slab_mm},
            "wedge": {"sheet": SHEET_CSV, "sheet_image": SHEET_PNG,
                      "calibration_set_template": SET_TEMPLATE, "slabs": rows},
            "printer": printer.to_json_dict(),
            **grid_entries(printer, (nx, ny, nz)),
            "seed": 0, "halftoning": {"method": "none: solid slabs, one material each"},
            "slices": slices_entry(printer, (nx, ny, nz)),
            "labels": labels_entry(printer, palette),
            # one material a voxel: a label's concentration sum is its voxel count
            **count_entries(counts, counts, nx * ny * nz),
            "timings_s": {"total": time.perf_counter() - started},
        }
        w.commit(manifest)
    return manifest
