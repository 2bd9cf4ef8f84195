"""Stages 2-3 of a print job: sample the source on the printer grid and label each voxel.

``layer_kernel`` (threshold -> table lookup -> density alignment -> halftone, one layer at a
time), ``dense_job`` and ``leaf_grid_job`` (the same kernel fused with sampling a dense grid or
an OpenVDB leaf grid), ``vec16`` and ``vector_math`` (the vector arithmetic they use).
"""
