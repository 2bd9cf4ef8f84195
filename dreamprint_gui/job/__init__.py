"""The print job, one stage per module (paper Fig. 2 and section 4).

plan -> sample -> label -> encode -> write -> check, with the job's material intent and its
estimate before it runs:

- :mod:`.spec`: :class:`~.spec.PrintSpec`, the print stated once (source, size, placement,
  printer, profile, rendering, halftone, seed, background, correction) that the job, the proof
  and the compensation settings hold.
- :mod:`.content`: the material intent of a source (fog or solid, ``--content``).
- :mod:`.preflight`: the job's estimate (grid, slices, disk, time, materials) and warnings.
- :mod:`.correction`: an appearance correction file a job applies (``--compensation``), and
  the check that it was made for this job.

- :mod:`.plan`: :class:`~.plan.ConvertSettings`, :func:`~.plan.prepare_job` (source, printer
  grid, colour tables, halftoner, printer) and the slab plan.
- :mod:`.run`: :func:`~.run.run_conversion`, which runs the slabs on Dask (threads, processes or
  a ``dask.distributed`` cluster, :mod:`.cluster`) and writes the manifest; :mod:`.resume`
  finishes an interrupted job (``--resume``).
- :mod:`.slab`: one slab task, :func:`~.slab.run_slab` (sample, label, encode, write), and
  :func:`~.slab.halftone_layer`.
- :mod:`.sample_label`: the compiled kernels that sample a source and label its voxels
  (``layer_kernel``; the fused dense and leaf-grid paths ``dense_job`` and ``leaf_grid_job``;
  the vectorised arithmetic they share with density alignment is
  :mod:`dreamprint_gui.core.kernels`).
- :mod:`.halftone`: the halftoning rule (blue-noise mask or hash) that picks each voxel's label.
- :mod:`.encode`: labels -> PNG slices (``png_slices``, ``label_deflate``).
- :mod:`.write`: the job folder (temporary folder, renamed into place when complete).
- :mod:`.clamp_report`: what the manifest says about voxels density alignment clamped.
- :mod:`.check`: ``dreamprint evaluate job``, reading a job folder back.
- :mod:`.wedge`: the translucency target (slabs of each ink at each thickness) as a job.

Nothing here imports Qt. Imports :mod:`dreamprint_gui.gamut`, :mod:`dreamprint_gui.physics`,
:mod:`dreamprint_gui.io` and :mod:`dreamprint_gui.core`; the proof, the command line and the GUI
stand on it.
"""
