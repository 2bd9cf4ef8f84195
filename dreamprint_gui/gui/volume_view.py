"""Volume rendering helpers shared by the preview and the gamut view (pyvista / pyvistaqt).

Defines :func:`make_plotter` (a QtInteractor with one or two linked views that leaves file
drops to the main window), :class:`ViewHost` (where a page's 3D view goes: a message until the
view is first needed, so a window shows before VTK is even imported), :func:`import_3d` (imports
VTK, pyvista and pyvistaqt, about 2.5 s, meant for a worker thread while the window is already
up), :func:`add_rgba_volume` (sRGB colour + Beer-Lambert opacity per voxel, rendered directly
as RGBA) and :func:`frame_statistics` (what tests and the screenshot check: the share of pixels
differing from the background).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from PySide6.QtCore import QSize, Qt
from PySide6.QtWidgets import QLabel, QStackedLayout, QWidget

from dreamprint_gui.gui.preview_data import opacity_per_voxel

__all__ = ["make_plotter", "ViewHost", "import_3d", "add_rgba_volume", "frame_statistics",
           "BACKGROUND"]

BACKGROUND = (0.16, 0.16, 0.18)


def import_3d() -> None:
    """Import the 3D stack (VTK, pyvista, pyvistaqt). Safe on a worker thread: it creates no
    widget, and a GUI-thread import of the same modules just waits for it to finish."""
    import pyvista  # noqa: F401
    import pyvistaqt  # noqa: F401
    import vtk  # noqa: F401


class ViewHost(QWidget):
    """A page's 3D view, created on first use of :attr:`plotter` (a message shows until then)."""

    def __init__(self, parent: QWidget | None, shape: tuple[int, int], message: str) -> None:
        super().__init__(parent)
        self._shape = shape
        self._plotter = None
        self.message = QLabel(message)
        self.message.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.message.setWordWrap(True)
        r, g, b = (int(round(255 * c)) for c in BACKGROUND)
        self.message.setStyleSheet(f"background: rgb({r},{g},{b}); color: #ccc; padding: 20px;")
        self.setMinimumSize(400, 300)
        self._stack = QStackedLayout(self)
        self._stack.setContentsMargins(0, 0, 0, 0)
        self._stack.addWidget(self.message)

    def sizeHint(self) -> QSize:  # noqa: N802 - Qt override
        return QSize(1000, 700)  # the 3D views take the room a splitter gives (not the text's)

    @property
    def has_plotter(self) -> bool:
        return self._plotter is not None

    @property
    def plotter(self):
        """The QtInteractor (created, and the 3D stack imported, on first access)."""
        if self._plotter is None:
            self._plotter = make_plotter(self, self._shape)
            self._stack.addWidget(self._plotter)
            self._stack.setCurrentWidget(self._plotter)
        return self._plotter

    def set_message(self, text: str) -> None:
        """What the placeholder says while there is nothing to draw yet."""
        self.message.setText(text)

    def close_view(self) -> None:
        if self._plotter is not None:
            self._plotter.close()


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
                    name: str, origin: tuple[float, float, float] = (0.0, 0.0, 0.0),
                    interpolation: str = "linear"):
    """Render colour (z, y, x, 3) sRGB and density (z, y, x) 1/mm as an emission-absorption
    volume in millimetres. Each voxel's alpha is 1 - exp(-sigma * voxel) and the opacity unit
    distance is one voxel, so VTK's per-sample correction keeps Beer-Lambert at any step.
    ``interpolation`` "linear" blends between voxels (fog), "nearest" keeps each voxel's
    colour and edges (voxel art). Not rendered here: the caller renders once when everything
    is added (each render of a volume takes a visible moment in software OpenGL)."""
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
                               show_scalar_bar=False, reset_camera=False, render=False)
    opacity = vtk.vtkPiecewiseFunction()  # alpha byte -> opacity, identity
    opacity.AddPoint(0.0, 0.0)
    opacity.AddPoint(255.0, 1.0)
    actor.prop.SetScalarOpacity(opacity)
    actor.prop.SetScalarOpacityUnitDistance(voxel_mm)
    if interpolation == "nearest":
        actor.prop.SetInterpolationTypeToNearest()
    else:
        actor.prop.SetInterpolationTypeToLinear()
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
