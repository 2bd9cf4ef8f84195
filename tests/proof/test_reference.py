"""The proof's reference is the source as the job's rendering intent maps it (proof.reference):
closed forms of the relative intent, colorimetric unchanged, the runner's judge."""

import numpy as np
import pytest

from dreamprint_gui.core.profile import load_profile
from dreamprint_gui.gamut.forward import forward_model, mixtures_xyz
from dreamprint_gui.proof.reference import intent_reference, job_intent
from dreamprint_gui.proof.source_render import SourceField

PROFILE = load_profile(None).with_settings(layer_thickness_mm=0.027)


def _field(colour, sigma):
    colour = np.asarray(colour, np.float32)
    return SourceField(np.asarray(sigma, np.float32), colour, np.zeros(3), np.ones(3))


def test_relative_reference_of_white_is_the_printable_white_and_scales_with_it():
    """ICC media-relative: source white -> the printable white (here: White ink alone, the
    brightest mixture, found independently of the map's own lattice search), and a von Kries
    map is linear, so a grey at 20 % maps to 20 % of it; empty cells are left alone."""
    model = forward_model(PROFILE)
    lattice = np.eye(5)
    y = mixtures_xyz(model, lattice)[:, 1]
    white_xyz = mixtures_xyz(model, lattice)[int(np.argmax(y))]
    white_rgb = white_xyz @ np.asarray(model.xyz_to_rgb).T
    colour = np.zeros((1, 1, 3, 3), np.float32)
    colour[0, 0, 0] = 1.0
    colour[0, 0, 1] = 0.2
    colour[0, 0, 2] = 0.7
    field = _field(colour, [[[1.0, 2.0, 0.0]]])
    ref = intent_reference(field, "relative", PROFILE)
    assert ref.colour[0, 0, 0] == pytest.approx(white_rgb, abs=2e-3)
    assert ref.colour[0, 0, 1] == pytest.approx(0.2 * white_rgb, abs=5e-4)
    assert np.all(ref.colour[0, 0, 2] == 0.7)          # density 0: not seen, not mapped
    assert ref.sigma is field.sigma


def test_colorimetric_keeps_the_source_and_perceptual_lands_in_the_printable_range():
    rng = np.random.default_rng(1)
    field = _field(rng.random((4, 4, 4, 3)), rng.random((4, 4, 4)) + 0.1)
    assert intent_reference(field, "colorimetric", PROFILE) is field
    assert intent_reference(field, None, PROFILE) is field      # the default intent
    model = forward_model(PROFILE)
    top = mixtures_xyz(model, np.eye(5))[:, 1].max()
    ref = intent_reference(field, "perceptual", PROFILE)
    y = ref.colour.reshape(-1, 3) @ np.linalg.inv(np.asarray(model.xyz_to_rgb)).T[:, 1]
    assert y.max() <= top * 1.001            # no mapped colour lighter than the inks' white
    assert not np.allclose(ref.colour, field.colour)


def test_job_intent_from_the_tables_or_the_manifest():
    class Tables:
        intent = "relative"

    class Ctx:
        tables = Tables()

    class Engine:
        ctx = Ctx()

    class Folder:
        manifest = {"profile": {"intent": "perceptual"}}

    class OldFolder:
        manifest = {"profile": {}}

    assert job_intent(Engine()) == "relative"
    assert job_intent(Folder()) == "perceptual"
    assert job_intent(OldFolder()) == "colorimetric"


def _drive(gen):
    try:
        while True:
            next(gen)
    except StopIteration as stop:
        return stop.value


def test_the_proof_judges_against_the_intents_reference():
    """The runner's source image under --intent colorimetric is the source's own render (the
    judge as before); under relative the demo's object pixels are the relatively mapped ones,
    darker (the printable white is below the environment's), and proof.json says which."""
    from dreamprint_gui.job.plan import ConvertSettings
    from dreamprint_gui.proof.cameras import orbit_views
    from dreamprint_gui.proof.labels import EngineLabels
    from dreamprint_gui.proof.medium import block_for_cell
    from dreamprint_gui.proof.runner import ProofSettings, render_proof
    from dreamprint_gui.proof.source_render import render_source, sample_source

    tiny = dict(source="demo", height_mm=3.0, views=1, resolution=16, spp=2, max_cells=12,
                table_size=17, seed=3, noise_floor=False)
    out = {}
    for intent in ("colorimetric", "relative"):
        res = _drive(render_proof(ProofSettings(**tiny, intent=intent)))
        assert res["report"]["reference"]["intent"] == intent
        out[intent] = res["images"][0]["source"]
    ps = ProofSettings(**tiny)
    lab = EngineLabels(ConvertSettings.from_spec(ps.spec))
    size = tuple(n * v for n, v in zip(lab.shape_xyz, lab.voxel_mm, strict=True))
    block = block_for_cell(lab.voxel_mm, size, 12)
    cells = tuple(-(-n // b) for n, b in zip(lab.shape_xyz, block, strict=True))
    field = sample_source(lab.source, lab.grid, block, lab.density_scale, cells,
                          -0.5 * np.asarray(size))
    own, _ = render_source(field, orbit_views(size, 1)[0], 16)
    assert np.allclose(out["colorimetric"], own, atol=1e-6)
    assert out["relative"].mean() < out["colorimetric"].mean() - 0.01
