"""Which inks a profile measured and which it models (issue 43)."""

import json

import pytest

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.profile import (
    INKS,
    default_profile,
    ink_origins,
    load_profile,
    modelled_inks,
)


def test_built_in_profile_models_every_ink():
    assert modelled_inks(default_profile()) == list(INKS)


def test_origin_is_checked_and_older_profiles_fall_back(tmp_path):
    d = default_profile().to_json_dict()
    d["provenance"]["ink_origin"] = {"Cl": "guessed"}
    f = tmp_path / "p.json"
    f.write_text(json.dumps(d))
    with pytest.raises(DreamPrintError, match="ink_origin' must map inks"):
        load_profile(f)
    del d["provenance"]["ink_origin"]
    d["provenance"]["measurements"] = {"W": ["1 mm: w.csv"]}
    f.write_text(json.dumps(d))
    assert ink_origins(load_profile(f))["W"] == "measured"
    assert modelled_inks(load_profile(f)) == ["C", "M", "Y", "K", "Cl"]
