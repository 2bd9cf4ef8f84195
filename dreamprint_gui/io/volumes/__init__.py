"""Volume sources sampled onto the printer grid, slab by slab (issue 6).

Public API: :class:`PrintGrid`, :func:`grid_for_source`, :class:`VolumeSource` (from
:mod:`.base`, the protocol every reader implements) and :func:`open_source` (from
:mod:`.registry`, the source kinds; it imports the readers, which import only the base).
One module per format: :mod:`.openvdb`, :mod:`.nanovdb`, :mod:`.vtkimage`, :mod:`.radiance`,
:mod:`.splats`, :mod:`.magicavoxel`, :mod:`.demo`; samplers in :mod:`.sampling`, dense grids
in :mod:`.dense`.
"""

from dreamprint_gui.io.volumes.base import PrintGrid, VolumeSource, grid_for_source
from dreamprint_gui.io.volumes.registry import open_source

__all__ = ["PrintGrid", "VolumeSource", "grid_for_source", "open_source"]
