"""How a level set (OpenVDB, NanoVDB) becomes density: one rule for every reader.

A level set holds a signed distance phi (negative inside, in source units) in a narrow band
around its surface; outside the band it reads +/- the grid's background. It is not a density:
a reader refuses it unless asked for one of two readings (``level_set=`` option):

- ``solid``: the inside, antialiased over one voxel of the file, ``rho = clip(1/2 - u, 0, 1)``
  with ``u = phi / voxel``;
- ``shell``: the wall of that solid ``w`` of the file's voxels thick (a hollow object),
  ``rho = clip(1/2 - u, 0, 1) * clip(1/2 + u + w, 0, 1)``; the wall must lie within the band
  (deeper inside phi is only known to be below -background), so ``w <= band - 1``.

Either is multiplied by ``solid_density`` (density per source unit). :data:`LEVEL_SET_ADVICE`
is the advice of every "is a level set" message, in the command line's words (the GUI names
its own controls instead: ``gui.names.gui_wording``).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dreamprint_gui.core.errors import DreamPrintError

__all__ = ["LEVEL_SET_MODES", "LEVEL_SET_ADVICE", "GRID_ADVICE", "level_set_density",
           "check_level_set_options", "check_shell"]

# refused (a reader's default; a job's content solid or auto asks for solid), solid, shell
LEVEL_SET_MODES = ("refuse", "solid", "shell")
LEVEL_SET_ADVICE = ("open it as a solid (--option level_set=solid) or as a hollow shell "
                    "(--option level_set=shell), or convert it to a fog volume")
GRID_ADVICE = "--option grid=NAME"


def check_level_set_options(level_set: str, shell_voxels: float, path) -> None:
    """Refuse an unknown ``level_set`` mode or a shell that is not > 0 voxels thick."""
    if level_set not in LEVEL_SET_MODES:
        raise DreamPrintError(f"level_set must be one of {', '.join(LEVEL_SET_MODES)}, got "
                              f"{level_set!r}", path)
    if isinstance(shell_voxels, bool) or not (isinstance(shell_voxels, int | float)
                                              and shell_voxels > 0):
        raise DreamPrintError(f"shell_voxels must be a number > 0, got {shell_voxels!r}", path)


def check_shell(level_set: str, shell_voxels: float, band: float, voxel: float, grid: str,
                path) -> None:
    """Refuse a shell thicker than the narrow band (``band`` = |background|, source units)."""
    inside = band / voxel
    if level_set == "shell" and shell_voxels > inside - 1.0:
        raise DreamPrintError(f"a shell of {shell_voxels:g} voxels is thicker than grid "
                              f"{grid!r} knows (its narrow band reaches {inside:g} voxels "
                              f"inside; shell_voxels at most {max(inside - 1.0, 0.0):g})", path)


def level_set_density(phi: NDArray, voxel: float, solid_density: float, mode: str,
                      shell_voxels: float) -> NDArray[np.float32]:
    """Density per source unit of signed distances ``phi`` read as ``mode`` (solid, shell)."""
    u = np.asarray(phi, np.float32) / np.float32(voxel)
    d = np.float32(solid_density) * np.clip(0.5 - u, 0.0, 1.0)
    if mode == "shell":
        d *= np.clip(0.5 + u + np.float32(shell_voxels), 0.0, 1.0)
    return d.astype(np.float32, copy=False)
