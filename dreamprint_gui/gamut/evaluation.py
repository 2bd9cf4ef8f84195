"""Figures of merit of a printable gamut and of its table (issue 5's ``dreamprint gamut``).

Defines
-------
- :data:`IN_GAMUT_DE2000`: a colour is called in gamut when its best printable reproduction is
  within dE2000 1.0 (about one just-noticeable difference).
- :func:`lut_vs_direct`: dE2000 between the colour reproduced from the table (tetrahedral lookup)
  and from a direct optimisation (the table's objective solved for that colour alone, after the
  table's rendering intent, from the centre of the simplex) at random in-gamut colours.
- :func:`lattice_gap`: dE2000 to the target of the table lookup minus that of the best mixture
  on a 5 % lattice over the five-ink simplex (all through ``mixture.predict``), at random sRGB
  targets: how far the table is from a brute-force search (negative: the table is better).
- :func:`adjacent_jumps`: the dE2000 between the reproduced colours of neighbouring table nodes
  (banding or flips show as jumps larger than those of the nodes' own target colours).
- :func:`printable_lab`: CIELAB of a lattice over the five-ink simplex (the printable gamut).
- :func:`lab_volume`: convex-hull volume (dE^3) of CIELAB points (an upper bound of a
  non-convex gamut's volume).
- :func:`srgb_lab`: CIELAB of the sRGB cube's surface (for comparison).
- :func:`evaluate`: the JSON report; :func:`objective_figures`: the per-objective figures.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numba as nb
import numpy as np
from numpy.typing import NDArray

from dreamprint_gui.core.profile import InkProfile
from dreamprint_gui.gamut.forward import N_COLOUR_INKS, forward_model, mixtures_lab
from dreamprint_gui.gamut.mapping import intent_map, simplex_lattice, srgb_cube_faces
from dreamprint_gui.gamut.optimise import (
    de2000_residual,
    solve,
    solve_xyz,
    srgb_to_xyz,
    targets_for,
)
from dreamprint_gui.gamut.tables import ColourTables, lookup
from dreamprint_gui.physics.colorimetry import delta_E2000, observer_for, srgb_to_lab
from dreamprint_gui.physics.mixture import predict

__all__ = ["IN_GAMUT_DE2000", "lut_vs_direct", "printable_lab", "lab_volume", "srgb_lab",
           "evaluate", "lattice_gap", "adjacent_jumps", "objective_figures", "LATTICE_STEP",
           "LATTICE_TARGETS"]

IN_GAMUT_DE2000 = 1.0
LATTICE_STEP = 0.05
LATTICE_TARGETS = 300


def _stats(x: NDArray) -> dict:
    if x.size == 0:
        return {"mean": None, "p95": None, "max": None, "count": 0}
    return {"mean": float(x.mean()), "p95": float(np.percentile(x, 95)),
            "max": float(x.max()), "count": int(x.size)}


def lut_vs_direct(tables: ColourTables, profile: InkProfile, samples: int = 2000,
                  seed: int = 0) -> tuple[NDArray, NDArray]:
    """(dE2000 LUT vs direct at the in-gamut samples, dE2000 of direct to target at all).

    "Direct" solves the table's objective for the colour the table's intent reproduces (the
    sample itself for ``colorimetric``, its white-mapped colour for ``relative``, its
    SGCK-mapped colour for ``perceptual``); a sample is
    in gamut when the colorimetric direct solution reproduces it within ``IN_GAMUT_DE2000``.
    """
    model = forward_model(profile)
    rgb = np.random.default_rng(seed).random((samples, 3))
    start = np.full(N_COLOUR_INKS, 0.2)
    direct, _, _ = solve(model, tables.objective, rgb, start, max_iter=300)
    de_target = delta_E2000(mixtures_lab(model, direct), targets_for(model, "cielab", rgb))
    imap = intent_map(model, getattr(tables, "intent", "colorimetric"))
    if imap is not None:
        mapped = imap.map_xyz(srgb_to_xyz(model, rgb))
        direct, _, _ = solve_xyz(model, tables.objective, mapped, start, max_iter=300)
    lab_direct = mixtures_lab(model, direct)
    lab_lut = mixtures_lab(model, lookup(tables, rgb))
    inside = de_target <= IN_GAMUT_DE2000
    return delta_E2000(lab_lut, lab_direct)[inside], de_target


def _simplex_lattice(step: float) -> NDArray[np.float64]:
    return simplex_lattice(round(1.0 / step))


@nb.njit(cache=True, parallel=True)
def _nearest_de2000(targets, candidates, out):
    """Smallest CIEDE2000 from each target to any candidate (brute force)."""
    for i in nb.prange(targets.shape[0]):
        r = np.empty(3)
        best = np.inf
        for j in range(candidates.shape[0]):
            d = de2000_residual(targets[i], candidates[j], r)
            if d < best:
                best = d
        out[i] = math.sqrt(best)


def lattice_best(profile: InkProfile, rgb: NDArray, step: float = LATTICE_STEP
                 ) -> NDArray[np.float64]:
    """dE2000 to each sRGB target of the best mixture on the ``step`` simplex lattice
    (colours through ``mixture.predict``, as every reproduced colour in the product)."""

    lattice_lab = predict(profile, _simplex_lattice(step)).Lab
    target = srgb_to_lab(rgb, observer_for(profile.wavelengths_nm))
    out = np.empty(target.shape[0])
    _nearest_de2000(np.ascontiguousarray(target), np.ascontiguousarray(lattice_lab), out)
    return out


def lattice_gap(tables: ColourTables, profile: InkProfile, targets: int = LATTICE_TARGETS,
                seed: int = 0, best: NDArray | None = None) -> NDArray[np.float64]:
    """dE2000(lookup, target) - dE2000(best lattice mixture, target) at random sRGB targets."""

    rgb = np.random.default_rng(seed).random((targets, 3))
    if best is None:
        best = lattice_best(profile, rgb)
    lab = predict(profile, lookup(tables, rgb)).Lab
    return delta_E2000(lab, srgb_to_lab(rgb, observer_for(profile.wavelengths_nm))) - best


@nb.njit(cache=True, parallel=True)
def _jumps(lab, out):
    """dE2000 from every node to its +1 neighbour along each axis (0 past the last node)."""
    n = lab.shape[0]
    for i in nb.prange(n):
        r = np.empty(3)
        for j in range(n):
            for k in range(n):
                out[0, i, j, k] = 0.0 if i + 1 >= n else math.sqrt(
                    de2000_residual(lab[i, j, k], lab[min(i + 1, n - 1), j, k], r))
                out[1, i, j, k] = 0.0 if j + 1 >= n else math.sqrt(
                    de2000_residual(lab[i, j, k], lab[i, min(j + 1, n - 1), k], r))
                out[2, i, j, k] = 0.0 if k + 1 >= n else math.sqrt(
                    de2000_residual(lab[i, j, k], lab[i, j, min(k + 1, n - 1)], r))


def adjacent_jumps(tables: ColourTables, profile: InkProfile) -> dict:
    """Largest dE2000 between the reproduced colours of neighbouring nodes, and the same for
    the nodes' target (sRGB) colours for comparison; ``max_excess`` is the largest jump minus
    its pair's target jump (> 0: the table changes faster than the colours it reproduces)."""
    model = forward_model(profile)
    n = tables.size
    lab = mixtures_lab(model, tables.conc.astype(np.float64)).reshape(n, n, n, 3)
    a = np.linspace(0.0, 1.0, n)
    rgb = np.stack(np.meshgrid(a, a, a, indexing="ij"), axis=-1)
    tgt = targets_for(model, "cielab", rgb)
    jr = np.empty((3, n, n, n))
    jt = np.empty((3, n, n, n))
    _jumps(np.ascontiguousarray(lab), jr)
    _jumps(np.ascontiguousarray(tgt), jt)
    return {"max": float(jr.max()), "p999": float(np.percentile(jr, 99.9)),
            "target_max": float(jt.max()), "max_excess": float((jr - jt).max())}


