"""Display colours of material labels: the slice PNGs' colour codes, mapped for legibility.

Defines :func:`label_colours`: labels 0..5 are the inks in ``INKS`` order (C, M, Y, K, W, Cl),
label 6 an empty voxel (``printer.EMPTY_LABEL``), each in the colour the printer file shows it
in on screen (``printer.material_legend(display=True)``: a material's ``display_rgb``, else its
code). The slices carry the codes (VeroClear 227, 233, 253, the Voxel Print legend's); the
screen shows Clear light steel blue (150, 190, 225), which a reader can tell from White.
"""

from __future__ import annotations

import numpy as np

__all__ = ["label_colours"]


def label_colours(printer=None) -> tuple[np.ndarray, list[str]]:
    """(7, 3) uint8 colours of labels 0..6 as the screen shows them (display colours, see the
    module doc), and their names ("C (VeroCyan-V)", ..., "empty (no material)")."""
    from dreamprint_gui.core.printer import material_legend

    legend = material_legend(printer, display=True)
    colours = np.array([rgb for _, _, rgb in legend], dtype=np.uint8)
    names = [name if lab == "empty" else f"{lab} ({name})" for lab, name, _ in legend]
    return colours, names
