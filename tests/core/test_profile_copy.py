"""A profile's JSON dict is a copy: editing it leaves the profile (and the process-wide built-in
profile) as it was."""

from dreamprint_gui.core.profile import default_profile, ink_origins


def test_json_dict_does_not_alias_the_profile():
    p = default_profile()
    before = ink_origins(p)
    d = p.to_json_dict()
    d["provenance"]["ink_origin"] = {"W": "measured"}
    d["provenance"]["measurements"] = {"W": ["1 mm: w.csv"]}
    d["residuals"]["W"] = {"rms": 0.0}
    assert ink_origins(default_profile()) == before
    assert "W" not in default_profile().residuals
