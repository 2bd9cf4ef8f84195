"""Small colour tables shared by the gamut tests (built once per session in a temp cache)."""

import pytest

from dreamprint_gui.core.profile import default_profile
from dreamprint_gui.gamut import get_tables


@pytest.fixture(scope="session")
def profile():
    return default_profile()


@pytest.fixture(scope="session")
def small_tables(profile, tmp_path_factory):
    return get_tables(profile, "lab", 9, cache=tmp_path_factory.mktemp("gamut-cache"))
