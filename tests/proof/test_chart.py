"""Chart proof: flat patches under an instrument's geometry against Kubelka-Munk R_inf (the model
the built-in K and S were fitted in), and the command's outputs and one-line errors."""

import json

import numpy as np
import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.core.profile import INKS, default_profile
from dreamprint_gui.physics.kubelka_munk import mix, reflectance_infinite
from dreamprint_gui.proof.chart import render_chart
from dreamprint_gui.proof.optics import Optics
from dreamprint_gui.proof.spectral import spectral_bands

RECIPES = np.array([[0, 0, 0, 0, 1, 0],            # White
                    [1, 0, 0, 0, 0, 0],            # Cyan
                    [0, 0.3, 0.3, 0, 0.4, 0],      # a light red
                    [0.2, 0, 0.1, 0.1, 0.6, 0]])


def _chandrasekhar_h(omega: float, mu: float, n: int = 64) -> float:
    """Chandrasekhar's H-function of isotropic scattering (albedo omega), by iterating
    1 / H(mu) = sqrt(1 - omega) + (omega / 2) int_0^1 mu' H(mu') / (mu + mu') dmu'."""
    x, w = np.polynomial.legendre.leggauss(n)
    x, w = (x + 1) / 2, w / 2
    h = np.ones(n)
    for _ in range(400):
        h = 1 / (np.sqrt(1 - omega) + omega / 2 * np.sum(w * x * h / (x[:, None] + x), axis=1))
    return float(1 / (np.sqrt(1 - omega) + omega / 2 * np.sum(w * x * h / (mu + x))))


@pytest.mark.parametrize("geometry", ["d:8", "45:0"])
def test_surface_none_matches_the_rte_closed_form(geometry):
    """An optically thick index-matched patch (isotropic scattering) against the exact
    solution of the semi-infinite RTE (Chandrasekhar 1960): under uniform diffuse light the
    radiance leaving at mu is 1 - sqrt(1 - omega) H(mu) (d:8: mu = cos 8 deg); under a beam at
    mu0 = cos 45 deg the reflectance factor on the normal is (omega / 4) H(1) H(mu0) /
    (1 + mu0). This is the RTE, not KM: the same K and S give KM's R_inf up to 0.06 higher for
    light patches (R_inf is the hemispherical flux ratio, an instrument reads one direction),
    the difference docs/physics.md states between calibration and proof."""
    from dreamprint_gui.proof.km_to_rte import rte_coefficients

    p = default_profile()
    b = spectral_bands(p, 3)
    R, info = render_chart(RECIPES, p, Optics("none"), b, geometry, spp=256)
    K, S = mix(RECIPES, b.K, b.S)
    sa, ss = rte_coefficients(K, S)
    om = ss / (sa + ss)
    if geometry == "d:8":
        mu = np.cos(np.radians(8.0))
        exact = np.vectorize(lambda o: 1 - np.sqrt(1 - o) * _chandrasekhar_h(o, mu))(om)
    else:
        mu0 = np.cos(np.radians(45.0))
        exact = np.vectorize(lambda o: o / 4 * _chandrasekhar_h(o, 1.0)
                             * _chandrasekhar_h(o, mu0) / (1 + mu0))(om)
    assert R.shape == exact.shape == (4, 3)
    np.testing.assert_allclose(R, exact, atol=0.012)
    km = reflectance_infinite(K, S)
    assert np.all(km - R > -0.012) and (km - R).max() < 0.08


def test_glossy_surface_adds_its_reflection_and_traps_light():
    """A glossy surface (n 1.5) on the same patches under d:8 (specular included): a dark
    patch gains about its Fresnel reflection (0.04 at 8 degrees), a white one loses light to
    internal reflection (the Saunderson picture: k1 0.04, k2 0.6)."""
    p = default_profile()
    b = spectral_bands(p, 3)
    c = np.array([np.eye(6)[INKS.index("K")], np.eye(6)[INKS.index("W")]])
    none, _ = render_chart(c, p, Optics("none"), b, "d:8", spp=256)
    glossy, _ = render_chart(c, p, Optics("glossy"), b, "d:8", spp=256)
    assert np.all(glossy[0] - none[0] > 0.025) and np.all(glossy[0] - none[0] < 0.06)
    # Saunderson with k1 = 0.04, k2 = 0.6 from R_inf: the closed form of the same picture
    r = none[1]
    saunderson = 0.04 + (1 - 0.04) * (1 - 0.6) * r / (1 - 0.6 * r)
    assert np.all(glossy[1] < r) and np.all(np.abs(glossy[1] - saunderson) < 0.06)


