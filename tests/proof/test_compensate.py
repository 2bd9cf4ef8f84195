"""The compensation loop (proof/compensate.py): back-projection, the loop's effect, the CLI."""

import json
import threading

import numpy as np
import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.job.correction import load_correction
from dreamprint_gui.job.plan import JobCancelled
from dreamprint_gui.proof.cameras import View
from dreamprint_gui.proof.compensate import (
    CompensateSettings,
    backproject,
    pixel_log_ratios,
    run_compensate,
    training_views,
)
from dreamprint_gui.proof.source_render import SourceField

TINY = dict(source="demo", height_mm=3.0, views=2, resolution=24, spp=4, max_cells=12,
            field_cells=6, table_size=17)


def test_backprojection_puts_a_pixel_value_where_the_ray_meets_the_medium():
    # one opaque cell in an otherwise empty 8^3 grid: every ray through it deposits its value
    # in the field cells around that cell, and nowhere else
    sigma = np.zeros((8, 8, 8), np.float32)
    sigma[6, 1, 2] = 50.0
    f = SourceField(sigma, np.ones((8, 8, 8, 3), np.float32), np.array([-4.0, -4, -4]),
                    np.ones(3))
    view = View(0.0, 0.0, 4.0 * 1.74, 30.0)
    num = np.zeros((4, 4, 4, 1))
    den = np.zeros((4, 4, 4))
    backproject(f, view, 32, np.ones((32, 32, 1)), np.array([-4.0, -4, -4]),
                np.array([8.0, 8, 8]), num, den)
    assert den.sum() > 0
    np.testing.assert_allclose(num[..., 0], den)  # value 1 everywhere: weighted mean 1
    zc, yc, xc = np.unravel_index(np.argmax(den), den.shape)
    # cell (x 2, y 1, z 6) of 8 lies in field cell (x 1, y 0, z 3) of 4
    assert (xc, yc, zc) == (1, 0, 3)


def test_ratios_are_source_over_print_and_clipped():
    src = np.full((2, 2, 3), 0.4)
    prn = np.full((2, 2, 3), 0.7)
    a = np.ones((2, 2))
    r = pixel_log_ratios(src, a, prn, a)
    want = np.log((0.4 + 0.02) / (0.7 + 0.02))
    np.testing.assert_allclose(r[..., :3], want)
    r = pixel_log_ratios(np.zeros((2, 2, 3)), a, prn, a)  # far off: clipped to 1/2
    np.testing.assert_allclose(r[..., :3], np.log(0.5))


def test_coverage_ratio_is_the_newton_step_on_the_objects_optical_depth():
    # a print whose optical depth on a ray is the block's tau_0 plus g times the object's:
    # one step g' = g r reaches the source's optical depth exactly (unclipped)
    tau_0, tau_obj, tau_s = 0.35, 0.30, 0.50
    a = lambda tau: np.full((1, 1), 1.0 - np.exp(-tau))  # noqa: E731
    col = np.full((1, 1, 3), 0.5)
    r = np.exp(pixel_log_ratios(col, a(tau_s), col, a(tau_0 + tau_obj), a(tau_0))[..., 3])
    np.testing.assert_allclose(tau_0 + r * tau_obj, tau_s, rtol=1e-9)
    # without the block the same pixel's plain ratio tau_s / tau_p asks for too little
    r0 = np.exp(pixel_log_ratios(col, a(tau_s), col, a(tau_0 + tau_obj))[..., 3])
    np.testing.assert_allclose(r0, tau_s / (tau_0 + tau_obj), rtol=1e-9)
    assert tau_0 + r0 * tau_obj > tau_s + 0.05
    # a source thinner than the block alone: the least density (the clip); a print already at
    # the block's floor where the source is too: no change
    r = pixel_log_ratios(col, a(0.1), col, a(tau_0 + tau_obj), a(tau_0))[..., 3]
    np.testing.assert_allclose(r, np.log(0.5))
    r = pixel_log_ratios(col, a(0.1), col, a(tau_0), a(tau_0))[..., 3]
    np.testing.assert_allclose(r, 0.0, atol=1e-12)
    # an empty background (floor coverage 0) is the plain ratio
    np.testing.assert_allclose(
        pixel_log_ratios(col, a(tau_s), col, a(0.7), np.zeros((1, 1))),
        pixel_log_ratios(col, a(tau_s), col, a(0.7)), atol=1e-12)


