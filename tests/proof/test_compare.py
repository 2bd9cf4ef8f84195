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


def test_no_empty_source_share_without_haze(obs):
    src, prn, sa, pa = _scene(obs, 0.0)
    fig, _ = compare_view(src, prn, sa, pa, obs, samples_per_degree=10.0)
    assert fig["object_pixels"] == 16 * 16
    for k in ("empty_source_fraction", "empty_source_de2000", "empty_source_scielab_de2000",
              "empty_source_coverage_error"):
        assert fig[k] == 0.0
    assert summarise([fig, fig])["empty_source_fraction"] == 0.0


def test_the_note_names_the_empty_source_share_only_when_there_is_one(obs):
    from dreamprint_gui.proof.compare import empty_source_note

    src, prn, sa, pa = _scene(obs, 0.2)
    fig, _ = compare_view(src, prn, sa, pa, obs, samples_per_degree=10.0)
    note = empty_source_note(fig)
    assert "75 % of the object pixels" in note and "+0.150 of the coverage error" in note
    assert "inside the source: dE2000 mean" in note and "coverage error +0.020" in note
    src, prn, sa, pa = _scene(obs, 0.0)
    assert empty_source_note(compare_view(src, prn, sa, pa, obs, 10.0)[0]) == ""
