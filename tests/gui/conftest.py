"""Qt test set-up shared by the GUI tests.

One QApplication serves the whole pytest process (pytest-qt creates it for the first test that
needs it), so the Qt platform is chosen once, by the session fixture below, which runs before:
pytest-xvfb has started Xvfb and set DISPLAY by then (pytest_configure), and the X11 platform
then serves plain widgets and the VTK views alike
(MEASURED.md: a QtInteractor cannot create a GL context on the offscreen platform). Without a
display (``pytest --no-xvfb`` on a headless machine) plain widget tests still run offscreen and
the tests that render with VTK fail with a message saying why (fixture ``gl_display``).
"""

from __future__ import annotations

import os

import pytest

TABLE_SIZE = 16  # small colour tables keep the suite fast; the code path is the full one


@pytest.fixture(scope="session")
def table_size() -> int:
    return TABLE_SIZE


@pytest.fixture(scope="session", autouse=True)
def _qt_platform():
    if not os.environ.get("QT_QPA_PLATFORM"):
        os.environ["QT_QPA_PLATFORM"] = "xcb" if os.environ.get("DISPLAY") else "offscreen"


@pytest.fixture(scope="session")
def _table_cache(tmp_path_factory):
    return tmp_path_factory.mktemp("cache")


@pytest.fixture(autouse=True)
def _isolated(_qt_platform, qapp, tmp_path_factory, monkeypatch, _table_cache):
    """Settings and log of each test in a private folder; colour tables cached per session;
    cyclic garbage collected on the GUI thread only, as in the application (gc_guard.py)."""
    from dreamprint_gui.gui.gc_guard import GuiThreadCollector
    from dreamprint_gui.gui.workers import wait_all

    d = tmp_path_factory.mktemp("gui-home")
    monkeypatch.setenv("XDG_CACHE_HOME", str(_table_cache))
    monkeypatch.setenv("DREAMPRINT_SETTINGS", str(d / "settings.ini"))
    monkeypatch.setenv("DREAMPRINT_LOG_DIR", str(d / "log"))
    collector = GuiThreadCollector()
    try:
        yield d
        wait_all(120000)  # no worker thread outlives its test
    finally:
        collector.stop()
        collector.deleteLater()


@pytest.fixture
def gl_display():
    """VTK views need an X display (Xvfb, started by pytest-xvfb)."""
    if os.environ.get("QT_QPA_PLATFORM") != "xcb" or not os.environ.get("DISPLAY"):
        pytest.fail("this test renders with VTK and needs an X display: run pytest with "
                    "pytest-xvfb installed (it starts Xvfb), not with --no-xvfb")
