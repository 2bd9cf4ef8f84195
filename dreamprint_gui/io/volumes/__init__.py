"""Volume sources sampled onto the printer grid, slab by slab (issue 6).

Public API: :class:`PrintGrid`, :func:`grid_for_source`, :class:`VolumeSource` (from
:mod:`.base`, the protocol every reader implements) and :func:`open_source` (from
:mod:`.registry`, the source kinds; it imports the readers, which import only the base).

Readers, one folder per family:

- :mod:`.vdb`, OpenVDB and NanoVDB: :mod:`.vdb.openvdb` (over :mod:`.vdb.vdb_file`, the file
  format in numpy), :mod:`.vdb.nanovdb`; level sets as density in :mod:`.vdb.level_set`; the
  leaves densified and sampled a layer at a time in :mod:`.vdb.leaf_grid`.
- :mod:`.splats`, Gaussian splats: :mod:`.splats.cloud` (the cloud; PLY, compressed PLY),
  :mod:`.splats.formats` (``.splat``, ``.ksplat``, SPZ, SOG), rasterised by
  :mod:`.splats.raster`.
- :mod:`.ingp`, InstantNGP: :mod:`.ingp.snapshot` (snapshots: :mod:`.ingp.kernels`,
  :mod:`.ingp.encode`, :mod:`.ingp.occupancy`) and :mod:`.ingp.exports` (its RGBA PNG slice
  and raw volume exports).
- :mod:`.grids`, dense grids: :mod:`.grids.vtkimage` (VTK XML and legacy, MetaImage; NRRD in
  :mod:`.grids.nrrd`), :mod:`.grids.radiance` (NeRF/radiance grids as ``.npz`` or EXR
  stacks), :mod:`.grids.magicavoxel` (``.vox``), :mod:`.grids.demo` (the built-in planet).

Shared, at the top: :mod:`.base` (the protocol, the printer grid), :mod:`.registry` (which
reader opens which file), :mod:`.orient` (``--up``, ``--rotate``, ``--fit``; :mod:`.stand`, the
resting side of a source whose up is a guess), :mod:`.dense`
(a source held as a regular grid: the grids, InstantNGP's exports) and :mod:`.dense_sampler`
(its trilinear sampler), :mod:`.sampling` (sparse leaf blocks, Gaussian kernels),
:mod:`.srgb_encode` (linear -> sRGB samples).
"""

from dreamprint_gui.io.volumes.base import PrintGrid, VolumeSource, grid_for_source
from dreamprint_gui.io.volumes.registry import open_source

__all__ = ["PrintGrid", "VolumeSource", "grid_for_source", "open_source"]
