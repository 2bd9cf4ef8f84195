"""The proof's print is the mean of two halves of its samples; its noise floor is taken
between them (proof.runner with print_render.render_print_halves, compare.noise_floor_from_halves).
"""

import numpy as np

from dreamprint_gui.proof import compare, runner
from dreamprint_gui.proof import print_render as pr
from dreamprint_gui.proof.runner import ProofSettings, render_proof

TINY = dict(source="demo", height_mm=3.0, views=1, resolution=16, spp=4, max_cells=12,
            table_size=17, seed=3)


def _run(s):
    gen = render_proof(s)
    try:
        while True:
            next(gen)
    except StopIteration as stop:
        return stop.value


def test_the_print_is_the_mean_of_the_halves_and_the_floor_is_between_them(monkeypatch):
    halves, xyz_of, floors = [], [], []
    real_seeds, real_xyz = pr.render_print_seeds, runner.print_xyz
    real_floor = runner.noise_floor_from_halves

    def seeds_spy(*a, **k):
        out = real_seeds(*a, **k)
        halves.append((a[7], out[0]))          # (seeds, images per seed)
        return out

    def xyz_spy(bands, rendered, T, *a):
        xyz_of.append((np.array(rendered, np.float64), T))
        return real_xyz(bands, rendered, T, *a)

    def floor_spy(xa, xb, *a, **k):
        floors.append((xa, xb))
        return real_floor(xa, xb, *a, **k)

    monkeypatch.setattr(pr, "render_print_seeds", seeds_spy)
    monkeypatch.setattr(runner, "print_xyz", xyz_spy)
    monkeypatch.setattr(runner, "noise_floor_from_halves", floor_spy)
    res = _run(ProofSettings(**TINY))
    rep = res["report"]
    (seeds, (a, b)), = halves
    assert seeds == (3, 4) and rep["noise_floor"]["seeds"] == [3, 4]
    # the print's image: the mean of the two halves (the first band image made into XYZ)
    assert np.allclose(xyz_of[0][0], (a[0].astype(np.float64) + b[0]) / 2, atol=1e-7)
    # the floor: between the halves' own XYZ, and what proof.json reports
    xa, xb = floors[0]
    T = xyz_of[0][1]
    np.testing.assert_allclose(xa, real_xyz(runner.spectral_bands(
        runner._labels(ProofSettings(**TINY)).profile, 12), a[0], T, False), atol=1e-9)
    assert not np.allclose(xa, xb)
    assert rep["views"][0]["noise_floor"]["mean_scielab_de2000"] > 0
    assert rep["renderer"]["pass_spp"] == [4, 4, 4, 2]
    assert rep["renderer"]["halves"]["pass_spp"] == [2, 2, 2, 1]


def test_without_the_floor_the_proof_is_the_same_at_the_same_cost():
    """--no-noise-floor reports no floor; the print and its figures are those of the proof
    with it (the same two halves are rendered)."""
    on = _run(ProofSettings(**TINY))
    off = _run(ProofSettings(**TINY, noise_floor=False))
    assert off["report"]["noise_floor"] is None and on["report"]["noise_floor"]
    np.testing.assert_array_equal(on["images"][0]["print"], off["images"][0]["print"])
    assert on["report"]["overall"] == off["report"]["overall"]
    assert compare.FLOOR_KEYS[0] in on["report"]["noise_floor"]
