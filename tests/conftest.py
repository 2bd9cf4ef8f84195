"""Shared test fixtures."""

from pathlib import Path

import pytest

import dreamprint_gui  # noqa: F401  (sets the numba cache folder before numba is imported)

SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """`../shared/data` beside the checkout (real sample files)."""
    if not SHARED_DATA.is_dir():
        pytest.fail(f"sample data folder missing: {SHARED_DATA}")
    return SHARED_DATA
