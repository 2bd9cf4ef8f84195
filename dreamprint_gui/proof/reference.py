"""The proof's reference: the source as the job's rendering intent maps it.

Defines :func:`job_intent` (the intent a proof's labels were made under) and
:func:`intent_reference` (the source field with each cell's colour replaced by the colour the
intent asks the print for).

A job does not try to print the source's colours but the intent's targets: the colour tables
are solved for ``intent_map(model, intent).map_xyz(XYZ(rgb))``
(:func:`dreamprint_gui.gamut.tables.build_tables`; :mod:`dreamprint_gui.gamut.mapping`). The
proof judges the print against the same targets, with the same map (one place), applied per
cell of the sampled source before its emission-absorption render (:mod:`.source_render`):

    c_ref = M_rgb . map_xyz(M_rgb^-1 . c)       c linear sRGB, M_rgb the model's XYZ -> sRGB

- ``colorimetric``: the identity, the judge as it always was (the field is returned as is);
- ``relative`` (ICC media-relative colorimetric): a von Kries (Bradford) adaptation taking
  the source white to the printable white, so a white smoke is judged against the white its
  inks can print, not against the environment's white, which no ink reaches;
- ``perceptual``: the SGCK compression into the printable gamut the tables use.

The environment (the white background every pixel is composited over) is not the source's
colour and stays white: only the object's colours are mapped. Only cells with density are
mapped (the others are never seen: colour is premultiplied by density in the render).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from dreamprint_gui.gamut.forward import forward_model
from dreamprint_gui.gamut.mapping import canonical_intent, intent_map
from dreamprint_gui.proof.source_render import SourceField

__all__ = ["job_intent", "intent_reference"]


def job_intent(lab: Any) -> str:
    """The rendering intent of a proof's labels: the job's tables' (the engine's labels), the
    manifest's (an exported job; ``colorimetric`` when it records none, as before intents)."""
    tables = getattr(getattr(lab, "ctx", None), "tables", None)
    if tables is not None:
        return canonical_intent(getattr(tables, "intent", None))
    manifest = getattr(lab, "manifest", None) or {}
    return canonical_intent((manifest.get("profile") or {}).get("intent"))


def intent_reference(field: SourceField, intent: str | None, profile: Any) -> SourceField:
    """``field`` with its colours as the ``intent`` reproduces them (module docstring) for
    the ink ``profile`` (the one the job's tables were built from); the same object for
    ``colorimetric``."""
    intent = canonical_intent(intent)
    if intent == "colorimetric":
        return field
    model = forward_model(profile)
    imap = intent_map(model, intent)
    to_rgb = np.asarray(model.xyz_to_rgb, np.float64)
    kept = field.sigma > 0
    lin = np.asarray(field.colour[kept], np.float64)
    mapped = imap.map_xyz(lin @ np.linalg.inv(to_rgb).T) @ to_rgb.T
    colour = np.array(field.colour, np.float32)
    colour[kept] = np.clip(mapped, 0.0, None)
    return replace(field, colour=np.ascontiguousarray(colour))