def test_background_fractions_take_the_object_out():
    from dreamprint_gui.proof.medium import CLEAR, EMPTY, background_fractions

    rng = np.random.default_rng(3)
    f = rng.random((2, 3, 4, 7))
    f /= f.sum(-1, keepdims=True)
    b = background_fractions(f, "clear")
    np.testing.assert_allclose(b.sum(-1), 1.0, rtol=1e-6)
    np.testing.assert_allclose(b[..., CLEAR], 1.0 - f[..., EMPTY], rtol=1e-6)
    np.testing.assert_allclose(b[..., EMPTY], f[..., EMPTY], rtol=1e-6)
    assert not b[..., :CLEAR].any()
    e = background_fractions(f, "empty")
    assert (e[..., EMPTY] == 1).all() and not e[..., :EMPTY].any()
    with pytest.raises(ValueError):
        background_fractions(f, "white")


def test_loop_lowers_the_error_and_writes_a_correction(tmp_path, capsys):
    out = tmp_path / "c.npz"
    code = main(["compensate", "demo", "-o", str(out), "--height-mm", "3", "--views", "2",
                 "--iterations", "2", "--resolution", "24", "--spp", "4", "--cells", "12",
                 "--field-cells", "6", "--table-size", "17", "--json"])
    cap = capsys.readouterr()
    assert code == 0, cap.err
    rep = json.loads(cap.out)
    hist = rep["history"]
    assert len(hist) == 3 and rep["proof_cells"] == 12
    # the default Clear block: the share of the training figures where the source is empty
    assert 0 <= hist[0]["empty_source_de2000"] <= hist[0]["mean_de2000"]
    assert 0 <= hist[0]["empty_source_fraction"] <= 1
    after = rep["figures"]["after"]
    assert after["mean_de2000"] < hist[0]["mean_de2000"]
    corr = load_correction(out)
    assert corr.gain.shape[3] == 4 and not corr.is_identity
    assert corr.report["figures"]["after"] == after
    # the job made with it records it, and a proof of it reports it
    code = main(["proof", "demo", "-o", str(tmp_path / "p"), "--height-mm", "3", "--views", "1",
                 "--resolution", "16", "--spp", "2", "--cells", "12", "--table-size", "17",
                 "--compensation", str(out), "--json"])
    cap = capsys.readouterr()
    assert code == 0, cap.err
    assert json.loads(cap.out)["compensation"]["optimiser_figures"]["after"] == after


def test_cancel_writes_nothing(tmp_path):
    out = tmp_path / "c.npz"
    cancel = threading.Event()
    gen = run_compensate(CompensateSettings(output=str(out), iterations=2, **TINY), cancel)
    with pytest.raises(JobCancelled):
        for p in gen:
            if p.stage.startswith("print"):
                cancel.set()
    assert list(tmp_path.iterdir()) == []


def test_gamut_floor_of_an_identity_table_is_the_source(monkeypatch):
    """With tables that deposit exactly the asked colour and density the floor's render is the
    source's own: dE2000 0 and coverage error 0 (the plumbing of runner.gamut_floor)."""
    from dreamprint_gui.job.plan import ConvertSettings
    from dreamprint_gui.proof import runner
    from dreamprint_gui.proof.cameras import orbit_views
    from dreamprint_gui.proof.labels import EngineLabels
    from dreamprint_gui.proof.runner import ProofSettings, gamut_floor
    from dreamprint_gui.proof.source_render import render_source
    from dreamprint_gui.proof.spectral import spectral_bands

    lab = EngineLabels(ConvertSettings.from_spec(ProofSettings(source="demo", height_mm=2,
                                                               table_size=17).spec))
    rng = np.random.default_rng(0)
    sigma = rng.uniform(0, 20, (6, 6, 6)).astype(np.float32)
    sigma[sigma < 5] = 0.0
    field = SourceField(sigma, rng.uniform(0, 1, (6, 6, 6, 3)).astype(np.float32),
                        np.array([-1.0, -1, -1]), np.full(3, 2 / 6))
    monkeypatch.setattr(runner, "predicted_appearance",
                        lambda tables, profile, rgb, s: (np.asarray(rgb), np.asarray(s)))
    assert lab.ctx.halftoner.threshold < 5.0  # every non-empty cell is printed
    views = orbit_views((2.0, 2.0, 2.0), 2)
    src = [render_source(field, v, 16) for v in views]
    obs = spectral_bands(lab.profile, 12).observer
    from dreamprint_gui.proof.scielab import samples_per_degree

    spd = samples_per_degree(2 * views[0].half_mm / 16, 400.0)
    f = gamut_floor(lab, field, views, 16, [s[0] for s in src], [s[1] for s in src], obs, spd)
    assert f["object_pixels"] > 0
    assert f["mean_de2000"] < 0.05 and abs(f["coverage_error"]) < 1e-9


