"""The entries every job folder's ``manifest.json`` has, whatever wrote the job.

A conversion (:mod:`.run`) and a translucency wedge (:mod:`.wedge`) write the same header, grid,
slice-file and label entries, so that ``evaluate job``, ``--resume`` and GrabCAD's operator read
either the same way; they are written here once. Each writer adds what is its own (the source,
the profile, the halftoning, the wedge's sheet).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from dreamprint_gui import __version__
from dreamprint_gui.core.printer import PrinterProfile
from dreamprint_gui.core.profile import INKS
from dreamprint_gui.job.write import slice_name

__all__ = ["LABELS", "FORMAT", "FORMAT_VERSION", "software", "header", "grid_entries",
           "slices_entry", "labels_entry", "count_entries"]

FORMAT = "dreamprint-job"
FORMAT_VERSION = 1
LABELS = (*INKS, "empty")  # the label of each value a slice's voxel may hold, in code order


def software() -> dict[str, str]:
    """Which program wrote the job."""
    return {"name": "dreamprint", "version": __version__}


def header() -> dict[str, Any]:
    """``format``, ``format_version``, ``software`` and ``created`` (local time, ISO 8601)."""
    return {"format": FORMAT, "format_version": FORMAT_VERSION, "software": software(),
            "created": time.strftime("%Y-%m-%dT%H:%M:%S%z")}


def grid_entries(printer: PrinterProfile, shape_xyz: Sequence[int]) -> dict[str, Any]:
    """The job's size: ``physical_size_mm``, ``voxel_mm`` and ``grid_dimensions`` (x, y, z)."""
    nx, ny, nz = (int(n) for n in shape_xyz)
    vx, vy, vz = printer.voxel_mm
    return {"physical_size_mm": [nx * vx, ny * vy, nz * vz], "voxel_mm": list(printer.voxel_mm),
            "grid_dimensions": [nx, ny, nz]}


def slices_entry(printer: PrinterProfile, shape_xyz: Sequence[int]) -> dict[str, Any]:
    """The slice files: folder, count, image size in the printer's orientation, first and
    last names and PNG mode."""
    nx, ny, nz = (int(n) for n in shape_xyz)
    x_columns = printer.image_columns == "x"
    return {"folder": "slices", "count": nz, "width": nx if x_columns else ny,
            "height": ny if x_columns else nx, "first": "slices/" + slice_name(0, nz),
            "last": "slices/" + slice_name(nz - 1, nz), "png_mode": printer.png_mode}


def labels_entry(printer: PrinterProfile, palette: np.ndarray) -> dict[str, Any]:
    """Each label's printer material (``none`` for empty) and its colour in the slices."""
    return {lab: {"material": printer.material_names[i] if i < len(INKS) else "none",
                  "rgb": palette[i].tolist()} for i, lab in enumerate(LABELS)}


def count_entries(counts: Sequence[int], concentration_sums: Sequence[float], n: int
                  ) -> dict[str, Any]:
    """``voxel_counts`` per label, ``mean_concentration`` (each label's concentration summed
    over the job's ``n`` voxels, divided by ``n``) and ``total_voxels`` (``n``)."""
    return {"voxel_counts": {lab: int(counts[i]) for i, lab in enumerate(LABELS)},
            "mean_concentration": {lab: float(concentration_sums[i]) / n
                                   for i, lab in enumerate(LABELS)},
            "total_voxels": n}
