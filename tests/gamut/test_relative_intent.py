"""The relative colorimetric intent: the source white onto the printable white (Bradford von
Kries, checked against the ICC.1 Bradford matrix written out here), the tables built for it, and
the pre-flight's gamut warning measured against the chosen intent's target."""

import numpy as np
import pytest

from dreamprint_gui.core.profile import load_profile
from dreamprint_gui.gamut.forward import forward_model, mixtures_xyz
from dreamprint_gui.gamut.mapping import INTENTS, RelativeMap, simplex_lattice
from dreamprint_gui.gamut.optimise import srgb_to_xyz

# ICC.1:2022 Annex E (Bradford), as published: rows map XYZ to the sharpened cone responses.
BRADFORD = np.array([[0.8951, 0.2664, -0.1614],
                     [-0.7502, 1.7135, 0.0367],
                     [0.0389, -0.0685, 1.0296]])


@pytest.fixture(scope="module")
def model():
    return forward_model(load_profile(None))


def test_white_maps_to_the_printable_white_by_bradford(model):
    r = RelativeMap.for_model(model)
    white = srgb_to_xyz(model, np.array([1.0, 1.0, 1.0]))
    np.testing.assert_allclose(r.map_xyz(white), r.print_white, rtol=1e-9)
    # an independent von Kries in the Bradford space, from the matrix above
    rng = np.random.default_rng(1)
    xyz = rng.random((50, 3))
    gain = (BRADFORD @ r.print_white) / (BRADFORD @ white)
    expect = (np.linalg.inv(BRADFORD) @ (gain[:, None] * (BRADFORD @ xyz.T))).T
    np.testing.assert_allclose(r.map_xyz(xyz), expect, rtol=1e-6, atol=1e-9)


def test_printable_white_is_the_brightest_printable_mixture(model):
    r = RelativeMap.for_model(model)
    mixes = np.concatenate([np.eye(5), np.random.default_rng(2).dirichlet(np.ones(5), 2000),
                            simplex_lattice(10)])
    assert mixtures_xyz(model, mixes)[:, 1].max() <= r.print_white[1] + 1e-12
    assert "relative" in INTENTS


def test_white_smoke_is_in_gamut_under_relative_and_honest_under_colorimetric(shared_data,
                                                                               tmp_path,
                                                                               monkeypatch):
    """hydrogen.vti prints as white smoke: under colorimetric every printed voxel is out of
    gamut (sRGB white is outside the printable gamut) and the warning says so against the
    source colour; under relative its white is the printable white: no warning."""
    from dreamprint_gui.job.plan import ConvertSettings
    from dreamprint_gui.job.preflight import preflight

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    src = str(shared_data / "volumes" / "hydrogen.vti")
    pfs = {i: preflight(ConvertSettings(source=src, height_mm=2.0, table_size=9, intent=i),
                        sample_voxels=20_000) for i in ("colorimetric", "relative")}
    col, rel = pfs["colorimetric"], pfs["relative"]
    assert col.out_of_gamut_fraction > 0.9
    (w,) = [w for w in col.warnings if w.code == "out-of-gamut"]
    assert "from the source colour" in w.message and "--intent relative" in w.message
    assert rel.intent == "relative" and rel.out_of_gamut_fraction < 0.01
    assert "out-of-gamut" not in {w.code for w in rel.warnings}