def test_evaluate_methods_compensated_row_and_gamut_floor(capsys):
    code = main(["evaluate", "methods", "demo", "--method", "paper", "--method", "compensated",
                 "--height-mm", "3", "--views", "1", "--resolution", "16", "--spp", "2",
                 "--cells", "12", "--table-size", "17", "--iterations", "1",
                 "--training-views", "1", "--json"])
    cap = capsys.readouterr()
    assert code == 0, cap.err
    t = json.loads(cap.out)
    paper, comp = t["methods"]
    assert (paper["method"], comp["method"]) == ("paper", "compensated")
    assert len(comp["training"]["before"]) and comp["optimise_seconds"] > 0
    assert t["gamut_floor"]["object_pixels"] > 0


def test_training_renders_use_the_proofs_cells(shared_data):
    """Solid or fog, the field is trained on the medium the proof judges (its default cells)
    unless told otherwise."""
    from dreamprint_gui.proof.compensate import TRAIN_CELLS, _Loop
    from dreamprint_gui.proof.runner import DEFAULT_MAX_CELLS

    knight = str(shared_data / "voxels" / "magicavoxel_chr_knight.vox")
    never = lambda: False  # noqa: E731
    assert TRAIN_CELLS == DEFAULT_MAX_CELLS
    assert _Loop(CompensateSettings(source=knight, height_mm=3.0, table_size=17), [],
                 never).cells == TRAIN_CELLS
    assert _Loop(CompensateSettings(source="demo", height_mm=3.0, table_size=17), [],
                 never).cells == TRAIN_CELLS
    assert _Loop(CompensateSettings(source=knight, height_mm=3.0, table_size=17, max_cells=20),
                 [], never).cells == 20


def test_floor_alphas_are_the_clear_blocks_own_transmittance():
    # a box of 8 x 6 x 4 cells of 1 mm, every cell printed: seen along x, each ray crosses
    # 8 mm of Clear, so the coverage is 1 - sum_b y_b exp(-8 sigma_Clear,b) (luminance
    # weights y); along z 4 mm. Without a block: no floor.
    from dreamprint_gui.core.profile import default_profile
    from dreamprint_gui.proof.compensate import floor_alphas
    from dreamprint_gui.proof.medium import CLEAR, EMPTY, N_LABELS, medium_coefficients
    from dreamprint_gui.proof.spectral import spectral_bands

    bands = spectral_bands(default_profile(), 12)
    f = np.zeros((4, 6, 8, N_LABELS), np.float32)
    f[..., 0] = 0.3   # any printed labels: taken out, they are Clear
    f[..., 3] = 0.7
    lo = np.array([-4.0, -3.0, -2.0])
    views = [View(0.0, 0.0, 5.0, 30.0), View(0.0, 90.0, 5.0, 30.0)]
    a0 = floor_alphas(f, "clear", bands, lo, (1.0, 1.0, 1.0), views, 16)
    clear = np.zeros(N_LABELS)
    clear[CLEAR] = 1.0
    sigma, _ = medium_coefficients(clear, bands.K, bands.S)
    y = bands.xyz_weights[:, 1] / bands.xyz_weights[:, 1].sum()
    for a, length in zip(a0, (8.0, 4.0), strict=True):
        np.testing.assert_allclose(a[8, 8], 1.0 - y @ np.exp(-sigma * length), rtol=1e-3)
    np.testing.assert_allclose(a0[0][0, 0], 0.0, atol=1e-12)   # a ray beside the box
    f[..., EMPTY] = 1.0
    f[..., :EMPTY] = 0.0
    np.testing.assert_allclose(
        floor_alphas(f, "clear", bands, lo, (1.0, 1.0, 1.0), views, 16)[0], 0.0, atol=1e-12)
    assert floor_alphas(f, "empty", bands, lo, (1.0, 1.0, 1.0), views, 16) == [None, None]


def test_training_cameras_bracket_the_proofs_elevation_and_miss_its_cameras():
    """The training cameras take 35 and 5 degrees in turn (the proof's 20 between them), none
    at a proof camera's azimuth, all framing the same box."""
    from dreamprint_gui.proof.cameras import orbit_views

    size = (24.0, 10.7, 20.0)
    train = training_views(size, 6)
    assert [v.elevation_deg for v in train] == [35.0, 5.0] * 3
    proof = orbit_views(size, 4)
    assert {v.elevation_deg for v in proof} == {20.0}
    assert min(abs((t.azimuth_deg - p.azimuth_deg + 180.0) % 360.0 - 180.0)
               for t in train for p in proof) > 5.0
    assert {(v.half_mm, v.distance_mm) for v in train} == {(proof[0].half_mm,
                                                             proof[0].distance_mm)}
    assert [v.elevation_deg for v in training_views(size, 1)] == [35.0]
    assert [v.elevation_deg for v in training_views(size, 3)] == [35.0, 5.0, 35.0]
    assert [v.elevation_deg for v in training_views(size, 16)] == [35.0, 5.0] * 8
