"""Stages 2-3 of a print job: sample the source on the printer grid and label each voxel.

``layer_kernel`` (threshold -> table lookup -> density alignment -> halftone, one layer at a
time), ``dense_job`` and ``leaf_grid_job`` (the same kernel fused with sampling a dense grid or
an OpenVDB leaf grid). The vector arithmetic they share with density alignment (``vec16``,
``vector_math``, ``aligned``) is in :mod:`dreamprint_gui.core.kernels`.
"""
