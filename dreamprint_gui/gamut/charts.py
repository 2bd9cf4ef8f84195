"""Pictures of the printable gamut (matplotlib, Agg canvas; no screen needed).

Defines
-------
- :func:`hexagon_chart`: the paper's Fig. 7 style chart: the sRGB cube seen along its grey axis
  (the hexagon of hue x saturation at HSV value 1 and 0.5), tiled with hexagonal cells; per
  cell the source colour, the colour printed through the table under its rendering intent
  (lookup, then KM eq. 7: the intent's mapping source -> printed), and their dE2000.
- :func:`gamut_plot`: the printable gamut (mixtures of the five inks) against sRGB in CIELAB:
  a*-b* and C*-L* projections.
"""

from __future__ import annotations

import os

import numpy as np
from numpy.typing import NDArray

from dreamprint_gui.core.profile import InkProfile
from dreamprint_gui.gamut.evaluation import printable_lab, srgb_lab
from dreamprint_gui.gamut.forward import forward_model, mixtures_lab, mixtures_srgb
from dreamprint_gui.gamut.optimise import targets_for
from dreamprint_gui.gamut.tables import ColourTables, lookup
from dreamprint_gui.physics.colorimetry import delta_E2000

__all__ = ["hexagon_cells", "hexagon_chart", "gamut_plot"]


def hexagon_cells(rings: int = 12) -> tuple[NDArray, NDArray]:
    """Centres (N, 2) of a hexagonal tiling of the unit hexagon and their HSV (hue, saturation)."""
    pts = []
    for q in range(-rings, rings + 1):
        for r in range(-rings, rings + 1):
            s = -q - r
            if max(abs(q), abs(r), abs(s)) <= rings:
                pts.append((np.sqrt(3) * (q + r / 2.0), 1.5 * r))
    xy = np.asarray(pts) / (1.5 * rings)
    # hexagonal (not circular) saturation so the tiling's rim is the cube's saturated rim
    ang = np.arctan2(xy[:, 1], xy[:, 0])
    rad = np.hypot(xy[:, 0], xy[:, 1])
    sector = np.mod(ang, np.pi / 3) - np.pi / 6
    sat = np.clip(rad * np.cos(sector) / np.cos(np.pi / 6), 0.0, 1.0)
    hue = np.mod(ang / (2 * np.pi), 1.0)
    return xy, np.stack([hue, sat], axis=1)


