"""compare_view's figures where the source is empty: a Clear block's body around the object."""

import numpy as np
import pytest

from dreamprint_gui.core.profile import default_profile
from dreamprint_gui.physics.colorimetry import delta_E2000, observer_for
from dreamprint_gui.proof.compare import compare_view, summarise

RES = 32


@pytest.fixture(scope="module")
def obs():
    return observer_for(default_profile().wavelengths_nm)


def _scene(obs, haze: float):
    """A grey square object (source and print alike, print 10 % darker) seen through a uniform
    haze of coverage ``haze`` over the whole print frame; the source has nothing outside the
    square. Linear sRGB -> XYZ with the observer's white (the environment) as 1."""
    a = np.linalg.inv(obs.XYZ_to_linear_sRGB(np.eye(3)))
    src_a = np.zeros((RES, RES))
    src_a[8:24, 8:24] = 0.9
    src = np.ones((RES, RES, 3))
    src[8:24, 8:24] = 0.4
    prn = src * 1.0
    prn[8:24, 8:24] = 0.36
    prn = prn * (1 - haze) + 0.7 * haze          # the haze is a darker veil over the frame
    prn_a = 1 - (1 - src_a) * (1 - haze)
    to_xyz = lambda lin: lin @ a  # noqa: E731
    assert np.allclose(to_xyz(np.ones(3)), obs.white_XYZ)
    return to_xyz(src), to_xyz(prn), src_a, prn_a


def test_empty_source_shares_add_up_to_the_figures(obs):
    src, prn, sa, pa = _scene(obs, 0.2)
    fig, _ = compare_view(src, prn, sa, pa, obs, samples_per_degree=10.0)
    inside = 16 * 16
    n = RES * RES                                    # the haze (0.2 > 0.05) covers every pixel
    assert fig["object_pixels"] == n
    assert fig["empty_source_fraction"] == pytest.approx((n - inside) / n)
    # coverage: outside the square print 0.2 against 0; inside 1 - 0.1 * 0.8 = 0.92 against 0.9
    assert fig["empty_source_coverage_error"] == pytest.approx(0.2 * (n - inside) / n)
    assert fig["coverage_error"] == pytest.approx(
        fig["empty_source_coverage_error"] + 0.02 * inside / n)
    # dE2000 outside: white against the veil, the same at every pixel of that region
    lab_w = obs.XYZ_to_Lab(src[0, 0])
    lab_v = obs.XYZ_to_Lab(prn[0, 0])
    de_out = float(delta_E2000(lab_w, lab_v))
    assert de_out > 1.0
    assert fig["empty_source_de2000"] == pytest.approx(de_out * (n - inside) / n, rel=1e-9)
    assert 0.0 < fig["empty_source_scielab_de2000"] < fig["mean_scielab_de2000"]


def test_inside_the_source_is_the_figure_over_the_source_pixels(obs):
    from dreamprint_gui.proof.compare import inside_source

    src, prn, sa, pa = _scene(obs, 0.2)
    fig, de = compare_view(src, prn, sa, pa, obs, samples_per_degree=10.0)
    assert inside_source(fig, "coverage_error") == pytest.approx(0.02)  # 0.92 against 0.9
    assert inside_source(fig, "mean_de2000") == pytest.approx(float(de[8:24, 8:24].mean()))
    assert inside_source({**fig, "empty_source_fraction": 1.0}, "mean_de2000") is None