def printable_lab(profile: InkProfile, steps: int = 24) -> NDArray[np.float64]:
    """CIELAB of all five-ink mixtures with concentrations in multiples of 1/steps."""
    return mixtures_lab(forward_model(profile), simplex_lattice(steps))


def srgb_lab(profile: InkProfile, steps: int = 33) -> NDArray[np.float64]:
    """CIELAB of the sRGB cube's six faces (steps x steps each)."""
    return targets_for(forward_model(profile), "lab", srgb_cube_faces(steps))


def lab_volume(lab: NDArray) -> float:
    from scipy.spatial import ConvexHull

    return float(ConvexHull(lab).volume)


_METRIC = {"srgb": "distance in encoded sRGB, paper eq. 10", "cielab": "dE76 in CIELAB",
           "de2000": "CIEDE2000"}


def objective_figures(tables: ColourTables, profile: InkProfile, samples: int = 2000,
                      best: NDArray | None = None) -> dict:
    """The figures of one table: LUT vs direct, in-gamut fraction, lattice gap, smoothness."""
    lut, de_direct = lut_vs_direct(tables, profile, samples)
    gap = lattice_gap(tables, profile, best=best)
    return {
        "objective": tables.objective,
        "intent": tables.intent,
        # as at the top level: this run's build, or the cached table's earlier build, apart
        "build_seconds": None if tables.cached else round(tables.build_seconds, 3),
        "built_seconds_when_cached": round(tables.build_seconds, 3) if tables.cached else None,
        "cached": tables.cached,
        "lut_vs_direct_dE2000": _stats(lut),
        "srgb_in_gamut_fraction": float(np.mean(de_direct <= IN_GAMUT_DE2000)),
        "lookup_minus_lattice_best_dE2000": _stats(gap),
        "adjacent_node_dE2000": adjacent_jumps(tables, profile),
        "node_dE2000_mean": float(np.mean(tables.dE2000)),
    }


