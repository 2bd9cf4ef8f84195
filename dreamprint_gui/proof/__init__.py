"""The print proof (no Qt): the printed object rendered physically beside the source.

Modules: :mod:`.mitsuba_setup` (renderer and variant), :mod:`.km_to_rte` (KM K, S -> sigma_a,
sigma_s), :mod:`.spectral` (bands, CIE 1931 / D65), :mod:`.medium` (labels -> block fractions
-> coefficients), :mod:`.labels` (engine or job-folder labels), :mod:`.methods` (the paper's
ablations), :mod:`.cameras`, :mod:`.print_render` (Mitsuba), :mod:`.source_render`
(emission-absorption), :mod:`.compare`, :mod:`.contact_sheet`, :mod:`.runner`.
"""