def test_the_headline_is_inside_the_source(obs):
    """compare_view's inside_source_* are the figures over the source's pixels (the square):
    coverage 0.92 against 0.9, dE2000 the map's mean there, and the derived inside_source()
    agrees; summarise weights views by those pixels; without them the headline is all object
    pixels."""
    from dreamprint_gui.proof.compare import headline, headline_text, inside_source

    src, prn, sa, pa = _scene(obs, 0.2)
    fig, de = compare_view(src, prn, sa, pa, obs, samples_per_degree=10.0)
    h = headline(fig)
    assert h["where"] == "inside the source"
    assert fig["inside_source_pixels"] == 16 * 16
    assert h["coverage_error"] == pytest.approx(0.02)
    assert h["coverage_abs_error"] == pytest.approx(0.02)
    assert h["mean_de2000"] == pytest.approx(float(de[8:24, 8:24].mean()))
    assert h["p95_de2000"] == pytest.approx(float(np.percentile(de[8:24, 8:24], 95)))
    assert h["mean_de2000"] == pytest.approx(inside_source(fig, "mean_de2000"))
    assert h["mean_scielab_de2000"] == pytest.approx(inside_source(fig, "mean_scielab_de2000"))
    assert h["mean_de2000"] != pytest.approx(fig["mean_de2000"])  # the veil is not counted
    assert headline_text(fig).startswith("inside the source: dE2000 mean")
    # two views: one with the object, one where the source is empty everywhere
    src0, prn0, sa0, pa0 = _scene(obs, 0.2)
    sa0[:] = 0.0
    empty, _ = compare_view(src0, prn0, sa0, pa0, obs, samples_per_degree=10.0)
    assert empty["inside_source_pixels"] == 0
    assert headline(empty)["where"] == "all object pixels"
    both = summarise([fig, empty])
    assert both["inside_source_pixels"] == 16 * 16
    assert headline(both)["mean_de2000"] == pytest.approx(h["mean_de2000"])


def test_the_noise_floor_inside_the_source(obs):
    from dreamprint_gui.proof.compare import noise_floor

    src, prn, sa, pa = _scene(obs, 0.2)
    other = prn.copy()
    other[8:24, 8:24] *= 1.05                      # the two renders differ only in the square
    f = noise_floor(prn, other, pa, obs, 10.0, source_alpha=sa)
    assert f["inside_source_pixels"] == 16 * 16
    de = delta_E2000(obs.XYZ_to_Lab(prn[8:24, 8:24]), obs.XYZ_to_Lab(other[8:24, 8:24]))
    assert f["inside_source_mean_de2000"] == pytest.approx(float(de.mean()))
    assert f["mean_de2000"] == pytest.approx(float(de.sum()) / (RES * RES))
    assert "inside_source_pixels" not in noise_floor(prn, other, pa, obs, 10.0)


def test_no_empty_source_share_without_haze(obs):
    src, prn, sa, pa = _scene(obs, 0.0)
    fig, _ = compare_view(src, prn, sa, pa, obs, samples_per_degree=10.0)
    assert fig["object_pixels"] == 16 * 16
    for k in ("empty_source_fraction", "empty_source_de2000", "empty_source_scielab_de2000",
              "empty_source_coverage_error"):
        assert fig[k] == 0.0
    assert summarise([fig, fig])["empty_source_fraction"] == 0.0


def test_the_note_names_the_empty_source_share_only_when_there_is_one(obs):
    from dreamprint_gui.proof.compare import empty_source_note, headline_text

    src, prn, sa, pa = _scene(obs, 0.2)
    fig, _ = compare_view(src, prn, sa, pa, obs, samples_per_degree=10.0)
    note = empty_source_note(fig)
    assert "75 % of the object pixels" in note and "+0.150 of the coverage error" in note
    # the figures inside the source are the headline, shown first; the note does not repeat them
    assert "inside the source" not in note
    head = headline_text(fig)
    assert head.startswith("inside the source") and "coverage error +0.020" in head
    src, prn, sa, pa = _scene(obs, 0.0)
    assert empty_source_note(compare_view(src, prn, sa, pa, obs, 10.0)[0]) == ""


