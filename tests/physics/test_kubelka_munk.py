"""Kubelka-Munk forward model against closed forms and limits."""

import numpy as np
import pytest

from dreamprint_gui.physics.kubelka_munk import mix, reflectance_infinite, reflectance_transmittance


def textbook(K, S, t):
    """Eqs. 3-4 of the paper, literally (valid for K, S > 0, moderate bSt)."""
    a = (S + K) / S
    b = np.sqrt(a * a - 1)
    d = a * np.sinh(b * S * t) + b * np.cosh(b * S * t)
    return np.sinh(b * S * t) / d, b / d


def test_matches_the_papers_equations():
    rng = np.random.default_rng(0)
    K, S, t = rng.uniform(0.01, 5, 200), rng.uniform(0.01, 5, 200), rng.uniform(0.01, 2, 200)
    R, T = reflectance_transmittance(K, S, t)
    R0, T0 = textbook(K, S, t)
    np.testing.assert_allclose(R, R0, rtol=1e-12)
    np.testing.assert_allclose(T, T0, rtol=1e-12)


def test_r_infinity_is_a_minus_b():
    K, S = np.array([0.1, 1.0, 7.0]), np.array([2.0, 1.0, 0.3])
    a = 1 + K / S
    np.testing.assert_allclose(reflectance_infinite(K, S), a - np.sqrt(a * a - 1), rtol=1e-12)
    R, T = reflectance_transmittance(K, S, np.inf)
    np.testing.assert_allclose(R, a - np.sqrt(a * a - 1), rtol=1e-12)
    assert np.all(T == 0)


def test_no_absorption_conserves_energy():
    S, t = np.array([0.1, 1, 10, 1e4]), np.array([0.5, 1, 2, 3])
    R, T = reflectance_transmittance(0.0, S, t)
    np.testing.assert_allclose(R + T, 1.0, rtol=1e-14)
    np.testing.assert_allclose(T, 1 / (1 + S * t), rtol=1e-14)


def test_beer_lambert_limit_without_scattering():
    K, t = np.array([0.0, 0.3, 5.0, 800.0]), 1.7
    R, T = reflectance_transmittance(K, 0.0, t)
    assert np.all(R == 0)
    np.testing.assert_allclose(T, np.exp(-K * t), rtol=1e-14)


def test_thin_layer_and_nothing():
    R, T = reflectance_transmittance(3.0, 2.0, 0.0)
    assert R == 0 and T == 1
    R, T = reflectance_transmittance(0.0, 0.0, np.inf)
    assert R == 0 and T == 1


@pytest.mark.parametrize("t", [1e3, 1e6, 1e300])
def test_huge_optical_thickness_saturates_without_overflow(t):
    with np.errstate(all="raise"):
        R, T = reflectance_transmittance(2.0, 3.0, t)
    assert np.isfinite(R) and T == pytest.approx(0.0, abs=1e-300)
    np.testing.assert_allclose(R, reflectance_infinite(2.0, 3.0), rtol=1e-14)


def test_transmittance_decreases_with_thickness():
    t = np.linspace(0, 10, 500)
    for K, S in [(0.1, 5.0), (3.0, 0.01), (0.0, 2.0), (1.0, 1.0)]:
        R, T = reflectance_transmittance(K, S, t)
        assert np.all(np.diff(T) < 0)
        assert np.all(np.diff(R) >= -1e-15)


def test_mixing_is_linear_in_concentration():
    Ki, Si = np.array([[1.0, 2.0], [3.0, 0.5]]), np.array([[0.1, 0.2], [0.4, 0.8]])
    K, S = mix([[0.25, 0.75]], Ki, Si)
    np.testing.assert_allclose(K, [[2.5, 0.875]])
    np.testing.assert_allclose(S, [[0.325, 0.65]])


def test_compiled_scalar_twin_matches_the_array_form():
    from dreamprint_gui.physics.kubelka_munk import layer_rt

    rng = np.random.default_rng(3)
    cases = [(0.0, 0.0, np.inf), (0.0, 2.0, np.inf), (3.0, 0.0, 1.0), (0.0, 0.0, 0.5),
             (2.0, 3.0, 1e300)]
    cases += [tuple(x) for x in np.c_[10 ** rng.uniform(-4, 3, (50, 2)), rng.uniform(0, 5, 50)]]
    for k, s, t in cases:
        R, T = reflectance_transmittance(k, s, t)
        r, tr = layer_rt(k, s, t)
        assert r == pytest.approx(float(R), rel=1e-12, abs=1e-300)
        assert tr == pytest.approx(float(T), rel=1e-12, abs=1e-300)
