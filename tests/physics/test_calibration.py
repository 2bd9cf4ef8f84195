"""Calibration round trips: forward model -> inversion gives back K and S."""

import numpy as np
import pytest

from dreamprint_gui.core.calibration_types import LayerMeasurement
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.profile import INKS, default_profile
from dreamprint_gui.physics.calibration import calibrate_profile, fit_ink, invert_closed_form
from dreamprint_gui.physics.chart_calibration import _Model, fit_chart
from dreamprint_gui.physics.kubelka_munk import mix, reflectance_infinite, reflectance_transmittance

RNG = np.random.default_rng(42)
K_TRUE = 10 ** RNG.uniform(-2, 1.5, 36)
S_TRUE = 10 ** RNG.uniform(-2, 1.5, 36)


def test_closed_form_inverts_the_forward_model():
    for t in (0.05, 0.3, 2.0):
        R, T = reflectance_transmittance(K_TRUE, S_TRUE, t)
        K, S = invert_closed_form(R, T, t)
        np.testing.assert_allclose(K, K_TRUE, rtol=1e-6)
        np.testing.assert_allclose(S, S_TRUE, rtol=1e-6)


def test_closed_form_limits_and_impossible_data():
    K, S = invert_closed_form(0.0, np.exp(-0.6), 0.2)  # no scattering: Beer-Lambert
    assert K == pytest.approx(3.0) and S == 0
    K, S = invert_closed_form(0.25, 0.75, 1.0)  # no absorption: R = St / (1 + St)
    assert K == pytest.approx(0.0, abs=1e-9) and S == pytest.approx(1 / 3)
    K, S = invert_closed_form(0.7, 0.6, 1.0)  # R + T > 1
    assert np.isnan(K) and np.isnan(S)


def test_levenberg_marquardt_over_several_thicknesses():
    layers = [LayerMeasurement("C", t, *reflectance_transmittance(K_TRUE, S_TRUE, t), "synthetic")
              for t in (0.05, 0.2, 0.8)]
    fit = fit_ink(layers, 36)
    np.testing.assert_allclose(fit.K, K_TRUE, rtol=1e-6)
    np.testing.assert_allclose(fit.S, S_TRUE, rtol=1e-6)
    assert fit.method == "Levenberg-Marquardt"
    assert np.nanmax(fit.rms_R) < 1e-9


def test_one_percent_noise_degrades_gracefully():
    rng = np.random.default_rng(7)
    layers = []
    for t in (0.05, 0.2, 0.8):
        R, T = reflectance_transmittance(K_TRUE, S_TRUE, t)
        layers.append(LayerMeasurement("M", t, R * (1 + 0.01 * rng.standard_normal(36)),
                                       T * (1 + 0.01 * rng.standard_normal(36)), "noisy"))
    fit = fit_ink(layers, 36)
    assert np.median(np.abs(fit.K / K_TRUE - 1)) < 0.05
    assert np.median(np.abs(fit.S / S_TRUE - 1)) < 0.05
    assert np.all(np.isfinite(fit.K)) and np.all(fit.K >= 0) and np.all(fit.S >= 0)


def test_calibrate_profile_keeps_unmeasured_inks_and_rejects_reflectance_only():
    base = default_profile()
    i = INKS.index("Y")
    R, T = reflectance_transmittance(base.K[i] * 1.5, base.S[i] * 0.5, 0.3)
    prof, fits = calibrate_profile([LayerMeasurement("Y", 0.3, R, T, "y.csv")], base, "test")
    np.testing.assert_allclose(prof.K[i], base.K[i] * 1.5, rtol=1e-6)
    np.testing.assert_allclose(prof.K[INKS.index("C")], base.K[INKS.index("C")])
    assert "C" in prof.provenance["inks_from_base_profile"]
    with pytest.raises(DreamPrintError, match="no transmittance"):
        calibrate_profile([LayerMeasurement("Y", 0.3, R, None, "y.csv")], base)


