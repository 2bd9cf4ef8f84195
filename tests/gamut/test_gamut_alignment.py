"""Density alignment (section 4.1, eqs. 11-13): exact hits, clamps, the 10 % grey bound."""

import numpy as np

from dreamprint_gui.gamut import align_density, lookup, lookup_and_align_into
from dreamprint_gui.gamut.alignment import predicted_appearance
from dreamprint_gui.physics.density import scalar_sigma
from dreamprint_gui.physics.kubelka_munk import mix


def _sigma(profile, c6):
    K, S = mix(c6, profile.K, profile.S)
    return scalar_sigma(K, S, profile.layer_thickness_mm, profile.density_t_max_mm)


def _grey_fraction(c5, c6):
    # aligned = (1 - g) C* + g X with X made of K and W only: C, M, Y shrink by (1 - g)
    cmy = c5[:, :3].sum(axis=1)
    ok = cmy > 1e-3
    return 1.0 - c6[ok, :3].sum(axis=1) / cmy[ok]


def test_alignment_hits_target_exactly_within_reach(profile, small_tables):
    rng = np.random.default_rng(4)
    rgb = rng.random((400, 3))
    target = np.exp(rng.uniform(np.log(0.1), np.log(60.0), 400))
    c5 = lookup(small_tables, rgb)
    al = align_density(small_tables, rgb, c5, target, profile)
    assert np.all(al.conc >= 0) and np.allclose(al.conc.sum(-1), 1.0, atol=1e-12)
    ok = al.clamped == 0
    assert ok.sum() > 200 and al.n_clamped_high > 0
    s = _sigma(profile, al.conc)
    np.testing.assert_allclose(s[ok], target[ok], rtol=1e-6)
    np.testing.assert_allclose(s, al.sigma, rtol=1e-9)
    lowered = ok & (target < small_tables.sigma.max()) & (al.conc[:, 5] > 0)
    # eq. 12: lowering keeps the colour inks' proportions, adding only Clear
    rho = 1.0 - al.conc[lowered, 5]
    np.testing.assert_allclose(al.conc[lowered, :5], rho[:, None] * c5[lowered], atol=1e-12)


def test_grey_never_exceeds_ten_percent_and_clamps_are_reported(profile, small_tables):
    rng = np.random.default_rng(5)
    rgb = rng.random((300, 3)) * 0.5
    c5 = lookup(small_tables, rgb)
    target = np.full(300, 1e4)  # unreachable
    al = align_density(small_tables, rgb, c5, target, profile)
    assert al.n_clamped_high == 300 and al.n_clamped_low == 0
    assert _grey_fraction(c5, al.conc).max() <= 0.1 + 1e-12
    np.testing.assert_allclose(al.max_shortfall_high, np.max(target - al.sigma))
    out = np.empty((300, 6), np.float32)
    counts = lookup_and_align_into(small_tables, rgb.astype(np.float32),
                                   target.astype(np.float32), out)
    assert counts.n_clamped_high == 300
    assert _grey_fraction(c5, out.astype(np.float64)).max() <= 0.1 + 1e-6


def test_target_below_clear_gives_pure_clear_clamped_low(profile, small_tables):
    rgb = np.random.default_rng(6).random((20, 3))
    al = align_density(small_tables, rgb, lookup(small_tables, rgb), np.zeros(20), profile)
    assert al.n_clamped_low == 20
    np.testing.assert_allclose(al.conc[:, 5], 1.0)
    clear = np.array([0, 0, 0, 0, 0, 1.0])
    np.testing.assert_allclose(al.max_shortfall_low, _sigma(profile, clear), rtol=1e-9)


def test_fused_kernel_agrees_with_exact_alignment(profile, small_tables):
    rng = np.random.default_rng(7)
    n = 2000
    rgb = rng.random((n, 3)).astype(np.float32)
    target = np.exp(rng.uniform(np.log(0.2), np.log(40.0), n)).astype(np.float32)
    rgb[0] = np.nan  # a damaged voxel must not crash or index outside the table
    out = np.empty((n, 6), np.float32)
    counts = lookup_and_align_into(small_tables, rgb, target, out)
    assert np.all(np.isfinite(out)) and out.min() >= 0
    np.testing.assert_allclose(out.sum(-1), 1.0, atol=1e-5)
    r64 = np.nan_to_num(rgb.astype(np.float64))
    exact = align_density(small_tables, r64, lookup(small_tables, r64), target, profile)
    assert abs(counts.n_clamped_high - exact.n_clamped_high) <= 0.01 * n
    ok = exact.clamped == 0
    s = _sigma(profile, out.astype(np.float64))
    rel = np.abs(s[ok] - target[ok]) / target[ok]
    assert np.median(rel) < 0.005 and rel.max() < 0.05


def test_predicted_appearance_shape_and_colour(profile, small_tables):
    rgb = np.random.default_rng(8).random((4, 5, 3))
    srgb, sigma = predicted_appearance(small_tables, profile, rgb, 5.0)
    assert srgb.shape == (4, 5, 3) and sigma.shape == (4, 5)
    assert np.all(np.isfinite(srgb)) and np.all(sigma > 0)


def test_kernel_table_carries_the_grey_rho_k_of_each_node(small_tables):
    from dreamprint_gui.gamut.alignment import K_RHOK, LANES, kernel_table
    from dreamprint_gui.gamut.grey import rho_k_for

    n = small_tables.packed.shape[0]
    lane = kernel_table(small_tables).reshape(n, n, n, LANES)[..., K_RHOK]
    a = np.arange(n) / (n - 1)
    bright = (a[:, None, None] + a[None, :, None] + a[None, None, :]) / 3.0
    np.testing.assert_array_equal(
        lane, rho_k_for(small_tables.brightness_rho_k, bright).astype(np.float32))
    assert lane.min() < 0.05 and lane.max() > 0.95  # black and white greys
