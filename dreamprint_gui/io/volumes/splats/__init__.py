"""Gaussian splats: the cloud and its PLY readers, the other exchange formats, the rasteriser."""