def _write_chart(tmp_path, n=3, quantity="reflectance"):
    p = default_profile()
    rec = tmp_path / "recipes.csv"
    rec.write_text("id,C,M,Y,K,W\n" + "".join(
        f"{i + 1},{c[0]},{c[1]},{c[2]},{c[3]},{c[4]}\n" for i, c in enumerate(RECIPES[:n])))
    R = reflectance_infinite(*mix(RECIPES[:n], p.K, p.S))
    meas = tmp_path / "measured.csv"
    meas.write_text(f"# quantity: {quantity}\nid," + ",".join(
        f"{w:g}" for w in p.wavelengths_nm) + "\n" + "".join(
        f"{i + 1}," + ",".join(f"{v:.5f}" for v in r) + "\n" for i, r in enumerate(R)))
    return rec, meas


def test_chart_proof_command(tmp_path, capsys):
    rec, meas = _write_chart(tmp_path)
    out = tmp_path / "cp"
    code = main(["proof", "--chart", str(rec), "--reflectance", str(meas), "-o", str(out),
                 "--spp", "128", "--bands", "36", "--json"])
    o, err = capsys.readouterr()
    assert code == 0, err
    rep = json.loads(o)
    assert {p.name for p in out.iterdir()} == {"chart_proof.json", "patches.csv", "chart.png"}
    assert rep["geometry"] == "d:8" and rep["optics"]["surface"] == "none"
    assert len(rep["patches"]) == 3 and all("de2000" in r for r in rep["patches"])
    # "measured" here is the profile's own KM R_inf; the proof is the RTE (up to 0.06 darker
    # for light patches, test above): a few dE2000, recomputed here from the written Labs
    import colour

    de = [colour.delta_E(r["measured_lab"], r["proof_lab"], method="CIE 2000")
          for r in rep["patches"]]
    np.testing.assert_allclose([r["de2000"] for r in rep["patches"]], de, atol=2e-3)
    assert rep["de2000"]["mean"] == pytest.approx(np.mean(de), abs=2e-3) and max(de) < 6
    assert rep["de2000"]["worst_patches"][0]["patch"] == int(np.argmax(de)) + 1
    lines = (out / "patches.csv").read_text().splitlines()
    assert len(lines) == 4 and lines[0].endswith("de2000")


@pytest.mark.parametrize("case, words", [
    ("count", "2 measured spectra but 3 recipes"),
    ("ink", "is not an ink"),
    ("quantity", "transmittance"),
    ("geometry", "unknown geometry"),
    ("phase", "unknown phase"),
    ("source", "give no SOURCE"),
])
def test_chart_proof_bad_input(tmp_path, capsys, case, words):
    rec, meas = _write_chart(tmp_path)
    args = ["proof", "--chart", str(rec), "--reflectance", str(meas), "-o",
            str(tmp_path / "x"), "--spp", "4"]
    if case == "count":
        (tmp_path / "b").mkdir()
        _, meas2 = _write_chart(tmp_path / "b", n=2)
        args[4] = str(meas2)
    elif case == "ink":
        rec.write_text("id,C,Q\n1,0.5,0.5\n")
    elif case == "quantity":
        _write_chart(tmp_path, quantity="transmittance")
    elif case == "geometry":
        args += ["--geometry", "0:45"]
    elif case == "phase":
        args += ["--phase", "mie"]
    elif case == "source":
        args.insert(1, "demo")
    code = main(args)
    _, err = capsys.readouterr()
    assert code == 2 and err.startswith("dreamprint: error:") and words in err, err
    assert err.count("\n") == 1 and not (tmp_path / "x").exists()
