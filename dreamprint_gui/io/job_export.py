"""Moved: the job folder writer now lives in :mod:`dreamprint_gui.job.write`. This module
re-exports its public names for older imports."""

from ..job.write import (  # noqa: F401
    CANCEL_MARKER,
    MANIFEST,
    SLICES,
    JobWriter,
    check_target,
    disk_error,
    slice_name,
)

__all__ = ["JobWriter", "check_target", "slice_name", "disk_error", "MANIFEST", "SLICES",
           "CANCEL_MARKER"]
