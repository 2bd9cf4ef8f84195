"""The appearance correction a job applies (job/correction.py): file, refusals, application."""

import hashlib
import json

import numpy as np
import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.job.correction import (
    Correction,
    apply_correction,
    load_correction,
    placement_key,
    rendering_key,
    save_correction,
    source_fingerprint,
)
from dreamprint_gui.job.plan import ConvertSettings, prepare_job
from dreamprint_gui.job.run import run_conversion

H = 2.0


def _settings(out=None, **kw):
    base = dict(source="demo", output=None if out is None else str(out), height_mm=H,
                table_size=17, seed=3)
    base.update(kw)
    return ConvertSettings(**base)


def _matching(gain, **over):
    ctx = prepare_job(_settings())
    size = tuple(n * v for n, v in zip(ctx.shape_xyz, ctx.printer.voxel_mm, strict=True))
    kw = dict(source="demo", source_fingerprint=source_fingerprint("demo"), print_size_mm=size,
              printer=ctx.printer.name, profile_fingerprint=ctx.profile_fingerprint,
              background="clear", report={"figures": {"before": {"mean_de2000": 9.0}}},
              placement=placement_key(ctx))
    kw.update(over)
    return Correction(np.asarray(gain, np.float32), **kw)


def _run(settings):
    gen = run_conversion(settings)
    try:
        while True:
            next(gen)
    except StopIteration as stop:
        return stop.value


def _slice_hashes(job):
    return [hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted((job / "slices").iterdir())]


def test_round_trip(tmp_path):
    rng = np.random.default_rng(1)
    corr = _matching(rng.uniform(0.5, 2.0, (3, 4, 5, 4)))
    save_correction(corr, tmp_path / "c.npz")
    back = load_correction(tmp_path / "c.npz")
    np.testing.assert_array_equal(back.gain, corr.gain)
    assert back.meta() == corr.meta()
    assert [p.name for p in tmp_path.iterdir()] == ["c.npz"]  # no temporary left


@pytest.mark.parametrize("damage, words", [
    ("missing", "no such"), ("garbage", "not a DreamPrint correction"),
    ("format", "not a DreamPrint correction"), ("version", "version"),
    ("shape", "shape"), ("negative", "negative"), ("field", "malformed")])
def test_bad_files_are_refused_in_one_line(tmp_path, damage, words):
    p = tmp_path / "c.npz"
    gain = np.ones((2, 2, 2, 4), np.float32)
    meta = _matching(gain).meta()
    if damage == "garbage":
        p.write_bytes(b"not a zip at all")
    elif damage != "missing":
        if damage == "format":
            meta["format"] = "something-else"
        if damage == "version":
            meta["version"] = 99
        if damage == "shape":
            gain = np.ones((2, 2, 2, 3), np.float32)
        if damage == "negative":
            gain[0, 0, 0, 1] = -1
        if damage == "field":
            del meta["printer"]
        np.savez(p, gain=gain, meta=np.array(json.dumps(meta)))
    with pytest.raises(DreamPrintError) as e:
        load_correction(p)
    assert words in str(e.value) and "\n" not in str(e.value)


@pytest.mark.parametrize("field, value, words", [
    ("source_fingerprint", "0123", "another source"),
    ("print_size_mm", (1.0, 2.0, 3.0), "print of 1.00 x 2.00 x 3.00 mm"),
    ("printer", "voxelprint-14um", "printer"),
    ("profile_fingerprint", "x", "ink profile"),
    ("background", "empty", "--background empty"),
    ("placement", "{}", "orientation")])
def test_mismatched_corrections_are_refused(tmp_path, capsys, field, value, words):
    p = tmp_path / "c.npz"
    save_correction(_matching(np.ones((2, 2, 2, 4)), **{field: value}), p)
    with pytest.raises(DreamPrintError, match=words):
        prepare_job(_settings(compensation=str(p)))
    code = main(["convert", "demo", "-o", str(tmp_path / "job"), "--height-mm", str(H),
                 "--table-size", "17", "--compensation", str(p), "-q"])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("dreamprint: error:") and err.count("\n") == 1
    assert not (tmp_path / "job").exists()


@pytest.mark.parametrize("field, value, option", [
    ("intent", "relative", "--intent"), ("objective", "srgb", "--objective"),
    ("content", "solid", "--content")])
