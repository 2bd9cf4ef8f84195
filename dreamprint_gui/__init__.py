"""DreamPrint: volumetric radiance content to per-voxel PolyJet material labels."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("dreamprint")
except PackageNotFoundError:  # running from a source tree that was not installed
    __version__ = "0.0.0+unknown"
