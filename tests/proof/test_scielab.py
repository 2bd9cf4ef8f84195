"""S-CIELAB against its published definition (Zhang & Wandell 1996, the authors' filters)."""

import math

import numpy as np
import pytest

from dreamprint_gui.core.profile import default_profile
from dreamprint_gui.physics.colorimetry import delta_E2000, observer_for
from dreamprint_gui.proof.scielab import (
    channel_kernel,
    samples_per_degree,
    scielab_de2000,
    scielab_filter,
)


@pytest.fixture(scope="module")
def obs():
    return observer_for(default_profile().wavelengths_nm)


@pytest.mark.parametrize("spd", [1.0, 7.3, 41.0, 224.0])
def test_kernels_sum_to_one(spd):
    for c in range(3):
        assert channel_kernel(c, spd).sum() == pytest.approx(1.0, abs=1e-12)


def test_kernel_matches_the_published_point_spread():
    # the released code's Gaussian: exp(-(2 sqrt(ln 2) x / h)^2), h the full width at half
    # maximum in samples; written out here point-sampled, the sum of weighted unit-sum Gaussians
    spd = 224.0
    half = 111
    x = np.arange(-half, half + 1)
    published = {0: [(0.05, 1.00327), (0.225, 0.114416), (7.0, -0.117686)],
                 1: [(0.0685, 0.616725), (0.826, 0.383275)],
                 2: [(0.0920, 0.567885), (0.6451, 0.432115)]}
    for c, parts in published.items():
        ref = np.zeros((x.size, x.size))
        for h, w in parts:
            g = np.exp(-(2 * math.sqrt(math.log(2)) * x / (h * spd)) ** 2)
            g /= g.sum()
            ref += w * np.outer(g, g)
        k = channel_kernel(c, spd)
        assert k.shape == ref.shape
        # pixel-integrated taps vs point samples: 1/(24 sigma^2) per axis, 0.4 % at the peak
        assert np.abs(k - ref).max() < 6e-3 * ref.max()
        assert np.abs(k - ref).sum() < 0.01


def test_samples_per_degree():
    # 1 degree at 500 mm is 8.727 mm
    assert samples_per_degree(8.7269, 500.0) == pytest.approx(1.0, rel=1e-4)
    assert samples_per_degree(0.1, 500.0) == pytest.approx(87.27, rel=1e-3)


def test_uniform_images_give_the_per_pixel_difference(obs):
    w = obs.white_XYZ
    a = np.broadcast_to(w * 0.4, (24, 24, 3))
    b = np.broadcast_to(np.array([0.30, 0.22, 0.35]) * w, (24, 24, 3))
    np.testing.assert_allclose(scielab_filter(a, 50.0), a, atol=1e-12)
    per_pixel = delta_E2000(obs.XYZ_to_Lab(a), obs.XYZ_to_Lab(b))
    np.testing.assert_allclose(scielab_de2000(a, b, obs, 50.0), per_pixel, atol=1e-9)


def test_fine_noise_is_invisible_coarse_noise_is_not(obs):
    w = obs.white_XYZ
    rng = np.random.default_rng(1)
    bw = rng.integers(0, 2, (160, 160)).astype(float)
    noise = bw[..., None] * w                      # black/white pixels
    grey = np.broadcast_to(0.5 * w * np.ones(1), noise.shape)  # their uniform mean
    per_pixel = delta_E2000(obs.XYZ_to_Lab(noise), obs.XYZ_to_Lab(grey)).mean()
    assert per_pixel > 40
    fine = scielab_de2000(noise, grey, obs, 224.0)[40:-40, 40:-40].mean()
    assert fine < 2.0          # the residual is the random pattern's own low frequencies
    coarse = scielab_de2000(noise, grey, obs, 5.0)[40:-40, 40:-40].mean()
    assert coarse > 0.7 * per_pixel


def test_chromatic_noise_is_blurred_more_than_luminance_noise(obs):
    # the eye's red-green and blue-yellow resolution is lower than its luminance resolution
    w = obs.white_XYZ
    rng = np.random.default_rng(2)
    sign = rng.choice([-1.0, 1.0], (128, 128))
    base = 0.4 * w
    inv = np.linalg.inv(np.array([[0.2787, 0.7218, -0.1066],
                                  [-0.4488, 0.2898, 0.0772],
                                  [0.0860, -0.5900, 0.5011]]))
    lum = base + 0.04 * sign[..., None] * (inv @ [1.0, 0.0, 0.0])
    rg = base + 0.04 * sign[..., None] * (inv @ [0.0, 1.0, 0.0])
    flat = np.broadcast_to(base, lum.shape)
    d_lum = scielab_de2000(lum, flat, obs, 30.0)[30:-30, 30:-30].mean()
    d_rg = scielab_de2000(rg, flat, obs, 30.0)[30:-30, 30:-30].mean()
    r_lum = d_lum / delta_E2000(obs.XYZ_to_Lab(lum), obs.XYZ_to_Lab(flat)).mean()
    r_rg = d_rg / delta_E2000(obs.XYZ_to_Lab(rg), obs.XYZ_to_Lab(flat)).mean()
    assert r_rg < r_lum


def test_mark_significance():
    from dreamprint_gui.proof.compare import mark_significance

    def row(m, floor):
        return {"mean_de2000": m, "mean_scielab_de2000": m / 2,
                "noise_floor": floor and {"mean_de2000": floor, "mean_scielab_de2000": floor / 2}}

    rows = [row(5.0, 0.2), row(5.5, 0.1), row(5.7, 0.2), row(9.0, None)]
    mark_significance(rows)
    got = [r["vs_best"]["mean_de2000"]["significant"] for r in rows]
    # 0.5 <= 3 x 0.2 (not significant), 0.7 > 0.6 (significant), no floor: unknown
    assert got == [False, False, True, None]
    assert rows[1]["vs_best"]["mean_de2000"]["threshold"] == pytest.approx(0.6)
    assert [r["vs_best"]["mean_scielab_de2000"]["significant"] for r in rows] == got