def test_a_correction_made_under_another_rendering_is_refused(tmp_path, capsys, field, value,
                                                              option):
    """Made under another intent, objective or content than the job's: one line, no job."""
    ctx = prepare_job(_settings())
    made = rendering_key(ctx)
    assert made[field] != value
    p = tmp_path / "c.npz"
    save_correction(_matching(np.ones((2, 2, 2, 4)), rendering={**made, field: value}), p)
    assert load_correction(p).rendering == {**made, field: value}
    with pytest.raises(DreamPrintError, match=f"made with {option} {value}, this job has "
                                              f"{made[field]}"):
        prepare_job(_settings(compensation=str(p)))
    code = main(["convert", "demo", "-o", str(tmp_path / "job"), "--height-mm", str(H),
                 "--table-size", "17", "--compensation", str(p), "-q"])
    err = capsys.readouterr().err
    assert code == 2 and option in err and err.count("\n") == 1
    assert not (tmp_path / "job").exists()
    # the job made under the correction's own choices takes it
    assert prepare_job(_settings(compensation=str(p), **{field: value})).correction is not None


def test_a_correction_without_recorded_rendering_counts_as_made_under_the_defaults(tmp_path):
    """Files written before the rendering was recorded were trained under content auto and the
    profile's objective and intent: taken by such a job, refused by one with other choices."""
    p = tmp_path / "c.npz"
    save_correction(_matching(np.ones((2, 2, 2, 4))), p)
    meta = json.loads(str(np.load(p)["meta"]))
    del meta["rendering"]
    np.savez(p, gain=np.ones((2, 2, 2, 4), np.float32), meta=np.array(json.dumps(meta)))
    assert load_correction(p).rendering is None
    assert prepare_job(_settings(compensation=str(p))).correction is not None
    # "fog" is what auto picks for the demo, so it is the default's content too
    assert prepare_job(_settings(compensation=str(p), content="fog")).correction is not None
    with pytest.raises(DreamPrintError, match=r"--intent colorimetric \(the defaults"):
        prepare_job(_settings(compensation=str(p), intent="relative"))


def test_identity_leaves_the_samples_and_the_slices_unchanged(tmp_path):
    rng = np.random.default_rng(2)
    rgb = rng.uniform(0, 1, (3, 5, 7, 3)).astype(np.float32)
    dens = rng.uniform(0, 30, (3, 5, 7)).astype(np.float32)
    r2, d2 = rgb.copy(), dens.copy()
    apply_correction(np.ones((4, 3, 2, 4), np.float32), (7, 5, 9), 2, r2, d2)
    assert r2.tobytes() == rgb.tobytes() and d2.tobytes() == dens.tobytes()
    p = tmp_path / "id.npz"
    save_correction(_matching(np.ones((3, 3, 3, 4))), p)
    a = _run(_settings(tmp_path / "a"))
    b = _run(_settings(tmp_path / "b", compensation=str(p)))
    assert _slice_hashes(tmp_path / "a") == _slice_hashes(tmp_path / "b")
    assert a["compensation"] is None and b["compensation"]["path"] == str(p.absolute())


def _decode(c):  # IEC 61966-2-1, written out independently of the module
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _encode(v):
    v = np.clip(v, 0, 1)
    return np.where(v <= 0.0031308, 12.92 * v, 1.055 * v ** (1 / 2.4) - 0.055)


def test_uniform_correction_scales_linear_colour_and_density():
    rng = np.random.default_rng(3)
    rgb = rng.uniform(0, 1, (2, 6, 4, 3)).astype(np.float32)
    dens = rng.uniform(0, 30, (2, 6, 4)).astype(np.float32)
    dens[0, 0, 0] = 0.0  # empty: untouched
    g = np.empty((3, 3, 3, 4), np.float32)
    g[...] = (0.5, 1.5, 0.25, 2.0)
    r2, d2 = rgb.copy(), dens.copy()
    apply_correction(g, (4, 6, 10), 4, r2, d2)
    lin = _decode(rgb.astype(np.float64)) * np.array([0.5, 1.5, 0.25])
    # a colour pushed above 1 is scaled down as a whole (its chromaticity kept), not clipped
    want = _encode(lin / np.maximum(lin.max(axis=-1, keepdims=True), 1.0))
    fg = dens > 0
    np.testing.assert_allclose(r2[fg], want[fg], atol=2e-6)
    np.testing.assert_array_equal(r2[~fg], rgb[~fg])
    np.testing.assert_allclose(d2, 2.0 * dens, rtol=1e-6)


