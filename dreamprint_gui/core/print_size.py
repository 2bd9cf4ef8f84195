"""The one rule for a print's size: exactly one of ``--height-mm`` and ``--size-mm``.

Defines :func:`check_print_size`, called by the job's settings check, the grid layout
(:func:`..io.volumes.base.grid_for_source`), ``inspect`` (where a size is optional) and, through
the job, the proof and the compensation.
"""

from __future__ import annotations

import math
from typing import Any

from dreamprint_gui.core.errors import DreamPrintError

__all__ = ["check_print_size", "DEMO_HEIGHT_MM"]

DEMO_HEIGHT_MM = 40.0
"""The built-in demo's design height (its densities are set for it): what it prints at when no
size is given, and the GUI's default height."""


def check_print_size(height_mm: float | None, size_mm: Any, required: bool = True) -> None:
    """Refuse (one line) a size that is not exactly one of ``height_mm`` and ``size_mm``
    (``required=False``: at most one), or a height or box that is not positive and finite."""
    if height_mm is not None and size_mm is not None:
        raise DreamPrintError("give exactly one of --height-mm and --size-mm" if required else
                              "give at most one of --height-mm and --size-mm")
    if required and height_mm is None and size_mm is None:
        raise DreamPrintError("give exactly one of --height-mm and --size-mm")
    if height_mm is not None and not (math.isfinite(float(height_mm)) and height_mm > 0):
        raise DreamPrintError(f"--height-mm must be a positive number of mm, got {height_mm}")
    if size_mm is not None:
        try:
            box = [float(v) for v in size_mm]
        except (TypeError, ValueError):
            box = []
        if len(box) != 3 or not all(math.isfinite(v) and v > 0 for v in box):
            raise DreamPrintError(f"--size-mm must be three positive numbers of mm, got "
                                  f"{size_mm}")
