"""A halftoned printer layer at full resolution, with zoom and pan, and its material legend.

Defines :class:`LayerView`: a ``QGraphicsView`` holding one layer image (one pixel per printer
voxel, never smoothed) drawn at the voxels' physical proportions (a voxel of 84 x 28 um is three
times as wide as it is tall). The wheel zooms about the cursor, a drag pans, "Fit" shows the whole
layer again and "1:1" shows one screen pixel per voxel along its finer axis. While the operator
has not zoomed the layer follows the view's size; after a zoom, moving to another layer keeps the
zoom and the place. :class:`MaterialLegend` lists the labels of a layer one per line (swatch,
name, share), so it never wraps.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from PySide6.QtCore import QRectF, Qt, Signal
from PySide6.QtGui import QBrush, QColor, QImage, QPainter, QPixmap, QTransform
from PySide6.QtWidgets import (
    QGraphicsPixmapItem,
    QGraphicsScene,
    QGraphicsView,
    QGridLayout,
    QHBoxLayout,
    QLabel,
    QPushButton,
    QVBoxLayout,
    QWidget,
)

__all__ = ["LayerView", "LayerCanvas", "MaterialLegend", "ZOOM_STEP", "MAX_ZOOM"]

ZOOM_STEP = 1.25  # per wheel notch (120 eighths of a degree)
MAX_ZOOM = 64.0  # screen pixels per voxel along the finer axis


class LayerCanvas(QGraphicsView):
    """The graphics view proper: wheel zoom about the cursor, drag to pan."""

    zoomed = Signal()

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.setScene(QGraphicsScene(self))
        self.item = QGraphicsPixmapItem()
        self.item.setTransformationMode(Qt.TransformationMode.FastTransformation)  # voxels
        self.scene().addItem(self.item)
        self.setDragMode(QGraphicsView.DragMode.ScrollHandDrag)
        self.setTransformationAnchor(QGraphicsView.ViewportAnchor.AnchorUnderMouse)
        self.setResizeAnchor(QGraphicsView.ViewportAnchor.AnchorViewCenter)
        self.setRenderHint(QPainter.RenderHint.SmoothPixmapTransform, False)
        self.setBackgroundBrush(QBrush(QColor(34, 34, 34)))
        self.setMinimumSize(220, 160)
        self.fitted = True  # follows the view's size until the operator zooms

    def zoom(self) -> float:
        """Screen pixels per scene unit (one unit = one voxel along the finer axis)."""
        return float(self.transform().m11())

    def zoom_by(self, factor: float) -> None:
        z = self.zoom()
        factor = max(min(factor, MAX_ZOOM / z), self._fit_zoom() / 4 / z)
        self.scale(factor, factor)
        self.fitted = False
        self.zoomed.emit()

    def _fit_zoom(self) -> float:
        r = self.sceneRect()
        vp = self.viewport().rect()
        if r.isEmpty() or vp.isEmpty():
            return 1.0
        return min(vp.width() / r.width(), vp.height() / r.height())

    def fit(self) -> None:
        if not self.sceneRect().isEmpty():
            self.fitInView(self.sceneRect(), Qt.AspectRatioMode.KeepAspectRatio)
        self.fitted = True
        self.zoomed.emit()

    def actual_size(self) -> None:
        self.setTransform(QTransform())
        self.fitted = False
        self.zoomed.emit()

    def wheelEvent(self, event) -> None:  # noqa: N802 - Qt override
        steps = event.angleDelta().y() / 120.0
        if steps:
            self.zoom_by(ZOOM_STEP ** steps)
        event.accept()

    def resizeEvent(self, event) -> None:  # noqa: N802 - Qt override
        super().resizeEvent(event)
        if self.fitted:
            self.fit()


class LayerView(QWidget):
    """One printer layer at full resolution with Fit and 1:1 buttons and the current zoom."""

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.canvas = LayerCanvas(self)
        self.fit_button = QPushButton("Fit")
        self.fit_button.setToolTip("Show the whole layer (the wheel zooms, a drag pans)")
        self.fit_button.clicked.connect(self.canvas.fit)
        self.one_button = QPushButton("1:1")
        self.one_button.setToolTip("One screen pixel per voxel along the finer axis")
        self.one_button.clicked.connect(self.canvas.actual_size)
        self.zoom_label = QLabel("")
        self.canvas.zoomed.connect(self._show_zoom)
        row = QHBoxLayout()
        row.setContentsMargins(0, 0, 0, 0)
        row.addWidget(self.fit_button)
        row.addWidget(self.one_button)
        row.addWidget(self.zoom_label, 1)
        lay = QVBoxLayout(self)
        lay.setContentsMargins(0, 0, 0, 0)
        lay.addWidget(self.canvas, 1)
        lay.addLayout(row)
        self.image: QImage | None = None

    def set_layer(self, image: QImage, voxel_xy_mm: tuple[float, float]) -> None:
        """Show ``image`` (one pixel per voxel) with voxels of ``voxel_xy_mm`` (x, y)."""
        same_size = self.image is not None and self.image.size() == image.size()
        self.image = image
        c = self.canvas
        c.item.setPixmap(QPixmap.fromImage(image))
        vx, vy = voxel_xy_mm
        unit = min(vx, vy)  # a scene unit: the finer axis' voxel
        c.item.setTransform(QTransform.fromScale(vx / unit, vy / unit))
        c.setSceneRect(c.item.sceneBoundingRect())
        if c.fitted or not same_size:
            c.fit()
        else:
            self._show_zoom()

    def visible_voxels(self) -> QRectF:
        """The part of the layer on screen, in voxels of the image (x, y, width, height)."""
        c = self.canvas
        shown = c.mapToScene(c.viewport().rect()).boundingRect()
        return c.item.mapFromScene(shown).boundingRect().intersected(c.item.boundingRect())

    def _show_zoom(self) -> None:
        if self.image is None:
            self.zoom_label.setText("")
            return
        r = self.visible_voxels()
        self.zoom_label.setText(f"{self.image.width()} x {self.image.height()} voxels; "
                                f"showing {max(0, round(r.width()))} x "
                                f"{max(0, round(r.height()))}")


class MaterialLegend(QWidget):
    """Materials of a layer, one per line: colour swatch, name, share of the layer's voxels."""

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.grid = QGridLayout(self)
        self.grid.setContentsMargins(0, 0, 0, 0)
        self.grid.setHorizontalSpacing(8)
        self.grid.setVerticalSpacing(2)
        self.grid.setColumnStretch(1, 1)
        self.rows: list[tuple[str, float]] = []

    def clear(self) -> None:
        while self.grid.count():
            w = self.grid.takeAt(0).widget()
            if w is not None:
                w.deleteLater()
        self.rows = []

    def set_counts(self, colours: np.ndarray, names: Sequence[str], counts: np.ndarray) -> None:
        """One line per label with a non-zero count (colours (n, 3) uint8)."""
        self.clear()
        total = max(1, int(np.sum(counts)))
        row = 0
        for i, name in enumerate(names):
            if not counts[i]:
                continue
            r, g, b = (int(v) for v in colours[i])
            swatch = QLabel()
            swatch.setFixedSize(18, 12)
            swatch.setStyleSheet(f"background: rgb({r},{g},{b}); border: 1px solid #777;")
            share = 100.0 * float(counts[i]) / total
            text = QLabel(name)
            pct = QLabel(f"{share:.1f} %")
            pct.setAlignment(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)
            self.grid.addWidget(swatch, row, 0)
            self.grid.addWidget(text, row, 1)
            self.grid.addWidget(pct, row, 2)
            self.rows.append((name, share))
            row += 1