def test_a_gain_above_the_top_keeps_the_asked_chromaticity():
    # white asked 10 % brighter in blue than in red: it cannot be brighter, so it becomes the
    # white whose linear R : G : B are 1 : 1.05 : 1.1 (a bluish white the print can show),
    # where clipping each channel would have left it white
    g = np.empty((1, 1, 1, 4), np.float32)
    g[...] = (1.0, 1.05, 1.1, 1.0)
    rgb = np.ones((1, 1, 2, 3), np.float32)
    rgb[0, 0, 1] = (0.2, 0.4, 0.6)
    apply_correction(g, (2, 1, 1), 0, rgb, np.ones((1, 1, 2), np.float32))
    np.testing.assert_allclose(_decode(rgb[0, 0, 0].astype(np.float64)),
                               [1 / 1.1, 1.05 / 1.1, 1.0], atol=1e-6)
    # a colour that stays inside keeps each channel's own factor
    np.testing.assert_allclose(_decode(rgb[0, 0, 1].astype(np.float64)),
                               _decode(np.array([0.2, 0.4, 0.6])) * [1.0, 1.05, 1.1],
                               atol=1e-6)


def test_field_is_trilinear_between_cell_centres():
    # a field varying along x only: density factor 1 at the first cell centre, 3 at the last
    g = np.ones((1, 1, 2, 4), np.float32)
    g[0, 0, 1, 3] = 3.0
    nx = 8
    dens = np.ones((1, 1, nx), np.float32)
    apply_correction(g, (nx, 1, 1), 0, np.full((1, 1, nx, 3), 0.5, np.float32), dens)
    u = np.clip((np.arange(nx) + 0.5) / nx * 2 - 0.5, 0, 1)  # cell coordinate, clamped
    np.testing.assert_allclose(dens[0, 0], 1 + 2 * u, rtol=1e-6)


def test_corrected_job_is_deterministic_for_any_worker_count(tmp_path):
    rng = np.random.default_rng(4)
    p = tmp_path / "c.npz"
    save_correction(_matching(rng.uniform(0.6, 1.6, (3, 3, 3, 4))), p)
    _run(_settings(tmp_path / "plain"))
    m1 = _run(_settings(tmp_path / "w1", compensation=str(p), workers=1))
    _run(_settings(tmp_path / "w2", compensation=str(p), workers=2, slab_layers=3))
    h1 = _slice_hashes(tmp_path / "w1")
    assert h1 == _slice_hashes(tmp_path / "w2")
    assert h1 != _slice_hashes(tmp_path / "plain")  # the correction did change the print
    assert m1["compensation"]["density_gain_range"][1] > 1.0


def test_a_solid_voxel_stays_solid_under_a_density_gain():
    """Solid content's density is the sentinel SOLID_SIGMA (the colour's undiluted mixture):
    a gain below 1 used to turn it into a 'too dense' target, reported as "short by up to
    1e+30/mm" (issue 46). It stays solid; a fog voxel beside it is scaled."""
    from dreamprint_gui.job.content import SOLID_SIGMA

    rgb = np.full((1, 2, 2, 3), 0.5, np.float32)
    dens = np.array([[[SOLID_SIGMA, 4.0], [SOLID_SIGMA, 0.0]]], np.float32)
    g = np.empty((2, 2, 2, 4), np.float32)
    g[...] = (1.0, 1.0, 1.0, 0.5)
    d2 = dens.copy()
    apply_correction(g, (2, 2, 1), 0, rgb.copy(), d2)
    np.testing.assert_array_equal(d2, [[[SOLID_SIGMA, 2.0], [SOLID_SIGMA, 0.0]]])


def test_a_correction_made_under_another_background_threshold_is_refused(tmp_path, capsys):
    """The threshold decides which voxels are background (and what a solid's surface is): a
    correction trained under another is refused in one line; a file that records none was
    made under the default (half of pure Clear's density), as every correction was before."""
    ctx = prepare_job(_settings())
    default = float(ctx.halftoner.threshold)
    p = tmp_path / "c.npz"
    save_correction(_matching(np.ones((2, 2, 2, 4)), density_threshold=default * 2), p)
    assert load_correction(p).density_threshold == default * 2
    with pytest.raises(DreamPrintError, match=r"background threshold of .*/mm, this job has"):
        prepare_job(_settings(compensation=str(p)))
    code = main(["convert", "demo", "-o", str(tmp_path / "job"), "--height-mm", str(H),
                 "--table-size", "17", "--compensation", str(p), "-q"])
    err = capsys.readouterr().err
    assert code == 2 and "--density-threshold" in err and err.count("\n") == 1
    assert not (tmp_path / "job").exists()
    assert prepare_job(_settings(compensation=str(p), density_threshold=default * 2)
                       ).correction is not None
    # a file from before the threshold was recorded: the default's
    save_correction(_matching(np.ones((2, 2, 2, 4))), p)
    assert load_correction(p).density_threshold is None
    assert prepare_job(_settings(compensation=str(p))).correction is not None
    with pytest.raises(DreamPrintError, match=r"\(the default: the file predates"):
        prepare_job(_settings(compensation=str(p), density_threshold=default / 2))
