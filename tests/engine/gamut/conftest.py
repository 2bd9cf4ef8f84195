"""Small colour tables shared by the gamut tests (built once per session in a temp cache)."""

import pytest

from dreamprint_gui.engine.gamut import get_tables
from dreamprint_gui.engine.profile import default_profile


@pytest.fixture(scope="session")
def profile():
    return default_profile()


@pytest.fixture(scope="session")
def small_tables(profile, tmp_path_factory):
    return get_tables(profile, "lab", 9, cache=tmp_path_factory.mktemp("gamut-cache"))
