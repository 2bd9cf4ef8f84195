"""The thick patch's reflectance-vs-albedo curve: the H-function closed form against an
independent iterative solution and published values, its inverse, the rendered curve against the
closed form, and a surface's curve starting at the surface's own (Fresnel) reflection."""

import json
import math

import numpy as np
import pytest

from dreamprint_gui.proof import thick_patch as tp
from dreamprint_gui.proof.optics import Optics


def _h_iterated(omega: float, mu: float, n: int = 64) -> float:
    """H by iterating 1 / H(mu) = sqrt(1 - omega) + (omega / 2) int mu' H(mu') / (mu + mu')
    (a different form of the same equation, converging slowly near omega = 1)."""
    x, w = np.polynomial.legendre.leggauss(n)
    x, w = (x + 1) / 2, w / 2
    h = np.ones(n)
    for _ in range(3000):
        h = 1 / (np.sqrt(1 - omega) + omega / 2 * np.sum(w * x * h / (x[:, None] + x), axis=1))
    return float(1 / (np.sqrt(1 - omega) + omega / 2 * np.sum(w * x * h / (mu + x))))


def test_h_function():
    # Chandrasekhar (1960), table XI: conservative scattering H(1) = 2.9078, H(0.1) = 1.2474
    np.testing.assert_allclose(tp.chandrasekhar_h([1.0], [1.0, 0.1])[0], [2.9078, 1.2474],
                               atol=2e-4)
    for om in (0.3, 0.8, 0.95):
        for mu in (1.0, 0.5, math.cos(math.radians(8))):
            assert tp.chandrasekhar_h([om], [mu])[0, 0] == pytest.approx(_h_iterated(om, mu),
                                                                         abs=1e-5)
    assert np.all(tp.chandrasekhar_h([0.0], [0.2, 1.0]) == 1.0)


def test_closed_form_curve_limits_and_inverse():
    om = tp.CLOSED_FORM_ALBEDOS
    for geo in ("d:8", "45:0"):
        R = tp.closed_form_curve(geo, om)
        assert R[0] == 0.0 and np.all(np.diff(R) > 0)
        c = tp.thick_curve(Optics("none"), geo)
        probe = np.linspace(0.001, 0.98, 50)
        np.testing.assert_allclose(c(c.albedo_for(probe)), probe, atol=1e-9)
        # the interpolation between the curve's points against the closed form itself
        fine = np.linspace(0.0, 0.9999, 3001)
        assert np.abs(c(fine) - tp.closed_form_curve(geo, fine)).max() < 1e-3
    # d:8 of a lossless medium: all the light comes back, radiance 1 (energy conservation)
    assert tp.closed_form_curve("d:8", [1.0])[0] == pytest.approx(1.0, abs=1e-9)


def test_rendered_curve_matches_the_closed_form():
    """The renderer's thick patch (the chart proof's integrator and lighting) against the
    exact solution at d:8 and 45:0, isotropic, no surface. 256 spp on 8 x 8 pixels."""
    om = np.array([0.3, 0.8, 0.95, 0.99, 0.2, 0.6])
    for geo in ("d:8", "45:0"):
        R = tp.render_curve(Optics("none"), geo, om, spp=256, pixels=8)
        np.testing.assert_allclose(R, tp.closed_form_curve(geo, om), atol=0.01)


def test_glossy_curve_starts_at_fresnel_and_is_cached(tmp_path, monkeypatch):
    """A glossy surface (n 1.5) over a black medium at d:8 (specular included) reads the
    Fresnel reflectance of 8 degrees incidence; the curve rises from there; the second request
    reads the cache. Small renders (32 spp, 4 x 4 pixels) for speed."""
    monkeypatch.setenv("DREAMPRINT_CACHE", str(tmp_path))
    monkeypatch.setattr(tp, "CURVE_SPP", 32)
    monkeypatch.setattr(tp, "CURVE_PIXELS", 4)
    tp._curve.cache_clear()
    o = Optics("glossy", ior=1.5)
    c = tp.thick_curve(o, "d:8")
    n = 1.5
    ci = math.cos(math.radians(8.0))
    ct = math.sqrt(1 - (math.sin(math.radians(8.0)) / n) ** 2)
    rs = ((ci - n * ct) / (ci + n * ct)) ** 2
    rp = ((n * ci - ct) / (n * ci + ct)) ** 2
    assert c.reflectance[0] == pytest.approx((rs + rp) / 2, abs=0.004)
    assert c.reflectance[-1] > 0.8 and np.all(np.diff(c.reflectance) >= 0)
    files = list((tmp_path / "rte_curves").iterdir())
    assert len(files) == 1
    data = json.loads(files[0].read_text())
    assert data["key"]["surface"] == "glossy" and data["key"]["spp"] == 32
    tp._curve.cache_clear()
    monkeypatch.setattr(tp, "render_curve", lambda *a, **k: pytest.fail("not read from cache"))
    c2 = tp.thick_curve(o, "d:8")
    np.testing.assert_array_equal(c2.reflectance, c.reflectance)
    tp._curve.cache_clear()
