"""Numba helpers shared by density alignment (:mod:`dreamprint_gui.gamut.alignment`) and the
print job's labelling kernels (:mod:`dreamprint_gui.job.sample_label`): 16-lane vectors
(:mod:`.vec16`), IEEE-exact elementary functions (:mod:`.vector_math`) and cache-line aligned
arrays (:mod:`.aligned`)."""
