"""The paper's ablations as label-producing methods (its Fig. "ablation study" as numbers).

Defines :data:`METHODS` and :func:`method_labels`.

- ``paper``: the product's pipeline (table lookup + density alignment + halftoning), i.e.
  exactly ``dreamprint convert`` (:class:`.labels.EngineLabels`).
"""

from __future__ import annotations

from typing import Any

__all__ = ["METHODS", "method_labels"]

METHODS = ("paper",)


def _convert_settings(s: Any):
    from ..pipeline import ConvertSettings

    return ConvertSettings(source=s.source, output=None, profile=s.profile, printer=s.printer,
                           height_mm=s.height_mm, size_mm=s.size_mm,
                           density_scale=s.density_scale, halftone=s.halftone, seed=s.seed,
                           background=s.background,
                           table_size=s.table_size, source_options=dict(s.source_options))


def method_labels(s: Any):
    """The label source of ``s.method`` for proof settings ``s``."""
    from .labels import EngineLabels

    cs = _convert_settings(s)
    if s.method == "paper":
        return EngineLabels(cs)
    raise ValueError(f"unknown method {s.method!r}")
