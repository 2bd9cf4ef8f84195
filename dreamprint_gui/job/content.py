"""Material intent of a source: a fog (density as the source states it) or a solid.

Defines
-------
- :data:`CONTENT_MODES` (``fog``, ``solid``, ``auto``) and :data:`SOLID_SIGMA`, the density
  target that means "solid" to density alignment.
- :class:`ContentChoice`: the mode used, whether ``auto`` picked it, and why.
- :func:`choose_content`: what ``auto`` picks for an open source (solid for voxel models,
  level sets and binary masks; fog for everything else: smoke, clouds, radiance fields, splats).
- :class:`SolidSource`: a source wrapper that makes occupied voxels solid and the rest empty.
- :func:`apply_content`: the source a job samples, and the choice, for a requested mode.
- :func:`solid_depth_mm`: the depth at which a solid of the least-absorbing printed colour
  transmits less than a given fraction (the stated opacity of ``solid``).

The rule of ``solid`` (docs/physics.md, "Solid content"): a voxel is *occupied* where the
source's own density reaches half its solid value (a .vox voxel's solid density, a level set's
zero crossing, the midpoint of a binary mask's two values), or, for a source without a solid
value (a fog forced to ``solid``), where its density reaches the job's background threshold.
An occupied voxel gets the target :data:`SOLID_SIGMA`, which density alignment
(:func:`.gamut.alignment.align_rows`, eq. 12) reads as "the colour's own undiluted mixture":
``rho = 1``, no Clear and no grey, the densest the colour can be printed without changing it.
Empty voxels get density 0 and become Clear or nothing (``--background``). The colour is the
source's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.gamut.alignment import SOLID_TARGET

__all__ = ["CONTENT_MODES", "SOLID_SIGMA", "ContentChoice", "choose_content", "SolidSource",
           "apply_content", "solid_depth_mm", "is_binary_mask", "content_of_info"]

CONTENT_MODES = ("fog", "solid", "auto")
# The target density (1/mm) that means "solid" to density alignment (no medium is this dense:
# the densest printable mixture is ~40/mm).
SOLID_SIGMA = np.float32(SOLID_TARGET)


@dataclass(frozen=True)
class ContentChoice:
    """``mode`` (fog or solid) used for a job; ``requested`` (fog, solid or auto); ``reason``."""

    mode: str
    requested: str
    reason: str

    @property
    def picked(self) -> bool:
        return self.requested == "auto"

    def describe(self) -> str:
        how = "auto: " if self.picked else ""
        return f"{self.mode} ({how}{self.reason})"

    def to_json(self) -> dict[str, Any]:
        return {"mode": self.mode, "requested": self.requested, "reason": self.reason}


def is_binary_mask(source) -> tuple[float, float] | None:
    """The two values of a scalar dense image that holds exactly two (a mask), else None.

    Read in chunks of layers (no copy of the grid); stops at the first layer with a third value.
    """
    vol = getattr(source, "volume", None)
    if vol is None or getattr(source, "window", None) is None:
        return None
    data = vol.data
    if data.ndim != 4 or data.shape[3] != 1 or data.size == 0:
        return None
    a = float(data[0, 0, 0, 0])
    b = None
    for z in range(data.shape[0]):
        layer = data[z, ..., 0]
        other = layer[layer != a]
        if other.size == 0:
            continue
        if b is None:
            b = float(other.flat[0])
        if np.any(other != b):
            return None
    if b is None or not (math.isfinite(a) and math.isfinite(b)):
        return None
    return (min(a, b), max(a, b))


def _solid_level(source) -> float | None:
    """The source density (1/source unit, density scale 1) at which a voxel is occupied."""
    if getattr(source, "format", "") == "MagicaVoxel":
        return 0.5 * float(source.solid_density)
    if getattr(source, "is_level_set", False):
        return 0.5 * float(source.solid_density)
    two = is_binary_mask(source)
    if two is not None:
        lo, hi = source.window
        t = [min(max((v - lo) / (hi - lo), 0.0), 1.0) for v in two]
        return 0.5 * (t[0] + t[1]) * float(source.density)
    return None


def choose_content(source) -> tuple[str, str]:
    """(mode, reason) that ``auto`` picks for ``source``."""
    fmt = str(getattr(source, "format", ""))
    if fmt == "MagicaVoxel":
        return "solid", "a voxel model (.vox)"
    if getattr(source, "is_level_set", False):
        return "solid", "a level set"
    two = is_binary_mask(source)
    if two is not None:
        return "solid", f"a binary mask (only the values {two[0]:g} and {two[1]:g})"
    kind = {"OpenVDB": "a fog volume", "NanoVDB": "a fog volume"}.get(fmt)
    if kind is None:
        low = fmt.lower()
        if "splat" in low or "gaussian" in low or hasattr(source, "n_total"):
            kind = "Gaussian splats"
        elif "radiance" in low:
            kind = "a radiance field"
        elif "instantngp" in low:  # snapshots and the exported RGBA volumes / PNG slices
            kind = "a radiance field (InstantNGP)"
        elif "demo" in low or "procedural" in low:
            kind = "the demo (densities made for printing as a fog)"
        else:
            kind = "a scalar volume (more than two values)"
    return "fog", kind


def content_of_info(info: dict) -> tuple[str, str]:
    """(mode, reason) ``auto`` picks for a sparse file described by its ``inspect`` info alone
    (OpenVDB, NanoVDB): the grid a job would read (``density``, else the only fog volume, else
    a level set) decides."""
    grids = info.get("grids", [])
    by_name = {g.get("name"): g for g in grids}
    g = by_name.get("density")
    if g is None:
        fog = [x for x in grids if x.get("class") == "fog volume"]
        ls = [x for x in grids if x.get("class") == "level set"]
        g = fog[0] if fog else (ls[0] if ls else None)
    if g is not None and g.get("class") == "level set":
        return "solid", f"a level set (grid {g.get('name')!r})"
    if g is not None:
        return "fog", "a fog volume"
    return "fog", "not a voxel model, level set or binary mask"


class SolidSource:
    """``inner`` with occupied voxels at :data:`SOLID_SIGMA` and the rest at 0 (module doc).

    ``level``: the inner source's occupied density (1/source unit at density scale 1), or None
    to use ``threshold`` (1/mm, after the density scale) instead. Offers no ``layer_plan``: the
    job takes the general path (sample the slab, then label it).
    """

    layer_plan = None  # never the inner source's fused dense path: it would skip the rule

    def __init__(self, inner, level: float | None, threshold: float) -> None:
        self.inner = inner
        self.level = level
        self.threshold = float(threshold)
        self.name = inner.name
        self.format = inner.format
        self.bounds = inner.bounds
        self.colour_encoding = inner.colour_encoding

    def __getattr__(self, name: str):  # reader attributes (solid_density, volume, ...)
        if name == "inner":
            raise AttributeError(name)
        return getattr(self.inner, name)

    def sample_slab(self, grid, z0: int, z1: int, *, density_scale: float = 1.0, out=None):
        if self.level is not None:
            cut = np.float32(self.level / grid.mm_per_unit)
            scale = 1.0
        else:
            cut = np.float32(self.threshold)
            scale = density_scale
        # the job reads the colour of the occupied voxels (inner density >= cut): the inner
        # source may skip colour below the cut, not below the job's own threshold
        keep = getattr(out, "colour_threshold", None)
        if keep is not None:
            out.colour_threshold = np.float32(max(cut, 0.0))
        try:
            rgb, sigma = self.inner.sample_slab(grid, z0, z1, density_scale=scale, out=out)
        finally:
            if keep is not None:
                out.colour_threshold = keep
        occupied = sigma >= cut
        if cut <= 0:
            occupied &= sigma > 0
        sigma = np.asarray(sigma)
        if not sigma.flags.writeable:
            sigma = sigma.copy()
        np.copyto(sigma, np.where(occupied, SOLID_SIGMA, np.float32(0.0)))
        return rgb, sigma

    def info(self) -> dict:
        return self.inner.info()


def apply_content(source, content: str, threshold: float) -> tuple[Any, ContentChoice]:
    """The source to sample for ``content`` (fog, solid or auto) and the choice made.

    ``threshold``: the job's background threshold (1/mm), the occupancy rule of a source
    without a solid value."""
    if content not in CONTENT_MODES:
        raise DreamPrintError(f"--content must be fog, solid or auto, not '{content}'")
    auto_mode, reason = choose_content(source)
    if content == "auto":
        mode = auto_mode
    else:
        mode = content
        reason = f"as asked; auto would pick {auto_mode}: {reason}"
    choice = ContentChoice(mode, content, reason)
    if mode == "fog":
        return source, choice
    return SolidSource(source, _solid_level(source), threshold), choice


def solid_depth_mm(tables, transmittance: float = 0.01) -> dict[str, float]:
    """How opaque ``solid`` is: the undiluted densities of the table's printable colours and the
    depth (mm) at which each transmits ``transmittance`` (Beer-Lambert, ``d = -ln T / sigma``).

    Returns ``sigma_min`` / ``sigma_max`` (1/mm, the least- and most-absorbing printed colour),
    ``depth_mm_least`` / ``depth_mm_most`` and ``transmittance``."""
    s = np.asarray(tables.sigma, np.float64)
    lo, hi = float(s.min()), float(s.max())
    ln = -math.log(transmittance)
    return {"transmittance": transmittance, "sigma_min": lo, "sigma_max": hi,
            "depth_mm_least": ln / lo, "depth_mm_most": ln / hi}
