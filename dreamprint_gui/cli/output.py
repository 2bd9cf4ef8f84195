"""What every command's ``--json`` prints: one JSON document, the same way for every command.

Strict JSON (RFC 8259) so that ``jq``, spreadsheets and other languages read it: a figure that
is not finite (NaN where nothing was measured, an infinite thickness) is written ``null``, never
``NaN``/``Infinity`` as Python's ``json`` would; numpy scalars and arrays are written as numbers
and lists.
"""

from __future__ import annotations

import json
import math
from typing import Any

import click
import numpy as np

__all__ = ["emit_json", "strict_json"]


def strict_json(obj: Any) -> Any:
    """``obj`` with numpy values as Python ones and non-finite floats as ``None``."""
    if isinstance(obj, dict):
        return {str(k): strict_json(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [strict_json(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return strict_json(obj.tolist())
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def emit_json(obj: Any) -> None:
    """Print ``obj`` as an indented, strict JSON document on standard output."""
    click.echo(json.dumps(strict_json(obj), indent=2, allow_nan=False))
