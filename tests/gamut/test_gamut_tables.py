"""Tables: forward model, solver round trips, simplex, brightness table (eq. 11), cache."""

import numpy as np
import pytest

from dreamprint_gui.gamut import get_tables, lookup
from dreamprint_gui.gamut.forward import forward_model, mixtures_xyz, spectrum_xyz_jac
from dreamprint_gui.gamut.grey import grey_brightness
from dreamprint_gui.gamut.optimise import solve
from dreamprint_gui.physics.colorimetry import delta_E2000, observer_for, srgb_to_lab
from dreamprint_gui.physics.mixture import mixture_colour, predict


@pytest.mark.parametrize("thickness", [np.inf, 0.5])
def test_compiled_colour_equals_mixture_colour(profile, thickness):
    p = profile.with_settings(colour_thickness_mm=thickness)
    c = np.random.default_rng(1).dirichlet(np.ones(5), 500)
    np.testing.assert_allclose(mixtures_xyz(forward_model(p), c), mixture_colour(p, c),
                               rtol=0, atol=1e-12)


def test_jacobian_matches_central_differences(profile):
    m = forward_model(profile)
    c = np.array([0.3, 0.1, 0.2, 0.05, 0.35])
    xyz, J, tmp = np.empty(3), np.empty((3, 5)), np.empty(5)
    spectrum_xyz_jac(c, m.K, m.S, m.weights, m.thickness_mm, xyz, J, tmp)
    h = 1e-6
    num = np.stack([(mixture_colour(profile, c + h * e) - mixture_colour(profile, c - h * e))
                    / (2 * h) for e in np.eye(5)], axis=-1)
    np.testing.assert_allclose(J, num, rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("objective", ["lab", "rgb"])
def test_solver_recovers_colour_of_a_known_mixture(profile, objective):
    # targets that are printable by construction: the colours of known mixtures
    rng = np.random.default_rng(2)
    known = rng.dirichlet(np.ones(5), 50)
    obs = observer_for(profile.wavelengths_nm)
    rgb = obs.XYZ_to_sRGB(mixture_colour(profile, known))
    keep = np.all((rgb >= 0) & (rgb <= 1), axis=1)
    conc, _, _ = solve(forward_model(profile), objective, rgb[keep], np.full(5, 0.2), 300)
    assert np.all(conc >= 0) and np.allclose(conc.sum(axis=1), 1.0)
    lab = predict(profile, conc).Lab
    assert delta_E2000(lab, srgb_to_lab(rgb[keep], obs)).max() < 0.05


def test_table_on_simplex_and_in_gamut_nodes_reproduce_target(profile, small_tables):
    conc = small_tables.conc.astype(np.float64)
    assert conc.shape == (9, 9, 9, 5)
    assert conc.min() >= 0.0
    np.testing.assert_allclose(conc.sum(axis=-1), 1.0, atol=1e-6)
    a = np.linspace(0, 1, 9)
    rgb = np.stack(np.meshgrid(a, a, a, indexing="ij"), -1)
    de = delta_E2000(predict(profile, conc).Lab,
                     srgb_to_lab(rgb, observer_for(profile.wavelengths_nm)))
    np.testing.assert_allclose(de, small_tables.dE2000, atol=1e-3)  # stored report is honest
    inside = de < 1.0
    assert inside.sum() > 20
    assert np.median(de[inside]) < 0.05
    # sigma per node is the density of the node's mixture (eq. 9), as predict computes it
    np.testing.assert_allclose(small_tables.sigma, predict(profile, conc).sigma_per_mm,
                               rtol=1e-5)


def test_lookup_hits_nodes_and_stays_on_simplex(small_tables):
    assert np.allclose(lookup(small_tables, [0.25, 0.5, 0.75]), small_tables.conc[2, 4, 6],
                       atol=1e-6)
    c = lookup(small_tables, np.random.default_rng(3).random((1000, 3)))
    assert c.min() >= 0 and np.allclose(c.sum(-1), 1.0, atol=1e-9)


def test_interpolation_is_exact_for_a_linear_table_and_agrees_with_the_kernel(small_tables):
    """Tetrahedral interpolation reproduces a table linear in the colour exactly (closed form),
    and ``lookup`` and the print job's kernel apply the same rule (to float32 rounding)."""
    from dreamprint_gui.gamut import lookup_and_align_into
    from dreamprint_gui.gamut.alignment import SOLID_TARGET
    from dreamprint_gui.gamut.tables import interpolate_fields

    n = 7
    a = np.random.default_rng(4).standard_normal((3, 4))
    grid = np.stack(np.meshgrid(*[np.arange(n) / (n - 1)] * 3, indexing="ij"), -1)
    rgb = np.random.default_rng(5).random((400, 3))
    rgb[:3] = [[0.5, 0.5, 0.5], [0.2, 0.2, 0.9], [1.0, 0.0, 0.3]]
    np.testing.assert_allclose(interpolate_fields(grid @ a, rgb, slice(None)), rgb @ a,
                               atol=1e-12)
    conc6 = np.empty((len(rgb), 6), np.float32)
    lookup_and_align_into(small_tables, rgb.astype(np.float32),
                          np.full(len(rgb), SOLID_TARGET, np.float32), conc6)
    np.testing.assert_allclose(conc6[:, :5], lookup(small_tables, rgb), atol=2e-6)
    assert np.all(conc6[:, 5] == 0)  # solid: no Clear


def test_tetrahedral_nodes_of_damaged_colours_stay_in_the_table():
    """NaN reads as 0 and values outside [0, 1] as the cube's faces: every node inside the
    table, weights on the simplex."""
    from dreamprint_gui.gamut.tables import tetrahedral_nodes

    n = 5
    rgb = np.array([[np.nan, 0.5, 1.0], [np.inf, -np.inf, 2.0], [-0.3, 1e-9, 1 - 1e-9],
                    [0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [0.3, 0.3, 0.3]])
    nodes, w = tetrahedral_nodes(rgb, n)
    assert nodes.min() >= 0 and nodes.max() < n ** 3
    assert np.all(w >= 0) and np.allclose(w.sum(1), 1.0)
    same, _ = tetrahedral_nodes(np.array([[0.0, 0.5, 1.0]]), n)
    np.testing.assert_array_equal(nodes[0], same[0])  # NaN -> 0


def test_brightness_table_monotonic_and_solves_eq11(profile, small_tables):
    t = small_tables.brightness_rho_k
    assert t.shape == (100,)
    assert np.all(np.diff(t) <= 0) and t.min() >= 0 and t.max() <= 1
    b = np.linspace(0, 1, 100)
    lo, hi = grey_brightness(profile, 1.0), grey_brightness(profile, 0.0)
    reach = (b > lo) & (b < hi)
    assert reach.sum() > 10
    np.testing.assert_allclose(grey_brightness(profile, t[reach]), b[reach], atol=1e-9)


def test_cache_reused_and_invalidated_by_profile_change(profile, tmp_path):
    first = get_tables(profile, "rgb", 5, cache=tmp_path)
    assert not first.cached
    again = get_tables(profile, "rgb", 5, cache=tmp_path)
    assert again.cached
    np.testing.assert_array_equal(again.packed, first.packed)
    changed = profile.with_settings(K=profile.K * 1.2)
    other = get_tables(changed, "rgb", 5, cache=tmp_path)
    assert not other.cached
    assert not np.allclose(other.sigma, first.sigma)
    # a damaged cache file is rebuilt, not trusted
    for f in tmp_path.glob("*.npz"):
        f.write_bytes(b"garbage")
    assert not get_tables(profile, "rgb", 5, cache=tmp_path).cached


@pytest.mark.parametrize("intent", ["colorimetric", "perceptual"])
def test_grid_solve_reports_progress_within_its_last_level(profile, monkeypatch, intent):
    """The table's last level (1e6 nodes at the default size, tens of seconds) reports progress
    piece by piece (issue 46: it jumped from 19 % to 80 %), with the same table as one piece."""
    from dreamprint_gui.gamut import optimise
    from dreamprint_gui.gamut.mapping import intent_map
    from dreamprint_gui.gamut.optimise import solve_grid, srgb_to_xyz

    model = forward_model(profile)
    imap = intent_map(model, intent)
    target = None if imap is None else (lambda rgb: imap.map_xyz(srgb_to_xyz(model, rgb)))
    seen: list[float] = []
    monkeypatch.setattr(optimise, "GRID_CHUNK", 1000)
    conc, cost = solve_grid(model, "de2000", 21, seen.append, target)
    monkeypatch.setattr(optimise, "GRID_CHUNK", 10 ** 9)
    whole, whole_cost = solve_grid(model, "de2000", 21, None, target)
    np.testing.assert_array_equal(conc, whole)
    np.testing.assert_array_equal(cost, whole_cost)
    # levels 5, 9, 17, 21: 21^3 = 9261 nodes in the last one, 10 pieces
    assert seen == sorted(seen) and seen[-1] == pytest.approx(0.8)
    assert len(seen) >= 4 + 9
    gaps = np.diff([0.0, *seen])
    assert gaps.max() < 0.8 * 21 ** 3 / (6 * 125 + 9 ** 3 + 17 ** 3 + 21 ** 3) / 5
