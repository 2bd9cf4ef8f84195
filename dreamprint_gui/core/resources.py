"""Where the shipped data (``resources/`` at the top of the source tree) is found.

A source checkout or editable install reads it in place; a PyInstaller bundle carries it as
``resources/`` beside the executable's modules (``packaging/dreamprint.spec``); a system install
may place it in ``<prefix>/share/dreamprint/resources``. ``DREAMPRINT_RESOURCES`` overrides.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from dreamprint_gui.core.errors import DreamPrintError

__all__ = ["resource_path"]


def _candidates() -> list[Path]:
    here = Path(__file__).resolve().parent
    out = []
    if os.environ.get("DREAMPRINT_RESOURCES"):
        out.append(Path(os.environ["DREAMPRINT_RESOURCES"]))
    out.append(here.parents[1] / "resources")
    if hasattr(sys, "_MEIPASS"):
        out.append(Path(sys._MEIPASS) / "resources")
    out.append(Path(sys.prefix) / "share" / "dreamprint" / "resources")
    return out


def resource_path(*parts: str) -> Path:
    """Path of a shipped resource, e.g. ``resource_path("profiles", "polyjet_default.json")``."""
    for root in _candidates():
        p = root.joinpath(*parts)
        if p.exists():
            return p
    raise DreamPrintError("DreamPrint's resources are missing (reinstall, or set "
                          "DREAMPRINT_RESOURCES)", "/".join(parts))
