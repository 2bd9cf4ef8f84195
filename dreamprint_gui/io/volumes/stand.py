"""How a source with no stated up axis is stood: the resting-side rule (issue 46, "stand it
right").

Placement step of a job (before the printer grid is laid): when neither the file nor its
writer's convention says which way is up (:func:`.orient.auto_up`), the object is stood as it
would rest on a table, among the six quarter-turn orientations ``--up`` offers.

The rule, on the source's density sampled over its declared box on a grid of
:data:`CELLS` cells along its longest side:

1. **The solid.** A cell is solid where the density reaches :data:`SURFACE_LEVEL` (a tenth) of
   the 99th percentile of the positive densities (an iso-surface: faint haze and stray splats
   are left out, whatever the file's density units). Its centre of mass ``c`` is the mean of
   the solid cells' centres (the print is one material, so mass follows volume).
2. **The underside, per side.** For each candidate up ``u`` the underside height ``h(x, y)`` of
   each column along ``u`` is where the density first crosses the level, linear between cells
   (sub-cell). The contact of tolerance ``t`` is the set of columns with
   ``h <= min h + t``; the support polygon ``P(t)`` is the convex hull of their cells
   (scipy's Qhull), and the stability margin ``m(t)`` the signed distance from the centre of
   mass's projection to the polygon's nearest edge (positive inside: it rests without tipping).
3. **Flat sides.** A side is flat when it rests (``m(t) > 0``) and its contact does not grow
   as the tolerance does: ``m(t) >= FLAT_RATIO * m(4 t)`` and ``|P(t)| >= AREA_RATIO *
   |P(4 t)|``, with ``t`` = :data:`TOLERANCE` of the longest side, and its support is not a
   speck (``|P(t)|`` at least :data:`MIN_SHARE` of the silhouette's hull along ``u``). A flat
   face has the same support at any tolerance; a curved one's grows with ``sqrt(t)`` in each
   curved direction (cylinder side: margin and area ratios 0.5; sphere, a donut on its rim:
   margin 0.5, area 0.25), so it is not flat. A donut lying down is: its support is the disc
   its hole's rim spans (ratios 0.85 and 0.7 for a tube half its ring's radius).
   The side with the **largest support area** ``|P(t)|`` wins; the kind's convention is kept
   when its own side is flat and within :data:`TIE` of the largest (a cube, a tile, a donut's
   two faces).
4. **No flat side: the longest axis up.** When the solid is elongated (the largest principal
   axis of its cells' second moments :data:`ELONGATION` times the next, within 30 degrees of a
   source axis), that axis is up, the end holding the centre of mass down (a lower centre of
   mass stands steadier; the convention's sign on a tie).
5. Otherwise the kind's convention is kept (a sphere, a cloud, a scene with no ground).

Every outcome is said in one line (:class:`.orient.Orientation`'s ``describe``), still as a
guess, with ``--up`` (the GUI's Up control) to change it. Hand-written: no maintained library
picks a resting orientation among axis turns of a sampled density (trimesh's
``compute_stable_poses`` needs a watertight mesh and arbitrary rotations).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from dreamprint_gui.io.volumes.base import PrintGrid

__all__ = ["CELLS", "SURFACE_LEVEL", "TOLERANCE", "FLAT_RATIO", "AREA_RATIO", "MIN_SHARE",
           "TIE", "ELONGATION",
           "solid_grid", "resting_up"]

CELLS = 96              # cells along the longest side of the declared box
SURFACE_LEVEL = 0.1     # of the positive densities' 99th percentile
TOLERANCE = 0.02        # contact tolerance t, of the solid's longest side
FLAT_RATIO = 0.75       # m(t) / m(4t) of a flat side
AREA_RATIO = 0.6        # |P(t)| / |P(4t)| of a flat side
MIN_SHARE = 0.05        # |P(t)| / the silhouette hull's area, of a flat side
TIE = 0.9               # the convention's flat side kept within this share of the largest
ELONGATION = 1.5        # ratio of principal standard deviations of an elongated solid
_MAX_SAMPLES = 2_000_000  # density samples per sample_slab call


def solid_grid(source, cells: int = CELLS):
    """(density (z, y, x) float32, cell size per axis (x, y, z), grid origin (x, y, z)): the
    source's density (source units) sampled at ``cells`` cells along its declared box's
    longest side; None when the box is empty or invalid."""
    lo = np.asarray(source.bounds[0], float)
    hi = np.asarray(source.bounds[1], float)
    ext = hi - lo
    if not (np.all(np.isfinite(ext)) and ext.max() > 0):
        return None
    step = float(ext.max()) / cells
    n = [max(1, math.ceil(e / step)) for e in ext]
    cell = np.array([e / k if e > 0 else step for e, k in zip(ext, n, strict=True)])
    grid = PrintGrid(tuple(n), tuple(cell), tuple(lo), 1.0)   # 1 mm per unit: cells in units
    dens = np.zeros((n[2], n[1], n[0]), np.float32)
    per = max(1, _MAX_SAMPLES // max(1, n[0] * n[1]))
    for z in range(0, n[2], per):
        _, sigma = source.sample_slab(grid, z, min(n[2], z + per), density_scale=1.0)
        dens[z:z + per] = np.nan_to_num(np.asarray(sigma, np.float32), nan=0.0)
    return dens, cell, lo


def _underside(dens: np.ndarray, level: float, axis: int, sign: int, cell: np.ndarray):
    """Height above the box's low side (for up = ``sign`` * source axis ``axis``, x=0) of each
    column's first crossing of ``level``, linear between cells, and the columns that cross;
    both as 2D arrays over the other two axes (ascending source axis order)."""
    d = np.moveaxis(dens, 2 - axis, 0)        # array axis of source axis a is 2 - a
    if sign < 0:
        d = d[::-1]
    solid = d >= level
    hit = solid.any(axis=0)
    first = np.argmax(solid, axis=0)
    at = np.take_along_axis(d, first[None], 0)[0].astype(np.float64)
    before = np.where(first > 0, np.take_along_axis(d, np.maximum(first - 1, 0)[None], 0)[0],
                      0.0).astype(np.float64)
    frac = np.clip((at - level) / np.maximum(at - before, 1e-30), 0.0, 1.0)
    h = (first + 0.5 - frac) * cell[axis]
    # the 2D arrays are (slow, fast) = (higher source axis, lower source axis): transpose
    return h.T, hit.T


def _support(h: np.ndarray, hit: np.ndarray, tol: float, centre: np.ndarray,
             cu: float, cv: float) -> tuple[float, float]:
    """(margin, area) of the support polygon of the columns within ``tol`` of the lowest:
    the hull of their cells (u, v) and the signed distance of ``centre`` (u, v) to its edges."""
    low = float(h[hit].min())
    iu, iv = np.nonzero(hit & (h <= low + tol))
    corners = np.concatenate([np.stack([(iu + du) * cu, (iv + dv) * cv], 1)
                              for du in (0, 1) for dv in (0, 1)])
    try:
        hull = ConvexHull(corners)
    except QhullError:
        return -math.inf, 0.0
    margin = -float(np.max(hull.equations[:, :2] @ centre + hull.equations[:, 2]))
    return margin, float(hull.volume)   # a 2D hull's "volume" is its area


def _name(axis: int, sign: int) -> str:
    return ("" if sign > 0 else "-") + "xyz"[axis]


def resting_up(source, convention: str) -> tuple[str, str] | None:
    """(up, reason) by the resting-side rule (module doc: a flat side, else the longest axis),
    or None when neither applies (no flat side, no long axis, nothing solid): the caller keeps
    ``convention``, which also settles ties."""
    sampled = solid_grid(source)
    if sampled is None:
        return None
    dens, cell, _ = sampled
    pos = dens[dens > 0]
    if pos.size < 8:
        return None
    level = SURFACE_LEVEL * float(np.percentile(pos, 99))
    solid = dens >= level
    if solid.sum() < 8:
        return None
    idx = np.argwhere(solid)[:, ::-1].astype(np.float64)          # (x, y, z) cell indices
    pts = (idx + 0.5) * cell
    com = pts.mean(axis=0)
    span = pts.max(axis=0) - pts.min(axis=0) + cell
    tol = TOLERANCE * float(span.max())
    flat = {}
    for axis in range(3):
        u, v = (a for a in range(3) if a != axis)
        for sign in (1, -1):
            h, hit = _underside(dens, level, axis, sign, cell)
            centre = com[[u, v]]
            m1, area = _support(h, hit, tol, centre, cell[u], cell[v])
            m4, area4 = _support(h, hit, 4 * tol, centre, cell[u], cell[v])
            _, silhouette = _support(h, hit, math.inf, centre, cell[u], cell[v])
            if m1 > 0 and m1 >= FLAT_RATIO * m4 and area >= AREA_RATIO * area4 \
                    and area >= MIN_SHARE * silhouette:
                flat[_name(axis, sign)] = area
    if flat:
        best = max(flat, key=flat.get)      # first of x, -x, y, ... on an exact tie
        if convention in flat and flat[convention] >= TIE * flat[best]:
            best = convention
        return best, "it stands on its largest flat side"
    cov = np.cov((pts - com).T)
    w, vec = np.linalg.eigh(cov)                                   # ascending
    if w[1] <= 0 or math.sqrt(w[2] / w[1]) < ELONGATION:
        return None
    major = vec[:, 2]
    axis = int(np.argmax(np.abs(major)))
    if abs(major[axis]) < math.cos(math.radians(30)):
        return None
    lo = float(pts[:, axis].min()) - cell[axis] / 2
    hi = float(pts[:, axis].max()) + cell[axis] / 2
    skew = (com[axis] - (lo + hi) / 2) / (hi - lo)
    if abs(skew) > 0.01:
        sign = 1 if skew < 0 else -1     # the end holding the centre of mass goes down
    else:
        sign = -1 if convention == "-" + "xyz"[axis] else 1
    return _name(axis, sign), "no flat side; it stands on its longest axis"
