"""Profile format: round trip and validation with clear errors."""

import json

import numpy as np
import pytest

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.profile import (
    INKS,
    default_profile,
    load_profile,
    parse_mix,
    save_profile,
)


def test_default_profile_is_valid_and_round_trips(tmp_path):
    p = default_profile()
    assert p.inks == INKS and p.K.shape == (6, 36) and np.isinf(p.colour_thickness_mm)
    out = tmp_path / "p.json"
    save_profile(p, out)
    q = load_profile(out)
    np.testing.assert_array_equal(q.K, p.K)
    np.testing.assert_array_equal(q.S, p.S)
    assert q.fingerprint() == p.fingerprint()
    assert q.with_settings(layer_thickness_mm=0.027).fingerprint() != p.fingerprint()


def test_default_inks_are_opaque_within_the_papers_t_max():
    from dreamprint_gui.physics.kubelka_munk import reflectance_transmittance

    p = default_profile()
    _, T = reflectance_transmittance(p.K[:5], p.S[:5], 5.0)
    assert T.max() < 3e-3


@pytest.mark.parametrize("mutate, message", [
    (lambda d: d["K_per_mm"].pop("W"), "lacks inks"),
    (lambda d: d["K_per_mm"].__setitem__("Q", [0.0] * 36), "unknown inks"),
    (lambda d: d["S_per_mm"]["C"].pop(), "must have 36 values"),
    (lambda d: d["K_per_mm"]["M"].__setitem__(3, -1.0), "ink M at 410 nm"),
    (lambda d: d["S_per_mm"]["Y"].__setitem__(0, "NaN"), "ink Y at 380 nm"),
    (lambda d: d.__setitem__("format", "other"), "not a DreamPrint ink profile"),
])
def test_invalid_profiles_are_refused_with_the_problem(tmp_path, mutate, message):
    d = default_profile().to_json_dict()
    mutate(d)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(d))
    with pytest.raises(DreamPrintError, match=message) as err:
        load_profile(path)
    assert str(path) in str(err.value)


def test_broken_json_names_the_line(tmp_path):
    path = tmp_path / "broken.json"
    path.write_text('{\n "format": \n')
    with pytest.raises(DreamPrintError, match=r"broken.json:3: invalid JSON"):
        load_profile(path)


def test_parse_mix():
    np.testing.assert_allclose(parse_mix("C=0.2, m=0.3,W=0.5"), [0.2, 0.3, 0, 0, 0.5, 0])
    np.testing.assert_allclose(parse_mix("Cl=40%,K=60%"), [0, 0, 0, 0.6, 0, 0.4])
    with pytest.raises(DreamPrintError, match="sum to 0.9"):
        parse_mix("C=0.9")
