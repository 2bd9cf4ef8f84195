"""Spectral bands: the environment is the observer's white; 12 bands vs 36 samples (KM colours)."""

import numpy as np

from dreamprint_gui.core.profile import default_profile
from dreamprint_gui.physics.colorimetry import delta_E2000
from dreamprint_gui.physics.kubelka_munk import mix, reflectance_transmittance
from dreamprint_gui.proof.spectral import spectral_bands


def test_unit_radiance_is_the_white():
    p = default_profile()
    b = spectral_bands(p, 12)
    np.testing.assert_allclose(b.to_XYZ(np.ones(12)), b.observer.white_XYZ, rtol=1e-12)
    np.testing.assert_allclose(b.to_linear_srgb(np.ones(12)), [1, 1, 1], atol=1e-9)
    assert sum(len(g) for g in b.groups) == p.wavelengths_nm.size


def test_band_error_against_every_wavelength():
    p = default_profile()
    rng = np.random.default_rng(0)
    c = np.vstack([np.eye(6), rng.dirichlet(np.full(6, 0.5), 2000)])
    b = spectral_bands(p, 12)
    for t in (np.inf, 1.0):
        R, T = reflectance_transmittance(*mix(c, p.K, p.S), t)
        ref = b.observer.spectra_to_Lab(R + T)
        Rb, Tb = reflectance_transmittance(*mix(c, b.K, b.S), t)
        got = b.observer.XYZ_to_Lab(b.to_XYZ(Rb + Tb))
        de = delta_E2000(ref, got)
        assert de.mean() < 1.0 and np.percentile(de, 95) < 2.0 and de.max() < 4.0
    # more bands, smaller error: the reduction converges to the per-wavelength result
    b36 = spectral_bands(p, 36)
    R, T = reflectance_transmittance(*mix(c, p.K, p.S), 1.0)
    R36, T36 = reflectance_transmittance(*mix(c, b36.K, b36.S), 1.0)
    np.testing.assert_allclose(b36.to_XYZ(R36 + T36), b36.observer.spectra_to_XYZ(R + T),
                               atol=1e-12)
