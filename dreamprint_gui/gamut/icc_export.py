"""Export the ICC profile of a print: build, check, write (issue 48).

Defines :func:`export_icc`, what ``dreamprint icc`` and the GUI's "Export ICC profile" (gamut
view, calibration wizard) call: the profile of :func:`.icc.build_icc`, read back by LittleCMS
and checked against DreamPrint's prediction (:func:`.icc.check_profile` on
:func:`check_colours`), written atomically, with the CGATS characterisation file
(:mod:`.characterisation`) beside it on request.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.profile import InkProfile
from dreamprint_gui.gamut import lcms
from dreamprint_gui.gamut.characterisation import write_characterisation
from dreamprint_gui.gamut.icc import (
    DEFAULT_A2B_GRID,
    DEFAULT_B2A_GRID,
    DEFAULT_VERSION,
    build_icc,
    check_profile,
    check_target,
    rgb_cube,
    write_atomically,
)
from dreamprint_gui.gamut.print_pcs import PrintPCS
from dreamprint_gui.gamut.tables import ColourTables
from dreamprint_gui.io.volumes.grids.demo import demo_colours

__all__ = ["export_icc", "check_colours", "check_outputs"]


def check_colours() -> NDArray[np.float64]:
    """The 9^3 lattice of the RGB cube and 400 of the colours the demo holds."""
    return np.concatenate([rgb_cube(9), demo_colours(400)])


def check_outputs(path: str | os.PathLike, cgats: str | os.PathLike | None = None) -> None:
    """Refuse output paths that cannot be written, or a characterisation file named as the
    profile, naming the path: before any work (the CLI and the GUI call it before building
    the colour tables, :func:`export_icc` again before the profile's seconds)."""
    if cgats is not None and Path(cgats).absolute() == Path(path).absolute():
        raise DreamPrintError("the characterisation file would overwrite the ICC profile: "
                              "give it another name (e.g. .ti3)", cgats)
    for target in (path, cgats):
        if target is not None:
            check_target(target)


def export_icc(path: str | os.PathLike, profile: InkProfile, tables: ColourTables, *,
               printer: str = "", version: int = DEFAULT_VERSION,
               a2b_grid: int = DEFAULT_A2B_GRID, b2a_grid: int = DEFAULT_B2A_GRID,
               cgats: str | os.PathLike | None = None, patches: int = 9,
               progress: Callable[[str], None] | None = None) -> dict:
    """Build the profile of ``tables``' print, read it back with LittleCMS and check it
    (:func:`check_profile` on :func:`check_colours`), write it to ``path`` (atomically) and,
    with ``cgats``, the characterisation file of a ``patches``^3 RGB lattice; a report."""
    t0 = time.perf_counter()
    check_outputs(path, cgats)
    data = build_icc(profile, tables, printer=printer, version=version, a2b_grid=a2b_grid,
                     b2a_grid=b2a_grid, progress=progress)
    if progress:
        progress("reading the profile back with Little CMS")
    pcs = PrintPCS.for_tables(profile, tables)
    info = lcms.profile_info(data)
    figures = check_profile(data, pcs, check_colours())
    write_atomically(path, data)
    report = {"path": str(path), "bytes": len(data), "icc_version": info["version"],
              "description": info.get("description", ""), "intent": tables.intent,
              "objective": tables.objective, "table_size": tables.size,
              "a2b_grid": a2b_grid, "b2a_grid": b2a_grid,
              "media_white_XYZ_D50": [float(v) for v in pcs.media_white],
              "littlecms_version": lcms.library().cmsGetEncodedCMMversion(),
              "check": figures, "seconds": time.perf_counter() - t0}
    if cgats is not None:
        layout = write_characterisation(cgats, pcs, profile, patches, info.get("description",
                                                                               ""))
        report["cgats"] = {"path": str(cgats), "layout": layout, "patches": patches ** 3}
    return report
