"""Fixtures of the command-line tests."""

import pytest


@pytest.fixture
def private_cache(tmp_path_factory, monkeypatch):
    """Colour tables cached in this session's own folder (a test that builds them, not the
    user's cache): use with ``pytestmark = pytest.mark.usefixtures("private_cache")``."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path_factory.getbasetemp() / "xdg-cache"))