def test_chart_calibration_recovers_known_inks():
    base = default_profile()
    rng = np.random.default_rng(3)
    used = [0, 1, 2, 3, 4]
    model = _Model(base, used, 3, anchor=4)
    K_true, S_true = model.unpack(rng.normal(0, 0.15, model.n_params))
    recipes = np.zeros((50, 6))
    recipes[:, :5] = rng.dirichlet(np.full(5, 0.5), 50)
    R = reflectance_infinite(*mix(recipes, K_true, S_true))
    fit = fit_chart(base, recipes, R, n_basis=3, ridge=1e-4, folds=2)
    visible = (base.wavelengths_nm >= 420) & (base.wavelengths_nm <= 680)
    np.testing.assert_allclose(fit.profile.K[:5, visible], K_true[:5, visible], rtol=1e-2)
    np.testing.assert_allclose(fit.profile.S[:5, visible], S_true[:5, visible], rtol=1e-2)
    assert fit.cv_dE2000.mean() < 0.05 < fit.base_dE2000.mean()


def test_leave_one_thickness_out_predicts_each_thickness_from_the_others():
    """Noise-free layers: every held-out prediction is the measurement (round trip). A layer
    offset by +0.01 in R is predicted from the exact others, so its held-out R error is that
    offset and its T error zero; the others' fits include the offset layer and are off."""
    from dreamprint_gui.physics.calibration import exact_by_construction, leave_one_thickness_out

    ts = (0.05, 0.2, 0.8)
    layers = [LayerMeasurement("C", t, *reflectance_transmittance(K_TRUE, S_TRUE, t), "synthetic")
              for t in ts]
    held, notes = leave_one_thickness_out(layers, 36)
    assert [h.thickness_mm for h in held] == list(ts) and notes == []
    assert held[0].fitted_on == [0.2, 0.8]
    for h in held:
        assert h.overall_R < 1e-7 and h.overall_T < 1e-7

    R08, T08 = reflectance_transmittance(K_TRUE, S_TRUE, 0.8)
    layers[2] = LayerMeasurement("C", 0.8, R08 + 0.01, T08, "offset")
    held, _ = leave_one_thickness_out(layers, 36)
    np.testing.assert_allclose(held[2].rms_R, 0.01, rtol=1e-5)
    assert held[2].overall_T < 1e-7
    assert held[2].overall_R == pytest.approx(0.01, rel=1e-5)

    one = layers[:1]
    assert leave_one_thickness_out(one, 36)[0] == [] and exact_by_construction(one)
    assert not exact_by_construction([LayerMeasurement("C", 0.2, None, T08, "T only")])
    # a thickness whose remaining layers have no T cannot be held out, and is named
    r_only = [LayerMeasurement("Y", 0.2, *reflectance_transmittance(K_TRUE, S_TRUE, 0.2)),
              LayerMeasurement("Y", 0.5, reflectance_transmittance(K_TRUE, S_TRUE, 0.5)[0], None)]
    held, notes = leave_one_thickness_out(r_only, 36)
    assert [h.thickness_mm for h in held] == [0.5] and "0.2 mm not held out" in notes[0]


def test_inconsistent_opaque_layers_keep_k_and_s_finite():
    """Two thicknesses both opaque at long wavelengths (T ~ 1e-13) with R disagreeing by 0.01:
    the data fix K/S there and nothing else; the fit stays at the closed-form scale instead of
    running off to K, S ~ 1e9 along the flat valley (the profile refused those)."""
    K = np.linspace(1.0, 120.0, 36)
    S = np.full(36, 1.5)
    R4, T4 = reflectance_transmittance(K, S, 0.4)
    R8, T8 = reflectance_transmittance(K, S, 0.8)
    fit = fit_ink([LayerMeasurement("C", 0.4, R4, T4), LayerMeasurement("C", 0.8, R8 + 0.01, T8)],
                  36)
    assert np.all(np.isfinite(fit.K)) and np.all(np.isfinite(fit.S))
    assert np.all(fit.K < 3 * K) and np.all(fit.K > K / 3)
    assert np.all(fit.S < 10 * S)
