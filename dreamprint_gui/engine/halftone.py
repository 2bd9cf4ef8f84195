"""Moved: halftoning now lives in :mod:`dreamprint_gui.job.halftone`. This module re-exports
its public names for older imports."""

from ..job.halftone import (  # noqa: F401
    HALFTONE_METHODS,
    MASK_VERSION,
    Halftoner,
    blue_noise_mask,
    box_for_voxel,
    fg_threshold,
    fraction_variance_ratio,
    label_rows,
    mask_shape_for_voxel,
    pick_label,
    scatter_counts,
    scatter_labels,
    tile_layout,
    uniform_hash,
)

__all__ = ["blue_noise_mask", "mask_shape_for_voxel", "uniform_hash", "Halftoner",
           "pick_label", "label_rows", "fg_threshold", "scatter_labels", "scatter_counts",
           "tile_layout", "fraction_variance_ratio", "box_for_voxel", "HALFTONE_METHODS",
           "MASK_VERSION"]
