"""Printable gamut: RGB -> ink concentration tables, density alignment, gamut evaluation.

Modules: :mod:`.forward` (compiled colour model), :mod:`.optimise` (eq. 10 solver),
:mod:`.grey` (eq. 11 brightness table), :mod:`.tables` (the 100^3 table and its cache),
:mod:`.alignment` (section 4.1 density alignment), :mod:`.evaluation` (gamut figures),
:mod:`.charts` (Fig. 7 hexagon chart, CIELAB gamut plot).
"""

from dreamprint_gui.gamut.alignment import (
    AlignCounts,
    Alignment,
    align_density,
    lookup_and_align_into,
    predicted_appearance,
)
from dreamprint_gui.gamut.tables import (
    DEFAULT_OBJECTIVE,
    ColourTables,
    build_tables,
    get_tables,
    lookup,
)

__all__ = ["ColourTables", "get_tables", "build_tables", "lookup", "align_density", "Alignment",
           "AlignCounts", "lookup_and_align_into", "predicted_appearance", "DEFAULT_OBJECTIVE"]
