"""Volume sources sampled onto the printer grid, slab by slab (issue 6).

Public API: :class:`PrintGrid`, :func:`grid_for_source`, :class:`VolumeSource` (from
:mod:`.base`, the protocol every reader implements) and :func:`open_source` (from
:mod:`.registry`, the source kinds; it imports the readers, which import only the base).

Readers, by family:

- OpenVDB and NanoVDB: :mod:`.openvdb` (over :mod:`.vdb_file`, the file format in numpy),
  :mod:`.nanovdb`; level sets as density in :mod:`.level_set`; sparse sampling in
  :mod:`.sampling` and :mod:`.leaf_grid`.
- Gaussian splats: :mod:`.splats` (PLY, compressed PLY), :mod:`.splat_formats` (``.splat``,
  ``.ksplat``, SPZ, SOG), rasterised by :mod:`.splat_raster`.
- InstantNGP: :mod:`.ingp` (snapshots: :mod:`.ingp_kernels`, :mod:`.ingp_encode`,
  :mod:`.ingp_occupancy`) and :mod:`.ingp_volume` (its RGBA PNG slice and raw volume exports).
- Dense grids: :mod:`.vtkimage` (VTK XML and legacy, MetaImage; NRRD in :mod:`.nrrd`),
  :mod:`.radiance` (NeRF/radiance grids as ``.npz`` or EXR stacks), :mod:`.magicavoxel`
  (``.vox``), :mod:`.demo` (the built-in planet); held by :mod:`.dense`, sampled by
  :mod:`.dense_sampler`.

Shared: :mod:`.orient` (``--up``, ``--rotate``, ``--fit``), :mod:`.srgb_encode` (linear ->
sRGB samples).
"""

from dreamprint_gui.io.volumes.base import PrintGrid, VolumeSource, grid_for_source
from dreamprint_gui.io.volumes.registry import open_source

__all__ = ["PrintGrid", "VolumeSource", "grid_for_source", "open_source"]
