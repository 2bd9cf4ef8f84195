"""OpenVDB and NanoVDB readers: the file formats, level sets, sparse leaf grids."""
