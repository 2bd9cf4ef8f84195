"""Qt test set-up shared by the GUI tests.

One QApplication serves the whole pytest process (pytest-qt creates it after collection), so
the Qt platform is chosen once, here: pytest-xvfb has started Xvfb and set DISPLAY by the time
this file is imported, and the X11 platform then serves plain widgets and the VTK views alike
(MEASURED.md: a QtInteractor cannot create a GL context on the offscreen platform). Without a
display (``pytest --no-xvfb`` on a headless machine) plain widget tests still run offscreen and
the tests that render with VTK fail with a message saying why (fixture ``gl_display``).
"""

from __future__ import annotations

import os

import pytest

if not os.environ.get("QT_QPA_PLATFORM"):
    os.environ["QT_QPA_PLATFORM"] = "xcb" if os.environ.get("DISPLAY") else "offscreen"
TABLE_SIZE = 9  # small colour tables keep the suite fast; the code path is the full one


@pytest.fixture(autouse=True)
def _isolated(tmp_path_factory, monkeypatch):
    """Settings, log and colour-table cache of each test in a private folder."""
    d = tmp_path_factory.mktemp("gui-home")
    monkeypatch.setenv("DREAMPRINT_SETTINGS", str(d / "settings.ini"))
    monkeypatch.setenv("DREAMPRINT_LOG_DIR", str(d / "log"))
    yield d
    from dreamprint_gui.gui.workers import wait_all

    wait_all(120000)  # no worker thread outlives its test


@pytest.fixture
def gl_display():
    """VTK views need an X display (Xvfb, started by pytest-xvfb)."""
    if os.environ.get("QT_QPA_PLATFORM") != "xcb" or not os.environ.get("DISPLAY"):
        pytest.fail("this test renders with VTK and needs an X display: run pytest with "
                    "pytest-xvfb installed (it starts Xvfb), not with --no-xvfb")