def _noisy(obs, rng, spp: int, sd: float = 0.1, n: int = 96):
    """A proof at ``spp`` samples of a colourful smooth print (XYZ): each pixel the mean of
    ``spp`` independent samples of noise of standard deviation ``sd`` (of the white) per
    channel around it (0.1: a floor of 2.6 per pixel, 1.3 S-CIELAB, like the demo's at 64)."""
    a = np.linalg.inv(obs.XYZ_to_linear_sRGB(np.eye(3)))
    y, x = np.mgrid[0:n, 0:n] / n
    lin = np.stack([0.2 + 0.6 * x, 0.15 + 0.5 * y, 0.3 + 0.3 * x * y], axis=-1)
    xyz = lin @ a.T
    return xyz + sd * rng.standard_normal(xyz.shape) / np.sqrt(spp)


def test_the_floor_from_two_halves_estimates_two_independent_proofs(obs):
    """The floor computed from two halves of 32 samples (the proof is their mean) against the
    previous definition: two independent proofs of 64 samples, figures between them. The same
    in expectation (means within 3 %, p95 within 6 %, over 9216 pixels); the halves compared
    as they are read sqrt 2 too high, which the pair's scaling removes."""
    from dreamprint_gui.proof.compare import noise_floor, noise_floor_from_halves

    rng = np.random.default_rng(7)
    alpha = np.ones((96, 96))
    old = noise_floor(_noisy(obs, rng, 64), _noisy(obs, rng, 64), alpha, obs, 12.0)
    a, b = _noisy(obs, rng, 32), _noisy(obs, rng, 32)
    new = noise_floor_from_halves(a, b, alpha, obs, 12.0)
    raw = noise_floor(a, b, alpha, obs, 12.0)
    for k, tol in (("mean_de2000", 0.03), ("mean_scielab_de2000", 0.03), ("p95_de2000", 0.06)):
        assert new[k] == pytest.approx(old[k], rel=tol), k
        assert raw[k] / new[k] == pytest.approx(np.sqrt(2), rel=0.05), k
    assert new["object_pixels"] == 96 * 96


@pytest.mark.parametrize("scale", [0.93, 0.85])
def test_the_noise_corrected_de2000_takes_the_render_noise_out(obs, scale):
    """A print darker than its source by ``scale`` (noiseless mean dE2000 1.65 and 3.70),
    rendered as two halves of 32 samples with the noise of the demo's proof at 64: the raw
    mean dE2000 reads the noise too (0.93 and 0.55 above the noiseless figure); the corrected
    one is within 0.2 of it (0.02 and 0.15 off; a factor 1/8 or 1/3 instead of 1/4 misses).
    Equal halves (no noise) give the plain dE2000."""
    from dreamprint_gui.proof.compare import noise_corrected_de2000, noise_corrected_figures

    rng = np.random.default_rng(11)
    truth = _noisy(obs, rng, 1, sd=0.0)
    src = truth / scale
    lab = obs.XYZ_to_Lab
    clean = delta_E2000(lab(src), lab(truth)).mean()
    a, b = _noisy(obs, rng, 32), _noisy(obs, rng, 32)
    raw = delta_E2000(lab(src), lab((a + b) / 2)).mean()
    ones = np.ones(truth.shape[:2])
    fig = noise_corrected_figures(src, a, b, ones, ones, obs)
    assert raw - clean > 0.5
    assert fig["nc_mean_de2000"] == pytest.approx(clean, abs=0.2)
    assert fig["inside_source_nc_mean_de2000"] == fig["nc_mean_de2000"]
    assert np.allclose(noise_corrected_de2000(src, truth, truth, obs),
                       delta_E2000(lab(src), lab(truth)))
    # the proof's summary and headline carry it beside the raw mean
    from dreamprint_gui.proof.compare import headline_text

    view = {**compare_view(src, (a + b) / 2, ones, ones, obs, 10.0)[0], **fig}
    overall = summarise([view, view])
    assert overall["inside_source_nc_mean_de2000"] == pytest.approx(fig["nc_mean_de2000"])
    assert f"mean {raw:.2f} ({fig['nc_mean_de2000']:.2f} less the render's noise)" in \
        headline_text(overall)
