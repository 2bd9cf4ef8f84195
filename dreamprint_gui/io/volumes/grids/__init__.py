"""Dense grids: VTK image, MetaImage, NRRD, radiance grids, MagicaVoxel, the built-in demo."""