def _figure(width_in: float, height_in: float):
    """A figure drawn on its own Agg canvas: matplotlib's object interface, not pyplot, whose
    global figure list is not thread-safe (the GUI draws these charts in worker threads) and
    whose ``matplotlib.use`` would switch the backend of the whole process."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width_in, height_in), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def hexagon_chart(tables: ColourTables, profile: InkProfile, path: str | os.PathLike,
                  rings: int = 12) -> dict:
    """Write the chart to ``path`` (PNG); returns dE2000 statistics of the cells."""
    from matplotlib.collections import PolyCollection
    from matplotlib.colors import hsv_to_rgb

    model = forward_model(profile)
    xy, hs = hexagon_cells(rings)
    size = 1.0 / (1.5 * rings)
    ang = np.deg2rad(np.arange(6) * 60 + 30)
    hexagon = np.stack([np.cos(ang), np.sin(ang)], axis=1) * size * 1.0
    fig = _figure(12, 8.4)
    axes = fig.subplots(2, 3)
    stats = {}
    for row, value in enumerate((1.0, 0.5)):
        hsv = np.concatenate([hs, np.full((hs.shape[0], 1), value)], axis=1)
        rgb = hsv_to_rgb(hsv)
        conc = lookup(tables, rgb)
        lab = mixtures_lab(model, conc)
        repro = np.clip(mixtures_srgb(model, conc), 0.0, 1.0)
        de = delta_E2000(lab, targets_for(model, "lab", rgb))
        stats[f"value_{value:g}"] = {"mean": float(de.mean()), "max": float(de.max())}
        polys = xy[:, None, :] + hexagon[None]
        intent = getattr(tables, "intent", "colorimetric")
        for col, (colours, title) in enumerate(((rgb, "source sRGB"),
                                                (repro, f"printed, {intent}"))):
            ax = axes[row, col]
            ax.add_collection(PolyCollection(polys, facecolors=colours, edgecolors="none"))
            ax.set_title(f"{title}, HSV value {value:g}")
        ax = axes[row, 2]
        pc = PolyCollection(polys, array=de, cmap="magma", edgecolors="none")
        pc.set_clim(0, max(10.0, float(np.percentile(de, 99))))
        ax.add_collection(pc)
        fig.colorbar(pc, ax=ax, label="dE2000")
        ax.set_title(f"dE2000 source vs printed, mean {de.mean():.1f}")
        for ax in axes[row]:
            ax.set_xlim(-1.1, 1.1)
            ax.set_ylim(-1.1, 1.1)
            ax.set_aspect("equal")
            ax.axis("off")
    fig.suptitle(f"Printable colours vs sRGB (objective {tables.objective}, intent "
                 f"{getattr(tables, 'intent', 'colorimetric')}, table {tables.size}^3)")
    fig.savefig(path, dpi=110)
    return stats


def gamut_plot(profile: InkProfile, path: str | os.PathLike) -> None:
    """Write the CIELAB gamut picture (printable vs sRGB) to ``path`` (PNG)."""
    from scipy.spatial import ConvexHull

    lab_p = printable_lab(profile, steps=16)
    model = forward_model(profile)
    lab_s = srgb_lab(profile)
    srgb_faces = np.clip(model_srgb_of_lab(model, lab_s), 0, 1)
    conc_colours = np.clip(model_srgb_of_lab(model, lab_p), 0, 1)
    fig = _figure(12, 5.6)
    axes = fig.subplots(1, 2)
    ax = axes[0]
    ax.scatter(lab_p[:, 1], lab_p[:, 2], c=conc_colours, s=4, linewidths=0)
    hull = ConvexHull(lab_s[:, 1:])
    ring = np.append(hull.vertices, hull.vertices[0])
    ax.plot(lab_s[ring, 1], lab_s[ring, 2], "k-", lw=1.2, label="sRGB")
    hp = ConvexHull(lab_p[:, 1:])
    ringp = np.append(hp.vertices, hp.vertices[0])
    ax.plot(lab_p[ringp, 1], lab_p[ringp, 2], "-", color="tab:red", lw=1.2,
            label="printable (KM, 5 inks)")
    ax.set_xlabel("a*")
    ax.set_ylabel("b*")
    ax.set_aspect("equal")
    ax.legend(loc="lower left")
    ax.set_title("CIELAB a*-b*")
    ax = axes[1]
    c_p = np.hypot(lab_p[:, 1], lab_p[:, 2])
    c_s = np.hypot(lab_s[:, 1], lab_s[:, 2])
    ax.scatter(c_s, lab_s[:, 0], c=srgb_faces, s=3, linewidths=0, alpha=0.35, label="sRGB")
    ax.scatter(c_p, lab_p[:, 0], c=conc_colours, s=4, linewidths=0,
               edgecolors="none", label="printable")
    ax.set_xlabel("C*ab")
    ax.set_ylabel("L*")
    ax.set_title("CIELAB C*-L* (faint: sRGB surface)")
    fig.suptitle(f"Printable gamut vs sRGB, profile {profile.name}")
    fig.savefig(path, dpi=110)


def model_srgb_of_lab(model, lab: NDArray) -> NDArray:
    import colour

    xyz = colour.Lab_to_XYZ(lab, illuminant=colour.XYZ_to_xy(model.white))
    return colour.models.eotf_inverse_sRGB(xyz @ model.xyz_to_rgb.T)
