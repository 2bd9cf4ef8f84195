"""Geometry and numbers for the gamut page, from engine calls only (no Qt here).

Defines :func:`printable_gamut_mesh` (the convex hull in CIELAB of mixtures on a lattice over
the C, M, Y, K, W simplex, each coloured by its own predicted sRGB: ``mixture.predict`` at the
profile's reference thickness), :func:`srgb_gamut_mesh` (the surface of the sRGB cube mapped to
CIELAB, D65) and :func:`pick_colour` (a target colour's table concentrations, reproduced colour
and dE2000, as ``dreamprint lookup`` reports them). Coordinates of the meshes are
(a*, b*, L*) so that lightness is up.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["GamutMesh", "printable_gamut_mesh", "srgb_gamut_mesh", "pick_colour",
           "simplex_lattice"]


@dataclass
class GamutMesh:
    points_ab_l: NDArray[np.float64]  # (n, 3): a*, b*, L*
    faces: NDArray[np.int64]  # (m, 3) triangles
    rgb: NDArray[np.float64]  # (n, 3) sRGB in [0, 1]

    def to_pyvista(self):
        import pyvista as pv

        faces = np.hstack([np.full((len(self.faces), 1), 3), self.faces]).ravel()
        mesh = pv.PolyData(self.points_ab_l.astype(np.float64), faces)
        mesh.point_data["rgb"] = np.clip(self.rgb * 255 + 0.5, 0, 255).astype(np.uint8)
        return mesh


def simplex_lattice(n_inks: int, steps: int) -> NDArray[np.float64]:
    """All concentrations k / steps (k integer) of ``n_inks`` inks summing to 1."""
    rows = [c for c in itertools.product(range(steps + 1), repeat=n_inks - 1)
            if sum(c) <= steps]
    a = np.array(rows, dtype=np.float64)
    return np.column_stack([a, steps - a.sum(axis=1)]) / steps


def printable_gamut_mesh(profile, steps: int = 12) -> GamutMesh:
    """Hull of the colours printable with C, M, Y, K, W (Clear adds no colour at R_inf)."""
    from scipy.spatial import ConvexHull

    from dreamprint_gui.physics.mixture import predict

    conc = simplex_lattice(5, steps)
    pred = predict(profile, conc)
    lab = np.asarray(pred.Lab)
    pts = np.column_stack([lab[:, 1], lab[:, 2], lab[:, 0]])
    hull = ConvexHull(pts)
    used = np.unique(hull.simplices)
    remap = np.full(len(pts), -1)
    remap[used] = np.arange(len(used))
    return GamutMesh(pts[used], remap[hull.simplices], np.clip(pred.sRGB[used], 0, 1))


def srgb_gamut_mesh(profile, n: int = 17) -> GamutMesh:
    """The sRGB cube's surface (n x n per face) in CIELAB under the profile's observer."""
    from dreamprint_gui.physics.colorimetry import observer_for, srgb_to_lab

    t = np.linspace(0.0, 1.0, n)
    u, v = np.meshgrid(t, t, indexing="ij")
    pts, faces = [], []
    quads = np.array([[i * n + j, (i + 1) * n + j, (i + 1) * n + j + 1, i * n + j + 1]
                      for i in range(n - 1) for j in range(n - 1)])
    for axis in range(3):
        for value in (0.0, 1.0):
            rgb = np.empty((n * n, 3))
            others = [k for k in range(3) if k != axis]
            rgb[:, axis] = value
            rgb[:, others[0]] = u.ravel()
            rgb[:, others[1]] = v.ravel()
            base = sum(len(p) for p in pts)
            pts.append(rgb)
            faces.append(np.vstack([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]]) + base)
    rgb = np.vstack(pts)
    lab = np.asarray(srgb_to_lab(rgb, observer_for(profile.wavelengths_nm)))
    return GamutMesh(np.column_stack([lab[:, 1], lab[:, 2], lab[:, 0]]), np.vstack(faces), rgb)


def pick_colour(profile, tables, rgb, density: float | None = None) -> dict:
    """What the printer makes of sRGB ``rgb`` (encoded, 0-1 as ``dreamprint lookup --rgb``):
    table concentrations (C, M, Y, K, W), the reproduced colour (``predict`` at the reference
    thickness) and its dE2000 to the target, under the tables' rendering intent (``intent``:
    the mapping source -> printed colour); and, as ``dreamprint lookup`` reports them, the
    voxel's inks after density alignment (``aligned``: all six, Clear included) for a density
    ``density`` (1/mm; None: the mixture's own, so no Clear)."""
    from dreamprint_gui.core.profile import COLOUR_INKS, INKS
    from dreamprint_gui.gamut import align_density, lookup
    from dreamprint_gui.physics.colorimetry import delta_E2000, observer_for, srgb_to_lab
    from dreamprint_gui.physics.mixture import predict

    target = np.clip(np.asarray(rgb, dtype=np.float64).reshape(3), 0.0, 1.0)
    conc = np.asarray(lookup(tables, target.astype(np.float32)[None, :]),
                      dtype=np.float64).reshape(5)
    pred = predict(profile, conc)
    lab_t = np.asarray(srgb_to_lab(target, observer_for(profile.wavelengths_nm)))
    lab_r = np.asarray(pred.Lab).reshape(3)
    own = float(np.asarray(pred.sigma_per_mm).reshape(()))
    al = align_density(tables, target[None, :], conc[None, :],
                       np.array([own if density is None else float(density)]), profile)
    return {
        "rgb": target.tolist(),
        "concentrations": dict(zip(COLOUR_INKS, conc.tolist(), strict=True)),
        "aligned": dict(zip(INKS, np.asarray(al.conc).reshape(len(INKS)).tolist(),
                            strict=True)),
        "sRGB": np.asarray(pred.sRGB).reshape(3).tolist(),
        "Lab": lab_r.tolist(),
        "target_Lab": lab_t.reshape(3).tolist(),
        "dE2000": float(np.asarray(delta_E2000(lab_t, lab_r)).reshape(())),
        "sigma_per_mm": own,
        "aligned_sigma_per_mm": float(np.asarray(al.sigma).reshape(-1)[0]),
        "density_clamped": {-1: "low", 0: None, 1: "high"}[int(np.asarray(al.clamped)
                                                               .reshape(-1)[0])],
        "intent": getattr(tables, "intent", "colorimetric"),
    }
