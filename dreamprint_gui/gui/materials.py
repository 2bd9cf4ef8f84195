"""Display colours of material labels: exactly the slice PNGs' colour codes.

Defines :func:`label_colours`: labels 0..5 are the inks in ``INKS`` order (C, M, Y, K, W, Cl),
label 6 an empty voxel (``printer.EMPTY_LABEL``), each in the RGB code the job's slices write
for it (``printer.material_legend``, the one definition the PNG writer reads too), so the layer
view and its legend look like the files the printer receives.
"""

from __future__ import annotations

import numpy as np

__all__ = ["label_colours"]


def label_colours(printer=None) -> tuple[np.ndarray, list[str]]:
    """(7, 3) uint8 colours of labels 0..6 as the slices encode them, and their names
    ("C (VeroCyan-V)", ..., "empty (no material)")."""
    from dreamprint_gui.core.printer import material_legend

    legend = material_legend(printer)
    colours = np.array([rgb for _, _, rgb in legend], dtype=np.uint8)
    names = [name if lab == "empty" else f"{lab} ({name})" for lab, name, _ in legend]
    return colours, names
