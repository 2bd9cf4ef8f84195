"""What the calibration wizard's pages share: the ink colours of its plots, the style of an
inline error, and a matplotlib canvas."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from matplotlib.backends.backend_qtagg import FigureCanvasQTAgg
    from matplotlib.figure import Figure

__all__ = ["INK_COLOURS", "ERROR_STYLE", "canvas"]

INK_COLOURS = {"C": "#00a0d0", "M": "#d0007a", "Y": "#d8c000", "K": "#202020", "W": "#999999",
               "Cl": "#60b0a0"}
ERROR_STYLE = "color: #d33;"


def canvas(figsize: tuple[float, float] = (6, 4)) -> tuple[Figure, FigureCanvasQTAgg]:
    """A (Figure, Qt canvas) pair with constrained layout."""
    from matplotlib.backends.backend_qtagg import FigureCanvasQTAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout="constrained")
    return fig, FigureCanvasQTAgg(fig)
