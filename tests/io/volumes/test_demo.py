"""The built-in demo (io/volumes/grids/demo.py) prints well at its default size: every colour
it holds is printable (checked by the gamut's direct solve, not the tables the demo's palette
came from), it holds solid, translucent and faint parts, and its pre-flight at 40 mm has no
warning."""

import numpy as np
import pytest

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.profile import default_profile
from dreamprint_gui.gamut.evaluation import IN_GAMUT_DE2000
from dreamprint_gui.gamut.forward import N_COLOUR_INKS, forward_model, mixtures_lab
from dreamprint_gui.gamut.optimise import solve, targets_for
from dreamprint_gui.io.volumes.grids import demo
from dreamprint_gui.io.volumes.registry import open_source
from dreamprint_gui.job.plan import ConvertSettings
from dreamprint_gui.job.preflight import preflight
from dreamprint_gui.physics.colorimetry import delta_E2000


def _de_to_printable(rgb: np.ndarray) -> np.ndarray:
    """dE2000 between each sRGB colour and the closest colour the built-in inks print."""
    model = forward_model(default_profile())
    conc, _, _ = solve(model, "de2000", np.asarray(rgb, float), np.full(N_COLOUR_INKS, 0.2),
                       max_iter=300)
    return delta_E2000(mixtures_lab(model, conc), targets_for(model, "cielab", rgb))


def test_palette_is_printable():
    de = _de_to_printable(np.vstack([demo.PALETTE, demo.PRINTABLE_WHITE]))
    assert de.max() <= IN_GAMUT_DE2000, de


def test_every_colour_it_holds_is_printable():
    sigma, rgb = demo.demo_fields(48)
    seen = sigma > 0.05
    cols = rgb[seen]
    pick = np.random.default_rng(1).choice(len(cols), 600, replace=False)
    de = _de_to_printable(cols[pick])
    assert np.mean(de > IN_GAMUT_DE2000) <= 0.01, np.sort(de)[-10:]


def test_solid_translucent_and_faint_parts():
    """Optical depth (at the design height) across the planet, the ring and the haze."""
    sigma, _ = demo.demo_fields(128)
    mm_per_cell = demo.DESIGN_HEIGHT_MM / (demo.occupied_height(sigma) * 128)
    k = int(demo.CENTRE[2] * 128)
    through_planet = sigma[k, 64, :].sum() * mm_per_cell
    assert through_planet > 30            # reads as solid
    assert sigma.max() <= demo.PLANET_PER_MM + 1e-6
    ring = sigma[(sigma > 0.5 * demo.RING_PER_MM) & (sigma < 1.1 * demo.RING_PER_MM)]
    assert ring.size > 1000               # the translucent ring is there
    haze = sigma[(sigma > 0.01) & (sigma < 0.6)]
    assert haze.size > 1000               # and the faint haze


def test_deterministic_and_bounded():
    a, b = open_source("demo"), open_source("demo")
    assert np.array_equal(a.volume.data, b.volume.data)
    assert a.bounds == ((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    with pytest.raises(DreamPrintError, match="demo resolution must be 8..512"):
        open_source("demo", resolution=4)


def test_prints_with_no_warning_at_the_default_size(tmp_path):
    pf = preflight(ConvertSettings(source="demo", height_mm=demo.DESIGN_HEIGHT_MM,
                                   table_size=33), sample_voxels=60_000)
    assert pf.warnings == [], [w.message for w in pf.warnings]
    assert pf.clamped_voxels == 0 and pf.out_of_gamut_fraction <= 0.01
    assert pf.ink_fraction > 0.02   # not a faint haze
