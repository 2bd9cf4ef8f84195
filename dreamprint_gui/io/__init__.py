"""Readers and writers: spectra, volumes, print jobs. Never imports Qt."""
