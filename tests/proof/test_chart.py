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
def test_surface_none_matches_the_rte_closed_form_and_km(geometry):
    """An optically thick index-matched patch (isotropic scattering) against the exact
    solution of the semi-infinite RTE (Chandrasekhar 1960, H-function by iteration here): under
    uniform diffuse light the radiance leaving at mu is 1 - sqrt(1 - omega) H(mu) (d:8: mu =
    cos 8 deg); under a beam at mu0 = cos 45 deg the reflectance factor on the normal is
    (omega / 4) H(1) H(mu0) / (1 + mu0); omega is the albedo the proof's conversion gives the
    mixture. That conversion makes the reading KM's R_inf of the mixture's K and S (Gate's
    relation read up to 0.06 lower for light patches).

    The render's noise at 512 spp: a patch's band reads up to 0.014 off its exact value (seeds 0-5,
    both of Mitsuba's variants: a worker whose first test loaded the scalar one renders another
    realisation), their mean within 0.003; so 0.02 per patch and band, 0.005 on the mean."""
    from dreamprint_gui.proof.km_to_rte import gate_coefficients, rte_coefficients

    p = default_profile()
    b = spectral_bands(p, 3)
    R, info = render_chart(RECIPES, p, Optics("none"), b, geometry, spp=512)
    K, S = mix(RECIPES, b.K, b.S)
    sa, ss = rte_coefficients(K, S, 0.0, geometry)
    om = ss / (sa + ss)
    if geometry == "d:8":
        mu = np.cos(np.radians(8.0))
        exact = np.vectorize(lambda o: 1 - np.sqrt(1 - o) * _chandrasekhar_h(o, mu))(om)
    else:
        mu0 = np.cos(np.radians(45.0))
        exact = np.vectorize(lambda o: o / 4 * _chandrasekhar_h(o, 1.0)
                             * _chandrasekhar_h(o, mu0) / (1 + mu0))(om)
    assert R.shape == exact.shape == (4, 3)
    np.testing.assert_allclose(R, exact, atol=0.02)
    assert abs(float(np.mean(R - exact))) < 0.005
    km = reflectance_infinite(K, S)
    np.testing.assert_allclose(R, km, atol=0.02)
    assert abs(float(np.mean(R - km))) < 0.005
    ga, gs = gate_coefficients(K, S)
    assert np.abs(om - gs / (ga + gs)).max() > 0.005      # the conversion is not Gate's


def test_glossy_surface_adds_its_reflection_and_keeps_the_reading(tmp_path, monkeypatch):
    """A glossy surface (n 1.5) on the same patches under d:8 (specular included), with the
    conversion inverted through the surface: a black patch reads its Fresnel reflection (0.04
    at 8 degrees: KM's R_inf of Black, 0.01, is below what any patch behind that surface can
    read), a white one reads KM's R_inf again (the same K and S, now with the surface's light
    trapping inside the model). The surface's curve is rendered small (128 spp, 8 pixels)."""
    from dreamprint_gui.proof import thick_patch as tp

    monkeypatch.setenv("DREAMPRINT_CACHE", str(tmp_path))
    monkeypatch.setattr(tp, "CURVE_SPP", 128)
    monkeypatch.setattr(tp, "CURVE_PIXELS", 8)
    tp._curve.cache_clear()
    p = default_profile()
    b = spectral_bands(p, 3)
    c = np.array([np.eye(6)[INKS.index("K")], np.eye(6)[INKS.index("W")]])
    none, _ = render_chart(c, p, Optics("none"), b, "d:8", spp=256)
    glossy, _ = render_chart(c, p, Optics("glossy"), b, "d:8", spp=256)
    tp._curve.cache_clear()
    assert np.all(glossy[0] - none[0] > 0.025) and np.all(glossy[0] - none[0] < 0.04)
    assert np.all(np.abs(glossy[0] - 0.04) < 0.006)
    km = reflectance_infinite(b.K[INKS.index("W")], b.S[INKS.index("W")])
    np.testing.assert_allclose(glossy[1], km, atol=0.02)
    np.testing.assert_allclose(none[1], km, atol=0.012)


def test_hg_phase_keeps_the_reading(tmp_path, monkeypatch):
    """hg:0.4 with its own conversion (its thick-patch curve, rendered small here): a flat
    thick White and a light red read KM's R_inf at d:8 as isotropic scattering does."""
    from dreamprint_gui.proof import thick_patch as tp

    monkeypatch.setenv("DREAMPRINT_CACHE", str(tmp_path))
    monkeypatch.setattr(tp, "CURVE_SPP", 128)
    tp._curve.cache_clear()
    p = default_profile()
    b = spectral_bands(p, 3)
    R, _ = render_chart(RECIPES[[0, 2]], p, Optics("none", g=0.4), b, "d:8", spp=256)
    tp._curve.cache_clear()
    np.testing.assert_allclose(R, reflectance_infinite(*mix(RECIPES[[0, 2]], b.K, b.S)),
                               atol=0.02)


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
    # "measured" here is the profile's own KM R_inf, which the proof's thick patches read (test
    # above): below 1 dE2000 up to noise, recomputed here from the written Labs
    import colour

    de = [colour.delta_E(r["measured_lab"], r["proof_lab"], method="CIE 2000")
          for r in rep["patches"]]
    np.testing.assert_allclose([r["de2000"] for r in rep["patches"]], de, atol=2e-3)
    assert rep["de2000"]["mean"] == pytest.approx(np.mean(de), abs=2e-3) and max(de) < 1.5
    assert rep["de2000"]["worst_patches"][0]["patch"] == int(np.argmax(de)) + 1
    lines = (out / "patches.csv").read_text().splitlines()
    assert len(lines) == 4 and lines[0].endswith("de2000")
    # the wait is visible (issue 46): a line when rendering starts and after each of the 12
    # passes of 3 bands
    steps = [ln for ln in err.splitlines() if ln.startswith("chart proof: render passes")
             and ", pass " not in ln]          # not the heartbeat within a pass
    assert len(steps) == 13 and "12/12" in steps[-1] and "done" in steps[-1]


