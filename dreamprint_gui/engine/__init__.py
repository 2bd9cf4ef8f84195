"""Physics, calibration, tables, halftoning and pipelines. Never imports Qt."""
