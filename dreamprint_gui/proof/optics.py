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
"phase": ...}``, the model its K and S were fitted through), else the defaults: no surface and
isotropic scattering, the model of the built-in profile (its K and S are KM fits of measured
reflectance that already include the surface; a surface on top would count it twice, see
docs/physics.md "Calibration and proof share one optical model").
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.proof.km_to_rte import parse_phase, phase_name

__all__ = ["Optics", "resolve_optics", "SURFACES", "DEFAULT_IOR", "DEFAULT_ROUGHNESS"]

SURFACES = ("none", "glossy", "matte")
DEFAULT_IOR = 1.5
DEFAULT_ROUGHNESS = 0.1


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
