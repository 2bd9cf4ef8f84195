"""Shared test fixtures."""

import os
from pathlib import Path

import pytest

import dreamprint_gui  # noqa: F401  (sets the numba cache folder before numba is imported)

SHARED_DATA = Path(os.environ.get("DREAMPRINT_SAMPLE_DATA")
                   or Path(__file__).resolve().parents[2] / "shared" / "data")


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The real sample files: `../shared/data` beside the checkout, or the folder named by
    ``DREAMPRINT_SAMPLE_DATA`` (README, quick start)."""
    if not SHARED_DATA.is_dir():
        pytest.fail(f"sample data folder missing: {SHARED_DATA} (the tests read real sample "
                    "files from ../shared/data beside the checkout, or from the folder "
                    "DREAMPRINT_SAMPLE_DATA names)")
    return SHARED_DATA
