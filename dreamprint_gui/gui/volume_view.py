"""Volume rendering helpers shared by the preview and the gamut view (pyvista / pyvistaqt).

Defines :func:`make_plotter` (a QtInteractor with one or two linked views that leaves file
drops to the main window), :func:`add_rgba_volume` (sRGB colour + Beer-Lambert opacity per
voxel, rendered directly as RGBA) and :func:`frame_statistics` (what tests and the screenshot
check: the share of pixels differing from the background).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .preview_data import opacity_per_voxel

__all__ = ["make_plotter", "add_rgba_volume", "frame_statistics", "BACKGROUND"]

BACKGROUND = (0.16, 0.16, 0.18)


def make_plotter(parent, shape: tuple[int, int] = (1, 1), link: bool = True):
    """A pyvistaqt QtInteractor; with two views their cameras are linked."""
    from pyvistaqt import QtInteractor

    plotter = QtInteractor(parent, shape=shape, auto_update=False, border=False)
    plotter.setAcceptDrops(False)  # drops go to the main window, which opens files
    plotter.set_background(BACKGROUND)
    if link and shape != (1, 1):
        plotter.link_views()
    return plotter


def add_rgba_volume(plotter, rgb: NDArray, sigma_per_mm: NDArray, voxel_mm: float,
                    name: str, origin: tuple[float, float, float] = (0.0, 0.0, 0.0)):
    """Render colour (z, y, x, 3) sRGB and density (z, y, x) 1/mm as an emission-absorption
    volume in millimetres. Each voxel's alpha is 1 - exp(-sigma * voxel) and the opacity unit
    distance is one voxel, so VTK's per-sample correction keeps Beer-Lambert at any step."""
    import pyvista as pv
    import vtk

    nz, ny, nx = sigma_per_mm.shape
    alpha = opacity_per_voxel(sigma_per_mm, voxel_mm)
    rgba = np.empty((nz, ny, nx, 4), dtype=np.uint8)
    rgba[..., :3] = np.clip(np.asarray(rgb) * 255.0 + 0.5, 0, 255).astype(np.uint8)
    rgba[..., 3] = np.clip(alpha * 255.0 + 0.5, 0, 255).astype(np.uint8)
    grid = pv.ImageData(dimensions=(nx, ny, nz), spacing=(voxel_mm,) * 3, origin=origin)
    grid.point_data["rgba"] = rgba.reshape(-1, 4)  # (z, y, x) C order = VTK's x-fastest order
    actor = plotter.add_volume(grid, scalars="rgba", name=name, opacity_unit_distance=voxel_mm,
                               show_scalar_bar=False, reset_camera=False)
    opacity = vtk.vtkPiecewiseFunction()  # alpha byte -> opacity, identity
    opacity.AddPoint(0.0, 0.0)
    opacity.AddPoint(255.0, 1.0)
    actor.prop.SetScalarOpacity(opacity)
    actor.prop.SetScalarOpacityUnitDistance(voxel_mm)
    return actor, grid


def frame_statistics(image: NDArray, background=BACKGROUND, tol: int = 6) -> dict:
    """Share of pixels of an RGB(A) frame that differ from the background colour, and their
    mean colour. A rendered volume gives a share well above 0; an empty view gives 0."""
    img = np.asarray(image)[..., :3].astype(np.int16)
    bg = np.round(np.asarray(background) * 255).astype(np.int16)
    differs = np.abs(img - bg).max(axis=-1) > tol
    share = float(differs.mean()) if differs.size else 0.0
    mean = img[differs].mean(axis=0).tolist() if differs.any() else [0.0, 0.0, 0.0]
    return {"non_background_fraction": share, "mean_rgb": mean,
            "pixels": int(differs.size)}
