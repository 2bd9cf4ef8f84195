"""The print's optics in the proof: its surface (a dielectric boundary) and phase function.

Defines :class:`Optics`, :func:`resolve_optics`, :data:`SURFACES` and the defaults.

- ``surface``: ``none`` (index-matched: the light enters and leaves the medium unrefracted, the
  model the built-in K and S were fitted in, :mod:`.km_to_rte`), ``glossy`` (a smooth
  dielectric of refractive index n: Fresnel reflection, refraction, total internal reflection)
  or ``matte`` (a rough dielectric, GGX microfacets of roughness alpha; Walter et al. 2007).
  The boundary is the print's bounding box: the block of Clear resin a ``clear`` background
  prints (with ``--background empty`` the print has no box, and a surface is refused).
- ``phase``: isotropic, or Henyey-Greenstein of asymmetry g with the reduced scattering
  coefficient kept (:func:`.km_to_rte.rte_coefficients`).

Where the settings come from: the command line (``--surface``, ``--phase``), else the ink
profile's ``proof`` section (``{"surface": ..., "refractive_index": ..., "roughness": ...,
"phase": ...}``), else the defaults: no surface and isotropic scattering. The K -> RTE
conversion (:mod:`.km_to_rte`) keeps every thick patch's reading at KM's R_inf through whatever
optics is chosen, so a surface does not count the K and S's surface twice; the defaults are what
the chart proof measured best (docs/physics.md, "Chart proof on a real chart": with a surface at
d:8, the surface's own 0.04 reflection keeps dark patches from reading as dark as measured).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from dreamprint_gui.core.errors import DreamPrintError

__all__ = ["Optics", "resolve_optics", "SURFACES", "DEFAULT_IOR", "DEFAULT_ROUGHNESS",
           "parse_phase", "phase_name", "MAX_ABS_G"]

MAX_ABS_G = 0.95

SURFACES = ("none", "glossy", "matte")
DEFAULT_IOR = 1.5
DEFAULT_ROUGHNESS = 0.1


def parse_phase(text: str) -> float:
    """The asymmetry g of ``isotropic`` (0) or ``hg:G`` (``|G| <= MAX_ABS_G``); ValueError with
    a one-line message otherwise."""
    t = str(text).strip().lower()
    if t == "isotropic":
        return 0.0
    if t.startswith("hg:"):
        try:
            g = float(t[3:])
        except ValueError:
            g = math.nan
        if math.isfinite(g) and abs(g) <= MAX_ABS_G:
            return g
        raise ValueError(f"phase '{text}': G of hg:G must be a number in "
                         f"[-{MAX_ABS_G}, {MAX_ABS_G}]")
    raise ValueError(f"unknown phase function '{text}' (use isotropic or hg:G, e.g. hg:0.4)")


def phase_name(g: float) -> str:
    return "isotropic" if g == 0 else f"hg:{g:g}"


@dataclass(frozen=True)
class Optics:
    surface: str = "none"
    ior: float = DEFAULT_IOR
    roughness: float = DEFAULT_ROUGHNESS
    g: float = 0.0

    def bsdf(self) -> dict | None:
        """Mitsuba BSDF of the print's boundary (None: index-matched, no boundary)."""
        if self.surface == "glossy":
            return {"type": "dielectric", "int_ior": float(self.ior), "ext_ior": 1.0}
        if self.surface == "matte":
            return {"type": "roughdielectric", "distribution": "ggx",
                    "alpha": float(self.roughness), "int_ior": float(self.ior), "ext_ior": 1.0}
        return None

    def describe(self) -> dict[str, Any]:
        d: dict[str, Any] = {"surface": self.surface, "phase": phase_name(self.g)}
        if self.surface != "none":
            d["refractive_index"] = self.ior
        if self.surface == "matte":
            d["roughness"] = {"alpha": self.roughness, "distribution": "GGX"}
        return d


def resolve_optics(surface: str | None, phase: str | None,
                   profile_section: dict[str, Any] | None = None) -> Optics:
    """The proof's optics: ``surface``/``phase`` if given, else the profile's, else defaults."""
    sec = dict(profile_section or {})
    surf = surface if surface is not None else sec.get("surface", "none")
    if surf not in SURFACES:
        raise DreamPrintError(f"unknown surface '{surf}' (use {', '.join(SURFACES)})")
    try:
        g = parse_phase(phase if phase is not None else sec.get("phase", "isotropic"))
    except ValueError as exc:
        raise DreamPrintError(str(exc)) from None
    ior = float(sec.get("refractive_index", DEFAULT_IOR))
    rough = float(sec.get("roughness", DEFAULT_ROUGHNESS))
    return Optics(surf, ior, rough, g)
