"""The print's medium cut into bricks, each a Mitsuba medium with its own majorant.

Defines :func:`partition` (boxes of cells chosen by a cost model) and :func:`uniform` (cubes of
a fixed number of cells).

Mitsuba's ``heterogeneous`` medium has one majorant: delta tracking steps through it at the
medium's largest extinction, so thin Clear around dense ink is crossed in the ink's steps (null
collisions). Cutting the print into boxes, each its own medium, gives each box its own
majorant, but every box a ray enters costs a boundary crossing (an intersection, a new ray
segment, a medium switch). :func:`partition` splits the print's box of cells top-down (a k-d
tree, greedy) wherever that lowers the expected cost of a ray path, for random straight rays::

    cost(box) = A(box) + w * majorant(box) * V(box)

``A`` the box's surface (rays entering it, by Cauchy's formula the count of chords is
proportional to the surface, and their mean length is 4 V / A), ``majorant * V`` the null and
real collisions of those chords (each chord averages ``majorant * 4 V / A`` collisions), ``w``
the cost of a collision step relative to a crossing, per unit surface. Boxes holding no ink are
not media at all (cost 0). Hand-written: no library cuts a Mitsuba medium by majorant.

``w`` was measured (``benchmarks/bench_proof.py --bricks``, 256 px, 16 spp, one view, quiet
2-core host, 2026-11-28): uniform bricks of 16 to 64 cells on the demo (a fog; 25.0, 19.8, 16.1,
16.7, 18.4 s per render for 16, 24, 32, 48, 64 cells) and the MagicaVoxel knight (a solid in
Clear; 51.2, 67.1, 71.6 s for 16, 32, 48) fit ``t = a + c_x sum A + c_m sum 4 maj V`` with
c_m / c_x = 0.118 (one crossing costs about what 8.5 collision steps do), so w = 4 x 0.118.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["partition", "uniform", "optically_deep", "COLLISION_WEIGHT", "DEEP_TAU", "Box"]

# cost of a collision step against a boundary crossing, per (majorant x volume) against per
# unit surface (module docstring)
COLLISION_WEIGHT = 4.0 * 0.118

Box = tuple[int, int, int, int, int, int]    # z0, z1, y0, y1, x0, x1 (cells, half-open)

# a box whose mean extinction (its least extinct channel) times its smallest extent is above
# this many mean free paths samples no emitters from inside (optically_deep)
DEEP_TAU = 3.0


def _box_cost(shape: tuple[int, int, int], majorant: float, cell: NDArray) -> float:
    if majorant <= 0:
        return 0.0
    ez, ey, ex = (n * c for n, c in zip(shape, cell[::-1], strict=True))
    return 2.0 * (ex * ey + ey * ez + ez * ex) + COLLISION_WEIGHT * majorant * ex * ey * ez


def _trim(m: NDArray, box: Box) -> Box | None:
    """The smallest box holding every cell of ``box`` with a positive extinction, or None."""
    z0, z1, y0, y1, x0, x1 = box
    occ = m[z0:z1, y0:y1, x0:x1] > 0
    if not occ.any():
        return None
    out = []
    for axis, start in ((0, z0), (1, y0), (2, x0)):
        other = tuple(a for a in range(3) if a != axis)
        idx = np.flatnonzero(occ.any(axis=other))
        out += [start + int(idx[0]), start + int(idx[-1]) + 1]
    return tuple(out)


def partition(sigma_t: NDArray, cell_mm: tuple[float, float, float]) -> list[Box]:
    """Boxes of cells covering every cell of ``sigma_t`` (ncz, ncy, ncx[, channels]) with a
    positive extinction, chosen to lower the cost model of the module docstring.
    ``cell_mm``: the cell's size along x, y, z. Deterministic."""
    m = np.asarray(sigma_t, np.float32)
    if m.ndim == 4:
        m = m.max(axis=-1)
    cell = np.asarray(cell_mm, np.float64)
    root = _trim(m, (0, m.shape[0], 0, m.shape[1], 0, m.shape[2]))
    out: list[Box] = []
    stack = [root] if root is not None else []
    while stack:
        box = stack.pop()
        z0, z1, y0, y1, x0, x1 = box
        sub = m[z0:z1, y0:y1, x0:x1]
        shape = sub.shape
        best = (_box_cost(shape, float(sub.max()), cell), None, 0)
        for axis in range(3):
            n = shape[axis]
            if n < 2:
                continue
            other = tuple(a for a in range(3) if a != axis)
            profile = sub.max(axis=other).astype(np.float64)
            before = np.maximum.accumulate(profile)[:-1]         # max of cells [0, k)
            after = np.maximum.accumulate(profile[::-1])[::-1][1:]  # max of cells [k, n)
            for k in range(1, n):
                lo = list(shape)
                lo[axis] = k
                hi = list(shape)
                hi[axis] = n - k
                c = (_box_cost(tuple(lo), before[k - 1], cell)
                     + _box_cost(tuple(hi), after[k - 1], cell))
                if c < best[0] * (1.0 - 1e-9):
                    best = (c, axis, k)
        _, axis, k = best
        if axis is None:
            out.append(box)
            continue
        starts = [z0, y0, x0]
        ends = [z1, y1, x1]
        mid = starts[axis] + k
        left_end = list(ends)
        left_end[axis] = mid
        right_start = list(starts)
        right_start[axis] = mid
        for child in ((starts[0], left_end[0], starts[1], left_end[1], starts[2], left_end[2]),
                      (right_start[0], ends[0], right_start[1], ends[1], right_start[2],
                       ends[2])):
            t = _trim(m, child)
            if t is not None:
                stack.append(t)
    return sorted(out)


def uniform(sigma_t: NDArray, brick: int) -> list[Box]:
    """Cubes of ``brick`` cells (cut at the grid's end) holding a positive extinction."""
    m = np.asarray(sigma_t)
    ncz, ncy, ncx = m.shape[:3]
    out: list[Box] = []
    for z0 in range(0, ncz, brick):
        for y0 in range(0, ncy, brick):
            for x0 in range(0, ncx, brick):
                box = (z0, min(z0 + brick, ncz), y0, min(y0 + brick, ncy), x0,
                       min(x0 + brick, ncx))
                if np.any(m[box[0]:box[1], box[2]:box[3], box[4]:box[5]] > 0):
                    out.append(box)
    return out


def optically_deep(sigma_t: NDArray, box: Box, cell_mm: tuple[float, float, float],
                   tau: float = DEEP_TAU) -> bool:
    """Whether ``box`` of ``sigma_t`` (ncz, ncy, ncx, channels) is optically deep: its mean
    extinction in its least extinct channel times its smallest extent (mm) above ``tau`` mean
    free paths. From most of its scattering events a shadow ray towards the environment
    crosses several mean free paths of ink and carries almost nothing, at the price of a
    ratio-tracked walk out of the print; a path that escapes finds the uniform environment by
    itself. The renderer switches next-event estimation off inside such boxes
    (``sample_emitters``; unbiased either way, :mod:`.print_render`)."""
    z0, z1, y0, y1, x0, x1 = box
    sub = np.asarray(sigma_t)[z0:z1, y0:y1, x0:x1]
    mean = sub.reshape(-1, sub.shape[-1]).mean(axis=0) if sub.ndim == 4 else sub.mean()
    extent = min((x1 - x0) * cell_mm[0], (y1 - y0) * cell_mm[1], (z1 - z0) * cell_mm[2])
    return float(np.min(mean)) * extent > tau
