"""Saunderson correction and spectral resampling."""

import numpy as np
import pytest

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.profile import default_profile
from dreamprint_gui.core.spectral_grid import PAPER_GRID, resample, uniform_grid
from dreamprint_gui.physics import saunderson
from dreamprint_gui.physics.mixture import predict


def test_saunderson_closed_form_and_inverse():
    R, T = np.array([0.0, 0.3, 0.9]), np.array([0.5, 0.2, 0.05])
    Rm, Tm = saunderson.apply(R, T, 0.04, 0.6)
    assert Rm[0] == pytest.approx(0.04)  # black layer: only the specular reflection
    assert Rm[1] == pytest.approx(0.04 + 0.96 * 0.4 * 0.3 / (1 - 0.6 * 0.3))
    back = saunderson.remove(Rm, Tm, 0.04, 0.6)
    np.testing.assert_allclose(back, (R, T), rtol=1e-12)
    np.testing.assert_allclose(saunderson.apply(R, T, 0, 0), (R, T))


def test_predict_with_saunderson_changes_only_when_asked():
    p = default_profile()
    plain = predict(p, [0, 0, 0, 0, 1, 0])
    corrected = predict(p, [0, 0, 0, 0, 1, 0], saunderson=(0.04, 0.6))
    assert np.all(corrected.R != plain.R)
    np.testing.assert_allclose(corrected.R, saunderson.apply(plain.R, plain.T, 0.04, 0.6)[0])


def test_resample_reproduces_smooth_spectra_and_refuses_gaps():
    src = uniform_grid(360, 780, 5)
    f = 0.5 + 0.3 * np.sin(src / 40.0)
    out = resample(src, f, PAPER_GRID)
    np.testing.assert_allclose(out, 0.5 + 0.3 * np.sin(PAPER_GRID / 40.0), atol=1e-6)
    uneven = np.sort(np.r_[src[::3], 401.3, 555.5])
    out2 = resample(uneven, 0.5 + 0.3 * np.sin(uneven / 40.0), PAPER_GRID)
    np.testing.assert_allclose(out2, 0.5 + 0.3 * np.sin(PAPER_GRID / 40.0), atol=1e-3)
    short = uniform_grid(400, 700, 10)
    with pytest.raises(DreamPrintError, match="covers 400-700 nm but 380-750 nm"):
        resample(short, np.ones(short.size), PAPER_GRID, source="x.csv")
    held = resample(short, np.linspace(0, 1, short.size), PAPER_GRID, extrapolate_nm=50)
    assert held[0] == pytest.approx(0, abs=1e-12) and held[-1] == pytest.approx(1)
