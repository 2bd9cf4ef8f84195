"""Figures of merit of a printable gamut and of its table (issue 5's ``dreamprint gamut``).

Defines
-------
- :data:`IN_GAMUT_DE2000`: a colour is called in gamut when its best printable reproduction is
  within dE2000 1.0 (about one just-noticeable difference).
- :func:`lut_vs_direct`: dE2000 between the colour reproduced from the table (trilinear lookup)
  and from a direct optimisation (eq. 10 solved for that colour alone, from the centre of the
  simplex) at random in-gamut colours.
- :func:`printable_lab`: CIELAB of a lattice over the five-ink simplex (the printable gamut).
- :func:`lab_volume`: convex-hull volume (dE^3) of CIELAB points (an upper bound of a
  non-convex gamut's volume).
- :func:`srgb_lab`: CIELAB of the sRGB cube's surface (for comparison).
- :func:`evaluate`: the JSON report.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from numpy.typing import NDArray

from ..colorimetry import delta_E2000
from ..profile import InkProfile
from .forward import N_COLOUR_INKS, forward_model, mixtures_lab
from .optimise import solve, targets_for
from .tables import ColourTables, lookup

__all__ = ["IN_GAMUT_DE2000", "lut_vs_direct", "printable_lab", "lab_volume", "srgb_lab",
           "evaluate"]

IN_GAMUT_DE2000 = 1.0


def _stats(x: NDArray) -> dict:
    if x.size == 0:
        return {"mean": None, "p95": None, "max": None, "count": 0}
    return {"mean": float(x.mean()), "p95": float(np.percentile(x, 95)),
            "max": float(x.max()), "count": int(x.size)}


def lut_vs_direct(tables: ColourTables, profile: InkProfile, samples: int = 2000,
                  seed: int = 0) -> tuple[NDArray, NDArray]:
    """(dE2000 LUT vs direct at the in-gamut samples, dE2000 of direct to target at all)."""
    model = forward_model(profile)
    rgb = np.random.default_rng(seed).random((samples, 3))
    direct, _, _ = solve(model, tables.objective, rgb, np.full(N_COLOUR_INKS, 0.2), max_iter=300)
    lab_direct = mixtures_lab(model, direct)
    lab_lut = mixtures_lab(model, lookup(tables, rgb))
    de_target = delta_E2000(lab_direct, targets_for(model, "lab", rgb))
    inside = de_target <= IN_GAMUT_DE2000
    return delta_E2000(lab_lut, lab_direct)[inside], de_target


def printable_lab(profile: InkProfile, steps: int = 24) -> NDArray[np.float64]:
    """CIELAB of all five-ink mixtures with concentrations in multiples of 1/steps."""
    combos = [c for c in itertools.product(range(steps + 1), repeat=N_COLOUR_INKS - 1)
              if sum(c) <= steps]
    a = np.asarray(combos, dtype=np.float64)
    conc = np.concatenate([a, steps - a.sum(axis=1, keepdims=True)], axis=1) / steps
    return mixtures_lab(forward_model(profile), conc)


def srgb_lab(profile: InkProfile, steps: int = 33) -> NDArray[np.float64]:
    """CIELAB of the sRGB cube's six faces (steps x steps each)."""
    a = np.linspace(0.0, 1.0, steps)
    u, v = (x.ravel() for x in np.meshgrid(a, a))
    faces = []
    for axis in range(3):
        for value in (0.0, 1.0):
            f = np.empty((u.size, 3))
            others = [i for i in range(3) if i != axis]
            f[:, axis] = value
            f[:, others[0]] = u
            f[:, others[1]] = v
            faces.append(f)
    return targets_for(forward_model(profile), "lab", np.concatenate(faces))


def lab_volume(lab: NDArray) -> float:
    from scipy.spatial import ConvexHull

    return float(ConvexHull(lab).volume)


def evaluate(tables: ColourTables, profile: InkProfile, samples: int = 2000) -> dict:
    """The report printed by ``dreamprint gamut --json``."""
    de_nodes = np.asarray(tables.dE2000, dtype=np.float64).ravel()
    lut, _ = lut_vs_direct(tables, profile, samples)
    out = de_nodes[de_nodes > IN_GAMUT_DE2000]
    ct = tables.colour_thickness_mm
    return {
        "lut_size": tables.size,
        "objective": tables.objective,
        # this run: loaded from the cache (cached, load_seconds) or built (build_seconds)
        "cached": tables.cached,
        "seconds": round(tables.load_seconds if tables.cached else tables.build_seconds, 3),
        "load_seconds": round(tables.load_seconds, 3) if tables.cached else None,
        "build_seconds": None if tables.cached else round(tables.build_seconds, 3),
        "built_seconds_when_cached": round(tables.build_seconds, 3) if tables.cached else None,
        "colour_thickness_mm": None if math.isinf(ct) else ct,
        "srgb_in_gamut_fraction": float(np.mean(de_nodes <= IN_GAMUT_DE2000)),
        "in_gamut_threshold_dE2000": IN_GAMUT_DE2000,
        "node_dE2000_mean": float(de_nodes.mean()),
        "lab_gamut_volume": lab_volume(printable_lab(profile)),
        "srgb_lab_volume": lab_volume(srgb_lab(profile)),
        "lab_volume_method": "convex hull in CIELAB (dE^3)",
        "lut_vs_direct_dE2000": _stats(lut),
        "out_of_gamut_dE2000": _stats(out),
        "out_of_gamut_policy": "minimum of the objective over printable mixtures "
                               + ("(minimum dE76 in CIELAB)" if tables.objective == "lab"
                                  else "(minimum distance in encoded sRGB, paper eq. 10)"),
    }