@pytest.mark.parametrize("case, words", [
    ("count", "2 measured spectra but 3 recipes"),
    ("ink", "is not an ink"),
    ("quantity", "transmittance"),
    ("geometry", "unknown geometry"),
    ("phase", "unknown phase"),
    ("glossy45", "cannot be proofed at 45:0"),
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
    elif case == "glossy45":
        args += ["--geometry", "45:0", "--surface", "glossy"]
    elif case == "source":
        args.insert(1, "demo")
    code = main(args)
    _, err = capsys.readouterr()
    assert code == 2 and err.startswith("dreamprint: error:") and words in err, err
    assert err.count("\n") == 1 and not (tmp_path / "x").exists()


def test_the_starter_chart_is_a_valid_recipes_file():
    """resources/charts/starter-24.csv, the chart the README proofs (and an operator prints):
    24 distinct mixtures of the five opaque inks, each summing to 1, read by the recipes reader
    that `calibrate --chart` and `proof --chart` use."""
    from dreamprint_gui.core.resources import resource_path
    from dreamprint_gui.io.recipes import read_recipes

    rec = read_recipes(resource_path("charts", "starter-24.csv"))
    assert rec.shape == (24, 6)
    np.testing.assert_allclose(rec.sum(axis=1), 1.0)
    assert len({tuple(r) for r in rec.round(6)}) == 24
    assert np.all(rec[:, INKS.index("Cl")] == 0)


def test_the_chart_picture_numbers_its_patches_as_the_report_does():
    """Each square carries its patch number (issue 46: the report names the worst patches by
    number), legible on a black and on a white patch."""
    from dreamprint_gui.core.profile import default_profile
    from dreamprint_gui.proof.chart import chart_from_arrays, chart_picture
    from dreamprint_gui.proof.spectral import spectral_bands

    profile = default_profile()
    c = np.zeros((2, 6))
    c[0, 3] = c[1, 4] = 1.0                         # K, W
    chart = chart_from_arrays(c, None, profile)
    bands = spectral_bands(profile, 3)
    band_R = np.array([[0.0] * 3, [1.0] * 3])       # a black and a white patch
    px = 48
    img = chart_picture(chart, band_R, bands, px=px).astype(int)
    black, white = img[:px, :px], img[:px, px:2 * px]
    corner = (slice(2, px // 3), slice(2, px // 2))
    assert (black[corner].min(axis=-1) > 200).sum() > 5       # white digits on black
    assert (white[corner].max(axis=-1) < 60).sum() > 5        # black digits on white
    assert (black[px // 2:px - 4, 4:px - 4] < 30).all()       # the patch itself stays clear
    one = black[corner].min(axis=-1) > 200
    two = white[corner].max(axis=-1) < 60
    assert (one != two).any()                                  # "1" and "2" differ


def test_a_render_pass_says_how_it_goes_and_the_numbers_stay(monkeypatch):
    """While a pass renders (one Mitsuba call: about 20 s at the default 512 spp), progress
    hears 'pass k of n: elapsed, about T left' every HEARTBEAT_S seconds (here 0.02 s): the
    render leaves the GIL to the heartbeat's thread (with the scene a temporary it kept it: one
    beat per pass, at its end). The reflectances are bit-identical to a render without progress
    (same seed). Fails if the heartbeat is removed (no detail between the passes' lines)."""
    import time

    from dreamprint_gui.core import progress as core_progress

    p = default_profile()
    b = spectral_bands(p, 6)                       # 2 passes
    args = (RECIPES[:2], p, Optics("none"), b, "d:8")
    quiet, _ = render_chart(*args, spp=256, seed=3)
    monkeypatch.setattr(core_progress, "HEARTBEAT_S", 0.02)
    heard: list[tuple] = []
    told, _ = render_chart(*args, spp=256, seed=3,
                           progress=lambda *a: heard.append((time.monotonic(), *a)))
    np.testing.assert_array_equal(told, quiet)
    ends = [i for i, a in enumerate(heard) if len(a) == 3]
    assert [heard[i][1:] for i in ends] == [(0, 2), (1, 2), (2, 2)]
    for k in (0, 1):
        beats = heard[ends[k] + 1:ends[k + 1]]
        took = heard[ends[k + 1]][0] - heard[ends[k]][0]
        assert all(a[1:3] == (k, 2) and a[3].startswith(f"pass {k + 1} of 2: ") for a in beats)
        # a beat every 0.02 s while the pass renders (a quarter of them, for a loaded machine)
        assert len(beats) >= max(2, 0.25 * took / 0.02), (len(beats), took)
    first, second = heard[ends[0] + 1:ends[1]], heard[ends[1] + 1:ends[2]]
    # no pass before the first to go by; the second's time left from the first's
    assert not any(w in a[3] for a in first for w in ("left", "any moment"))
    assert all("left" in a[3] or "any moment now" in a[3] for a in second)
