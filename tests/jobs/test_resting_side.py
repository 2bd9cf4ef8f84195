"""A source whose up axis is a guess is stood as it would rest (issue 46, io/volumes/stand.py):
on its largest flat side, else on its longest axis, else the kind's convention; said in one
line with --up. Synthetic Gaussian splats written as INRIA PLY with no cameras.json (whose
convention, COLMAP's y down, would stand a donut lying in the file's y-z plane on its rim)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from plyfile import PlyData, PlyElement

from dreamprint_gui.cli import main
from dreamprint_gui.io.volumes import open_source
from dreamprint_gui.io.volumes.orient import choose_orientation
from dreamprint_gui.io.volumes.splats.cloud import SH_C0

SIGMA = 0.04


def _write_ply(path, means) -> str:
    """Isotropic opaque Gaussians (sigma SIGMA, opacity 0.9, grey) at ``means``, INRIA PLY."""
    names = (["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2", "opacity"]
             + [f"scale_{i}" for i in range(3)] + [f"rot_{i}" for i in range(4)])
    arr = np.zeros(len(means), [(k, "f4") for k in names])
    for i, k in enumerate("xyz"):
        arr[k] = means[:, i]
    for i in range(3):
        arr[f"f_dc_{i}"] = (0.6 - 0.5) / SH_C0
        arr[f"scale_{i}"] = np.log(SIGMA)
    arr["rot_0"] = 1.0
    arr["opacity"] = np.log(0.9 / 0.1)
    PlyData([PlyElement.describe(arr, "vertex")]).write(str(path))
    return str(path)


def _fill(inside, lo, hi, n, seed=0) -> np.ndarray:
    """``n`` points uniform in the solid ``inside(p) -> bool`` within the box lo..hi."""
    rng = np.random.default_rng(seed)
    out = []
    while sum(len(o) for o in out) < n:
        p = rng.uniform(lo, hi, (20000, 3))
        out.append(p[inside(p)])
    return np.concatenate(out)[:n]


def _torus(axis: int, big=1.0, tube=0.35):
    """A donut whose hole runs along source ``axis``."""
    def inside(p):
        a = p[:, axis]
        r = np.linalg.norm(np.delete(p, axis, 1), axis=1)
        return (r - big) ** 2 + a ** 2 <= tube ** 2
    e = big + tube
    return _fill(inside, (-e, -e, -e), (e, e, e), 6000)


def _figure(axis: int, sign: int, base: bool):
    """A tall figure about 3 units high along ``sign`` * ``axis``, its head at the top: on a
    flat round plinth (radius 0.7, 0.2 thick) with ``base``, a robe widening to its hem (radius
    0.3 at the shoulders, 0.55 at the hem); without, a rounded body (an ellipsoid 1 x 1 x 2.4),
    no flat side anywhere."""
    def inside(p):
        h = p[:, 2]
        r = np.linalg.norm(p[:, :2], axis=1)
        head = np.linalg.norm(p - (0, 0, 2.65), axis=1) <= 0.3
        if not base:
            body = np.linalg.norm((p - (0, 0, 1.3)) / (0.5, 0.5, 1.2), axis=1) <= 1.0
            return body | head
        robe = (h >= 0.2) & (h <= 2.3) & (r <= 0.55 - 0.25 * (h - 0.2) / 2.1)
        plinth = (h >= 0) & (h < 0.2) & (r <= 0.7)
        return robe | head | plinth
    p = _fill(inside, (-0.7, -0.7, 0.0), (0.7, 0.7, 2.95), 5000, seed=1)
    if sign < 0:
        p[:, 2] = 2.95 - p[:, 2]
    return p[:, _onto(axis)]


def _onto(axis: int) -> list[int]:
    """Column order that puts the points' third coordinate (the height) on source ``axis``."""
    return {0: [2, 0, 1], 1: [0, 2, 1], 2: [0, 1, 2]}[axis]


def _up(path) -> tuple[str, str]:
    o = choose_orientation(open_source(path), None, 0)
    assert o.auto and o.guessed
    return o.up, o.describe()


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_a_donut_lies_flat_whichever_way_the_file_holds_it(tmp_path, axis):
    up, text = _up(_write_ply(tmp_path / "donut.ply", _torus(axis)))
    assert up.lstrip("-") == "xyz"[axis], text
    if axis == 1:   # lying flat as COLMAP's y down has it: the convention's side is kept
        assert up == "-y"
    assert "a guess: no cameras.json beside it; it stands on its largest flat side" in text
    assert text.endswith("--up changes it)")


@pytest.mark.parametrize("axis, sign", [(0, 1), (2, -1), (1, 1)])
def test_a_tall_figure_on_a_plinth_stands_on_it(tmp_path, axis, sign):
    up, text = _up(_write_ply(tmp_path / "fig.ply", _figure(axis, sign, base=True)))
    assert up == ("" if sign > 0 else "-") + "xyz"[axis], text
    assert "largest flat side" in text


@pytest.mark.parametrize("axis, sign", [(0, -1), (2, 1), (1, -1)])
def test_a_tall_figure_with_no_flat_side_stands_on_its_longest_axis(tmp_path, axis, sign):
    up, text = _up(_write_ply(tmp_path / "fig.ply", _figure(axis, sign, base=False)))
    assert up == ("" if sign > 0 else "-") + "xyz"[axis], text
    assert "no flat side; it stands on its longest axis" in text


def test_a_round_blob_keeps_the_convention_and_says_so(tmp_path):
    ball = _fill(lambda p: np.linalg.norm(p, axis=1) <= 1.0, (-1,) * 3, (1,) * 3, 5000)
    up, text = _up(_write_ply(tmp_path / "ball.ply", ball))
    assert up == "-y"
    assert "no flat side or long axis, so COLMAP's frame, y down" in text


def test_the_guess_is_one_line_in_inspect_and_the_job(tmp_path, capsys):
    ply = _write_ply(tmp_path / "donut.ply", _torus(0))
    assert main(["inspect", ply, "--json"]) == 0
    place = json.loads(capsys.readouterr().out)["placement"]
    assert place["orientation"]["up"] in ("x", "-x")
    lo, hi = np.asarray(place["fit_bounds"])
    ext = hi - lo
    assert ext[2] < 0.4 * ext[0] and ext[2] < 0.4 * ext[1]   # lies flat: low and wide
    assert main(["inspect", ply]) == 0
    lines = [ln for ln in capsys.readouterr().out.splitlines() if "orientation" in ln]
    assert len(lines) == 1 and "largest flat side" in lines[0] and "--up" in lines[0]
    assert main(["inspect", ply, "--up", "-y", "--json"]) == 0   # --up overrides the guess
    place = json.loads(capsys.readouterr().out)["placement"]
    assert place["orientation"]["up"] == "-y" and not place["orientation"]["auto"]
