"""Display colours of material labels: each ink as the active profile predicts it.

Defines :func:`label_colours`: labels 0..5 are the inks in ``INKS`` order (C, M, Y, K, W, Cl),
label 6 an empty voxel (``printer.EMPTY_LABEL``). An ink's colour is ``mixture.predict`` of the
pure ink at the profile's reference thickness, so the slice scrubber shows what the printer's
materials look like under this calibration rather than arbitrary code colours.
"""

from __future__ import annotations

import numpy as np

from ..engine.profile import INKS

__all__ = ["label_colours", "EMPTY_DISPLAY"]

EMPTY_DISPLAY = (40, 40, 46)  # an empty voxel: dark, like the viewer's background


def label_colours(profile, printer=None) -> tuple[np.ndarray, list[str]]:
    """(7, 3) uint8 display colours of labels 0..6 and their names."""
    from ..engine.mixture import predict

    pred = predict(profile, np.eye(len(INKS)))
    rgb = np.clip(np.asarray(pred.sRGB), 0, 1)
    colours = np.vstack([np.round(rgb * 255), [EMPTY_DISPLAY]]).astype(np.uint8)
    names = list(INKS) if printer is None else [
        f"{ink} ({name})" for ink, name in zip(INKS, printer.material_names, strict=True)]
    return colours, [*names, "empty"]
