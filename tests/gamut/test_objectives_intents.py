"""Table objectives (srgb, cielab, de2000) and rendering intents (colorimetric, perceptual)."""

import json

import numpy as np
import pytest

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.profile import load_profile, save_profile
from dreamprint_gui.gamut import align_density, get_tables, lookup
from dreamprint_gui.gamut.evaluation import adjacent_jumps, lattice_best
from dreamprint_gui.gamut.forward import forward_model, mixtures_lab, mixtures_xyz
from dreamprint_gui.gamut.mapping import PerceptualMap, cam16_ucs
from dreamprint_gui.gamut.optimise import (
    OBJECTIVES,
    de2000_residual,
    solve,
    solve_xyz,
    srgb_to_xyz,
    target_coords,
)
from dreamprint_gui.gamut.tables import resolve_choice
from dreamprint_gui.physics.colorimetry import delta_E2000, observer_for, srgb_to_lab
from dreamprint_gui.physics.mixture import mixture_colour, predict

# Sharma, Wu & Dalal (2005), Table 1: pairs 1, 7, 17, 25 and their published dE00.
SHARMA = [((50.0, 2.6772, -79.7751), (50.0, 0.0, -82.7485), 2.0425),
          ((50.0, 0.0, 0.0), (50.0, -1.0, 2.0), 2.3669),
          ((50.0, 2.5, 0.0), (73.0, 25.0, -18.0), 27.1492),
          ((60.2574, -34.0099, 36.2677), (60.4626, -34.1751, 39.4387), 1.2644)]


@pytest.mark.parametrize("lab1, lab2, expected", SHARMA)
def test_de2000_residual_matches_sharma_table(lab1, lab2, expected):
    r = np.empty(3)
    assert np.sqrt(de2000_residual(np.array(lab1), np.array(lab2), r)) == pytest.approx(
        expected, abs=5e-5)
    assert np.dot(r, r) == pytest.approx(expected ** 2, rel=1e-4)  # |r|^2 = dE00^2


def test_de2000_residual_matches_colour_science_on_random_pairs():
    rng = np.random.default_rng(4)
    a = rng.uniform([0, -90, -90], [100, 90, 90], (500, 3))
    b = a + rng.normal(0, 8, a.shape)
    r = np.empty(3)
    mine = np.array([np.sqrt(de2000_residual(x, y, r)) for x, y in zip(a, b, strict=True)])
    np.testing.assert_allclose(mine, delta_E2000(a, b), atol=1e-9)


def _printable_targets(profile, n=40, seed=5):
    known = np.random.default_rng(seed).dirichlet(np.ones(5), n)
    rgb = observer_for(profile.wavelengths_nm).XYZ_to_sRGB(mixture_colour(profile, known))
    return rgb[np.all((rgb >= 0) & (rgb <= 1), axis=1)]


@pytest.mark.parametrize("objective", OBJECTIVES)
def test_every_objective_reproduces_a_printable_target(profile, objective):
    rgb = _printable_targets(profile)
    assert len(rgb) > 10
    conc, _, _ = solve(forward_model(profile), objective, rgb, np.full(5, 0.2), 300)
    de = delta_E2000(predict(profile, conc).Lab,
                     srgb_to_lab(rgb, observer_for(profile.wavelengths_nm)))
    assert de.max() < 0.1


def _hue_deg(ucs):
    return np.degrees(np.arctan2(ucs[..., 2], ucs[..., 1]))


def _hue_diff(a, b):
    return np.abs((a - b + 180.0) % 360.0 - 180.0)


# saturated sRGB colours, far outside the printable gamut
OUTSIDE = np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0], [0, 1.0, 1.0], [1.0, 0, 1.0],
                    [0.2, 0.9, 0.3]])


def test_perceptual_mapping_keeps_hue_and_lands_in_gamut(profile):
    model = forward_model(profile)
    xyz = srgb_to_xyz(model, OUTSIDE)
    colorimetric, _, _ = solve_xyz(model, "cielab", xyz, np.full(5, 0.2), 300)
    de_clip = delta_E2000(mixtures_lab(model, colorimetric), target_coords(model, "cielab", xyz))
    assert de_clip.min() > 5.0  # really out of gamut
    mapped = PerceptualMap.for_model(model).map_xyz(xyz)
    src, dst = cam16_ucs(xyz, model.white), cam16_ucs(mapped, model.white)
    assert _hue_diff(_hue_deg(src), _hue_deg(dst)).max() < 1e-6  # hue kept exactly
    assert np.all(np.hypot(dst[:, 1], dst[:, 2]) < np.hypot(src[:, 1], src[:, 2]))
    for objective in OBJECTIVES:  # the mapped colour is printable: reproduced exactly
        conc, _, _ = solve_xyz(model, objective, mapped, np.full(5, 0.2), 300)
        de = delta_E2000(mixtures_lab(model, conc), target_coords(model, "cielab", mapped))
        assert de.max() < 0.5, objective
        printed = cam16_ucs(mixtures_xyz(model, conc), model.white)
        assert _hue_diff(_hue_deg(printed), _hue_deg(src)).max() < 1.5, objective


