"""The bottom layer: types and constants every other layer shares, and nothing else.

Inks and ink profiles (:mod:`.profile`), the spectral grid (:mod:`.spectral_grid`), calibration
measurement types (:mod:`.calibration_types`), printers (:mod:`.printer`), errors
(:mod:`.errors`), shipped resources (:mod:`.resources`), and the small numba kernels that
density alignment and labelling both compile (:mod:`.kernels`). Imports no other layer.
"""
