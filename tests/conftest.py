"""Shared test fixtures."""

import functools
import os
import subprocess
from pathlib import Path

import pytest

import dreamprint_gui  # noqa: F401  (sets the numba cache folder before numba is imported)
from dreamprint_gui.proof import thick_patch

# A surface's or hg phase's thick-patch curve (proof/thick_patch.py) is rendered the first time
# it is needed: in tests at 32 spp (a few seconds; cached under its own key, apart from the
# product's 256 spp curves). Tests checking a curve's accuracy set their own.
thick_patch.CURVE_SPP = 32

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


@functools.cache
def _find_openvdb_python() -> str | None:
    py = os.environ.get("DREAMPRINT_TEST_OPENVDB_PYTHON", "/usr/bin/python3")
    try:
        ok = subprocess.run([py, "-I", "-c", "import pyopenvdb"], capture_output=True,
                            check=False).returncode == 0
    except OSError:
        ok = False
    return py if ok else None


@pytest.fixture(scope="session")
def openvdb_python() -> str:
    """An interpreter with OpenVDB's own Python module (Debian's python3-openvdb under
    /usr/bin/python3, or DREAMPRINT_TEST_OPENVDB_PYTHON): the tests write .vdb files with it
    and cross-check the product's reader against it. Skips the test when there is none (the
    product itself needs no OpenVDB)."""
    py = _find_openvdb_python()
    if py is None:
        pytest.skip("no Python with pyopenvdb here (apt-get install python3-openvdb): the "
                    "OpenVDB cross-check and the files it writes are unavailable")
    return py


@pytest.fixture
def idle_machine(monkeypatch):
    """The machine taken as idle by the pre-flight's estimates (``job.prepare_time.
    machine_slowdown`` = 1): a command's ``opening NAME: about T ...`` notice, said when
    opening a source is estimated at 2 s or more *now*, then depends on the source alone, not
    on the load (a shared 2-core machine at load 15 announced 0 MB files on stderr, where
    tests read the one line of an error)."""
    from dreamprint_gui.job import prepare_time

    monkeypatch.setattr(prepare_time, "machine_slowdown", lambda *a, **k: 1.0)