def test_perceptual_keeps_the_order_of_a_gradient(profile):
    model = forward_model(profile)
    t = np.linspace(0.0, 1.0, 41)[:, None]
    ramp = (1 - t) * np.array([0.5, 0.5, 0.5]) + t * np.array([0.0, 0.0, 1.0])  # grey -> blue
    pm = PerceptualMap.for_model(model)
    dst = cam16_ucs(pm.map_xyz(srgb_to_xyz(model, ramp)), model.white)
    src = cam16_ucs(srgb_to_xyz(model, ramp), model.white)
    m_dst, m_src = np.hypot(dst[:, 1], dst[:, 2]), np.hypot(src[:, 1], src[:, 2])
    assert np.all(np.diff(m_dst) > 0)  # order along the ramp kept (no clipping flat)
    assert m_dst[-1] < m_src[-1]
    # in-gamut, low-chroma colours stay nearly where they were (knee at 90 %)
    assert delta_E2000(target_coords(model, "cielab", pm.map_xyz(srgb_to_xyz(model, ramp[:1]))),
                       target_coords(model, "cielab", srgb_to_xyz(model, ramp[:1]))) < 8.0


def test_perceptual_table_prints_source_hue(profile, tmp_path):
    t = get_tables(profile, "de2000", 5, cache=tmp_path, intent="perceptual")
    assert t.intent == "perceptual" and t.objective == "de2000"
    model = forward_model(profile)
    src = cam16_ucs(srgb_to_xyz(model, OUTSIDE[:5]), model.white)  # cube corners: table nodes
    printed = cam16_ucs(mixtures_xyz(model, lookup(t, OUTSIDE[:5])), model.white)
    assert _hue_diff(_hue_deg(printed), _hue_deg(src)).max() < 1.5
    again = get_tables(profile, "de2000", 5, cache=tmp_path, intent="perceptual")
    assert again.cached and again.intent == "perceptual"
    other = get_tables(profile, "de2000", 5, cache=tmp_path, intent="colorimetric")
    assert not other.cached and not np.allclose(other.conc, t.conc)


@pytest.mark.parametrize("objective,intent", [("srgb", "perceptual"), ("de2000", "colorimetric")])
def test_alignment_and_grey_work_with_every_objective(profile, tmp_path, objective, intent):
    t = get_tables(profile, objective, 5, cache=tmp_path, intent=intent)
    rgb = np.random.default_rng(6).random((200, 3))
    target = np.full(200, 3.0)
    al = align_density(t, rgb, lookup(t, rgb), target, profile)
    ok = al.clamped == 0
    assert ok.sum() > 100
    np.testing.assert_allclose(al.sigma[ok], 3.0, rtol=1e-6)
    assert np.all(np.diff(t.brightness_rho_k) <= 0)


def test_lattice_best_is_zero_at_lattice_colours(profile):
    c = np.zeros((3, 6))
    c[0, [0, 4]] = 0.5  # C/W 50/50, K/W 25/75, M/Y/W 20/30/50: all on the 5 % lattice
    c[1, [3, 4]] = 0.25, 0.75
    c[2, [1, 2, 4]] = 0.2, 0.3, 0.5
    rgb = predict(profile, c).sRGB  # unclipped: C/W 50/50 lies outside sRGB
    np.testing.assert_allclose(lattice_best(profile, rgb), 0.0, atol=1e-6)


def test_adjacent_jumps_of_a_uniform_table_are_zero(small_tables, profile):
    from dataclasses import replace

    flat = small_tables.packed.copy()
    flat[..., :5] = flat[4, 4, 4, :5]
    rep = adjacent_jumps(replace(small_tables, packed=flat), profile)
    assert rep["max"] == pytest.approx(0.0, abs=1e-9) and rep["target_max"] > 1.0


def test_profile_table_settings_round_trip_and_choice(profile, tmp_path):
    p = profile.with_settings(table_settings={"objective": "srgb", "intent": "perceptual"})
    assert p.fingerprint() == profile.fingerprint()  # the cache key carries them separately
    path = tmp_path / "p.json"
    save_profile(p, path)
    back = load_profile(path)
    assert back.table_settings == {"objective": "srgb", "intent": "perceptual"}
    assert resolve_choice(back) == ("srgb", "perceptual")
    assert resolve_choice(back, "de2000", None) == ("de2000", "perceptual")
    assert resolve_choice(profile) == ("de2000", "colorimetric")
    assert resolve_choice(profile, "lab") == ("cielab", "colorimetric")  # former name
    d = json.loads(path.read_text())
    d["table"] = {"intent": "saturation"}
    path.write_text(json.dumps(d))
    with pytest.raises(DreamPrintError, match="intent 'saturation'"):
        load_profile(path)