def evaluate(tables: ColourTables, profile: InkProfile, samples: int = 2000,
             others: list[ColourTables] | None = None,
             progress: Callable[[int, int], None] | None = None) -> dict:
    """The report printed by ``dreamprint gamut --json``.

    Top level: the figures of ``tables`` (the chosen objective and intent) and the gamut;
    ``objectives``: :func:`objective_figures` of ``tables`` and of each of ``others``.
    ``progress(done, total)``: after each step (the lattice's best, then each objective's
    direct solves; seconds each), ``(0, total)`` first.
    """
    total = 2 + len(others or [])
    if progress is not None:
        progress(0, total)
    de_nodes = np.asarray(tables.dE2000, dtype=np.float64).ravel()
    rgb = np.random.default_rng(0).random((LATTICE_TARGETS, 3))
    best = lattice_best(profile, rgb)
    if progress is not None:
        progress(1, total)
    mine = objective_figures(tables, profile, samples, best)
    if progress is not None:
        progress(2, total)
    per = {tables.objective: mine}
    for k, t in enumerate(others or []):
        per[t.objective] = objective_figures(t, profile, samples, best)
        if progress is not None:
            progress(3 + k, total)
    out = de_nodes[de_nodes > IN_GAMUT_DE2000]
    ct = tables.colour_thickness_mm
    intent = tables.intent
    return {
        "lut_size": tables.size,
        "objective": tables.objective,
        "intent": intent,
        # this run: loaded from the cache (cached, load_seconds) or built (build_seconds)
        "cached": tables.cached,
        "seconds": round(tables.load_seconds if tables.cached else tables.build_seconds, 3),
        "load_seconds": round(tables.load_seconds, 3) if tables.cached else None,
        "build_seconds": None if tables.cached else round(tables.build_seconds, 3),
        "built_seconds_when_cached": round(tables.build_seconds, 3) if tables.cached else None,
        "colour_thickness_mm": None if math.isinf(ct) else ct,
        "srgb_in_gamut_fraction": mine["srgb_in_gamut_fraction"],
        "in_gamut_threshold_dE2000": IN_GAMUT_DE2000,
        "node_dE2000_mean": float(de_nodes.mean()),
        "lab_gamut_volume": lab_volume(printable_lab(profile)),
        "srgb_lab_volume": lab_volume(srgb_lab(profile)),
        "lab_volume_method": "convex hull in CIELAB (dE^3)",
        "lut_vs_direct_dE2000": mine["lut_vs_direct_dE2000"],
        "lookup_minus_lattice_best_dE2000": mine["lookup_minus_lattice_best_dE2000"],
        "lattice": {"step": LATTICE_STEP, "targets": LATTICE_TARGETS, "seed": 0,
                    "colour_model": "mixture.predict"},
        "adjacent_node_dE2000": mine["adjacent_node_dE2000"],
        "out_of_gamut_dE2000": _stats(out),
        "out_of_gamut_policy": (
            f"nearest printable colour ({_METRIC[tables.objective]})" if intent == "colorimetric"
            else "the source white mapped onto the printable white (ICC relative colorimetric, "
                 f"Bradford), then nearest printable colour ({_METRIC[tables.objective]})"
            if intent == "relative"
            else "SGCK compression of sRGB into the printable gamut in CAM16-UCS (CIE 156), "
                 f"then nearest printable colour ({_METRIC[tables.objective]})"),
        "objectives": per,
    }
