"""Moved: the print-job conversion now lives in :mod:`dreamprint_gui.job` (``job.plan``,
``job.slab``, ``job.run``). This module re-exports its public names for older imports; patch
the module the code reads from (e.g. ``job.plan._open_source``), not this one."""

from ..job.plan import (  # noqa: F401
    DEFAULT_SLAB_VOXELS,
    ConvertProgress,
    ConvertSettings,
    JobCancelled,
    JobContext,
    prepare_job,
    replace_settings,
    source_options_for,
)
from ..job.run import run_conversion  # noqa: F401
from ..job.slab import halftone_layer, run_slab  # noqa: F401

__all__ = ["ConvertSettings", "ConvertProgress", "JobContext", "run_conversion", "prepare_job",
           "halftone_layer", "JobCancelled", "DEFAULT_SLAB_VOXELS", "run_slab",
           "source_options_for", "replace_settings"]
