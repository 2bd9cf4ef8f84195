"""``dreamprint predict``, ``calibrate``, ``evaluate density-fit``, ``demo``."""

from __future__ import annotations


