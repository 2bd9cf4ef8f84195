"""Colorimetry on the profile grid."""

import colour
import numpy as np
import pytest

from dreamprint_gui.core.spectral_grid import PAPER_GRID, uniform_grid
from dreamprint_gui.physics.colorimetry import delta_E2000, observer_for


@pytest.mark.parametrize(
    "grid", [uniform_grid(380, 730, 10), PAPER_GRID, uniform_grid(400, 700, 5)])
def test_perfect_white_reflector(grid):
    obs = observer_for(grid)
    np.testing.assert_allclose(obs.spectra_to_sRGB(np.ones(grid.size)), [1, 1, 1], atol=1e-12)
    np.testing.assert_allclose(obs.spectra_to_Lab(np.ones(grid.size)), [100, 0, 0], atol=1e-9)
    np.testing.assert_allclose(obs.spectra_to_XYZ(np.ones(grid.size))[1], 1.0, rtol=1e-12)


def test_perfect_black_and_grey():
    obs = observer_for(PAPER_GRID)
    np.testing.assert_allclose(obs.spectra_to_sRGB(np.zeros(PAPER_GRID.size)), 0, atol=1e-15)
    grey = obs.spectra_to_sRGB(np.full(PAPER_GRID.size, 0.18))
    assert np.ptp(grey) < 1e-12
    # sRGB OETF of 0.18 (IEC 61966-2-1): 1.055 * 0.18^(1/2.4) - 0.055
    assert grey[0] == pytest.approx(1.055 * 0.18 ** (1 / 2.4) - 0.055, rel=1e-12)


def test_agrees_with_colour_science_integration():
    grid = uniform_grid(380, 730, 10)
    rng = np.random.default_rng(0)
    spectra = rng.uniform(0, 1, (5, grid.size))
    shape = colour.SpectralShape(380, 730, 10)
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(shape)
    d65 = colour.SDS_ILLUMINANTS["D65"].copy().align(shape)
    ref = colour.msds_to_XYZ(spectra, cmfs, d65, method="Integration", shape=shape) / 100
    np.testing.assert_allclose(observer_for(grid).spectra_to_XYZ(spectra), ref, rtol=2e-3)


def test_srgb_round_trip_and_de2000_reference_pair():
    obs = observer_for(PAPER_GRID)
    rgb = np.array([[0.2, 0.5, 0.7], [1.0, 0.0, 0.0]])
    np.testing.assert_allclose(obs.XYZ_to_sRGB(obs.sRGB_to_XYZ(rgb)), rgb, atol=1e-12)
    # Sharma, Wu, Dalal (2005), test pair 1: dE00 = 2.0425
    assert delta_E2000([50, 2.6772, -79.7751], [50, 0, -82.7485]) == pytest.approx(2.0425, abs=1e-4)
