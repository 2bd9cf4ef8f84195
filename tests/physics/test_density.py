"""Density: exponential fit (eq. 8) and scalar sigma (eq. 9, sign corrected)."""

import numpy as np
import pytest

from dreamprint_gui.physics.density import (
    exp_fit_errors,
    fit_sigma_per_wavelength,
    scalar_sigma,
    sigma_from_sigma_hat,
)


@pytest.mark.parametrize("exact", [True, False])
def test_pure_exponential_is_fitted_exactly(exact):
    K = np.array([1e-3, 0.2, 3.0, 40.0, 900.0])
    np.testing.assert_allclose(fit_sigma_per_wavelength(K, 0.0, exact=exact), K, rtol=1e-12)


def test_fit_minimises_the_integral_of_eq_8():
    K, S, t_max = 2.0, 1.5, 5.0
    from dreamprint_gui.physics.kubelka_munk import reflectance_transmittance

    t = np.linspace(0, t_max, 200001)
    _, T = reflectance_transmittance(K, S, t)

    def cost(sig):
        return np.trapezoid((np.exp(-sig * t) - T) ** 2, t)

    best = float(fit_sigma_per_wavelength(K, S, t_max, exact=True))
    assert cost(best) < cost(best * 1.001) and cost(best) < cost(best * 0.999)
    assert np.sqrt(K * K + 2 * K * S) < best < K + S  # between asymptotic and initial slope


def test_tabulated_fit_agrees_with_exact_solver():
    rng = np.random.default_rng(1)
    K = 10 ** rng.uniform(-4, 3, 3000)
    S = 10 ** rng.uniform(-4, 3, 3000)
    exact = fit_sigma_per_wavelength(K, S, exact=True)
    fast = fit_sigma_per_wavelength(K, S)
    np.testing.assert_allclose(fast, exact, rtol=1e-4)


def test_scalar_sigma_of_a_grey_medium_is_its_sigma():
    sigma = 7.5
    assert sigma_from_sigma_hat(np.full(36, sigma), 0.014) == pytest.approx(sigma, rel=1e-12)


def test_scalar_sigma_is_the_mean_transmittance_density():
    sh = np.array([1.0, 10.0, 100.0])
    dt = 0.014
    mean_t = np.mean(np.exp(-sh * dt))
    s = sigma_from_sigma_hat(sh, dt)
    assert s > 0
    assert np.exp(-s * dt) == pytest.approx(mean_t, rel=1e-12)


def test_scalar_sigma_positive_and_increasing_with_concentration():
    K = np.linspace(0.1, 5, 36)
    S = np.full(36, 0.5)
    s1, s2 = scalar_sigma(K, S, 0.014), scalar_sigma(2 * K, 2 * S, 0.014)
    assert 0 < s1 < s2


def test_table1_error_zero_for_an_absorber_and_small_for_weak_scatter():
    mean, worst = exp_fit_errors(np.array([[5.0] * 4, [5.0] * 4]),
                                 np.array([[0.0] * 4, [0.05] * 4]))
    assert mean[0] < 1e-12 and worst[0] < 1e-12
    assert 0 < mean[1] < 1e-2
