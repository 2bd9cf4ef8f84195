"""The print job, one stage per module (paper Fig. 2 and section 4).

plan -> sample -> label -> encode -> write -> check:

- :mod:`.plan`: :class:`~.plan.ConvertSettings`, :func:`~.plan.prepare_job` (source, printer
  grid, colour tables, halftoner, printer) and the slab plan.
- :mod:`.run`: :func:`~.run.run_conversion`, which runs the slabs on Dask (threads, processes or
  a ``dask.distributed`` cluster) and writes the manifest.
- :mod:`.slab`: one slab task, :func:`~.slab.run_slab` (sample, label, encode, write), and
  :func:`~.slab.halftone_layer`.
- :mod:`.sample_label`: the compiled kernels that sample a source and label its voxels
  (``layer_kernel``; the fused dense and leaf-grid paths ``dense_job`` and ``leaf_grid_job``;
  ``vec16`` and ``vector_math``, the vectorised arithmetic they use).
- :mod:`.halftone`: the halftoning rule (blue-noise mask or hash) that picks each voxel's label.
- :mod:`.encode`: labels -> PNG slices (``png_slices``, ``label_deflate``).
- :mod:`.write`: the job folder (temporary folder, renamed into place when complete).
- :mod:`.check`: ``dreamprint check``, reading a job folder back.

Nothing here imports Qt. This package imports no submodule eagerly, so that
``engine.gamut`` can use :mod:`.sample_label.vec16` without an import circle.
"""
