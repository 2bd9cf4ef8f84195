"""Material intent (--content), pre-flight estimates and warnings, the progress, the slice codes."""

import json
import math
import subprocess
import textwrap

import numpy as np
import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.printer import EMPTY_LABEL, load_printer, material_legend
from dreamprint_gui.core.profile import INKS
from dreamprint_gui.io.volumes import grid_for_source, open_source
from dreamprint_gui.job.content import SOLID_SIGMA, choose_content, is_binary_mask
from dreamprint_gui.job.encode.png_slices import read_png_labels
from dreamprint_gui.job.plan import ConvertSettings, prepare_job
from dreamprint_gui.job.preflight import preflight
from dreamprint_gui.job.run import run_conversion
from dreamprint_gui.job.slab import halftone_layer

TABLE = 9
CL = INKS.index("Cl")


@pytest.fixture(scope="module")
def knight(shared_data):
    return str(shared_data / "voxels" / "magicavoxel_chr_knight.vox")


def _occupied(spec, ctx, z, **options):
    """Printer voxels of layer z whose source voxel is filled: the plain (fog) source's density
    there is positive (nearest sampling: a filled .vox voxel or nothing)."""
    src = open_source(spec, **options)
    _, d = src.sample_slab(ctx.grid, z, z + 1)
    return d[0] > 0


def test_knight_auto_is_solid_ink_inside_clear_outside(knight):
    s = ConvertSettings(source=knight, height_mm=4.0, table_size=TABLE, content="auto")
    ctx = prepare_job(s)
    assert ctx.content.mode == "solid" and "voxel model" in ctx.content.reason
    nz = ctx.shape_xyz[2]
    ink_in = occ_n = 0
    for z in (nz // 4, nz // 2, 3 * nz // 4):
        lab = halftone_layer(s, z, ctx)
        occ = _occupied(knight, ctx, z)
        # solid: every occupied voxel prints undiluted colour (no Clear), every empty one Clear
        assert np.all(lab[~occ] == CL)
        ink_in += int(np.count_nonzero(lab[occ] != CL))
        occ_n += int(occ.sum())
    assert occ_n > 1000 and ink_in == occ_n
    # the same voxels as fog (today's density rule) were mostly Clear
    fog = ConvertSettings(source=knight, height_mm=4.0, table_size=TABLE, content="fog")
    fctx = prepare_job(fog)
    lab = halftone_layer(fog, nz // 2, fctx)
    occ = _occupied(knight, fctx, nz // 2)
    assert np.mean(lab[occ] != CL) < 0.8  # 10 mm: 0.2 (docs/physics.md)


def test_knight_cli_auto_job_interior_mostly_ink(knight, tmp_path, capsys):
    out = tmp_path / "K"
    assert main(["convert", knight, "-o", str(out), "--height-mm", "3", "--table-size",
                 str(TABLE), "--json"]) == 0
    cap = capsys.readouterr()
    m = json.loads(cap.out)
    assert m["source"]["content"] == {"mode": "solid", "requested": "auto",
                                      "reason": "a voxel model (.vox)"}
    assert "content: solid" in cap.err
    n = m["total_voxels"]
    ink = sum(m["voxel_counts"][k] for k in ("C", "M", "Y", "K", "W"))
    src = open_source(knight)
    from dreamprint_gui.io.volumes.orient import occupied_bounds

    # the job covers the knight's filled voxels (--fit occupied, the default)
    grid = grid_for_source(src, load_printer().voxel_mm, height_mm=3.0,
                           bounds=occupied_bounds(src))
    _, d = src.sample_slab(grid, 0, grid.shape_xyz[2])
    occupied = int(np.count_nonzero(d))
    # the job's ink voxels are its occupied voxels: its interior is ink, not Clear
    assert ink == occupied and m["voxel_counts"]["Cl"] == n - occupied
    # a slice as written: the pixels of occupied voxels are ink codes
    pal = load_printer().palette()
    z = grid.shape_xyz[2] // 2
    lab = read_png_labels(out / "slices" / f"{z:05d}.png", pal)
    assert np.array_equal(lab != CL, d[z] > 0)


def test_sampling_nearest_and_linear(knight):
    src = open_source(knight)
    grid = grid_for_source(src, (0.05, 0.05, 0.05), height_mm=4.0)  # 4 voxels per source one
    _, near = src.sample_slab(grid, 0, grid.shape_xyz[2])
    assert set(np.unique(near)) <= {0.0, np.float32(1.0 / grid.mm_per_unit)}
    lin = open_source(knight, sampling="linear")
    _, d = lin.sample_slab(grid, 0, grid.shape_xyz[2])
    mid = (d > 0.05 * near.max()) & (d < 0.95 * near.max())
    assert mid.sum() > 100  # smooth edges: partial densities
    # far from edges both agree; total mass is about the same (trilinear preserves it)
    assert abs(d.sum() - near.sum()) < 0.1 * near.sum()
    with pytest.raises(DreamPrintError, match="sampling"):
        open_source(knight, sampling="cubic")


def test_sampling_nearest_refused_for_a_trilinear_source(tmp_path):
    from dreamprint_gui.job.plan import source_options_for

    assert source_options_for("demo", {}, "fog", "linear") == {}
    with pytest.raises(DreamPrintError, match="voxel models"):
        source_options_for("demo", {}, "fog", "nearest")


WRITE_LS = textwrap.dedent('''
    import sys
    import pyopenvdb as vdb
    ls = vdb.createLevelSetSphere(radius=2.0, center=(0, 0, 0), voxelSize=0.1, halfWidth=3.0)
    ls.name = 'surface'
    vdb.write(sys.argv[1], [ls])
''')


@pytest.fixture(scope="module")
def level_set(tmp_path_factory, openvdb_python):
    out = tmp_path_factory.mktemp("ls")
    (out / "w.py").write_text(WRITE_LS)
    subprocess.run([openvdb_python, "-I", str(out / "w.py"), str(out / "sphere.vdb")],
                   check=True)
    return out / "sphere.vdb"


def test_level_set_auto_is_solid(level_set, tmp_path, capsys):
    with pytest.raises(DreamPrintError, match="level set"):  # fog: refused as before
        prepare_job(ConvertSettings(source=str(level_set), height_mm=2.0, table_size=TABLE,
                                    content="fog"))
    out = tmp_path / "S"
    assert main(["convert", str(level_set), "-o", str(out), "--height-mm", "1.5",
                 "--table-size", str(TABLE), "--json", "--quiet", "--fit", "box"]) == 0
    cap = capsys.readouterr()
    assert cap.err == ""  # --quiet: no summary, no warnings, no progress
    m = json.loads(cap.out)
    assert m["source"]["content"]["mode"] == "solid"
    assert "level set" in m["source"]["content"]["reason"]
    # the job's ink fraction is the sphere's share of its box (closed form)
    size = np.asarray(m["physical_size_mm"])
    b = open_source(level_set, level_set="solid").bounds  # the narrow band's box
    r_mm = 2.0 * 1.5 / (b[1][2] - b[0][2])  # radius 2 units; the box's z extent is 1.5 mm
    sphere = 4 / 3 * math.pi * r_mm ** 3
    ink = sum(m["voxel_counts"][k] for k in ("C", "M", "Y", "K", "W"))
    assert ink / m["total_voxels"] == pytest.approx(sphere / np.prod(size), rel=0.03)
    assert m["voxel_counts"]["Cl"] / m["total_voxels"] < 0.7


def _mhd(tmp_path, values):
    data = np.asarray(values, np.uint8)
    (tmp_path / "m.raw").write_bytes(data.tobytes())
    (tmp_path / "m.mhd").write_text(
        "ObjectType = Image\nNDims = 3\nDimSize = 8 8 8\nElementSpacing = 1 1 1\n"
        "ElementType = MET_UCHAR\nElementDataFile = m.raw\n")
    return tmp_path / "m.mhd"


def test_binary_mask_auto_solid_and_three_values_fog(tmp_path):
    v = np.zeros((8, 8, 8), np.uint8)
    v[2:6, 2:6, 2:6] = 200
    src = open_source(_mhd(tmp_path, v))
    assert is_binary_mask(src) == (0.0, 200.0)
    mode, reason = choose_content(src)
    assert mode == "solid" and "binary mask" in reason
    v[0, 0, 0] = 7
    src = open_source(_mhd(tmp_path, v))
    assert is_binary_mask(src) is None and choose_content(src)[0] == "fog"


def test_solid_source_marks_occupied_voxels(tmp_path):
    v = np.zeros((8, 8, 8), np.uint8)
    v[2:6, 2:6, 2:6] = 255
    ctx = prepare_job(ConvertSettings(source=str(_mhd(tmp_path, v)), height_mm=1.0,
                                      table_size=TABLE, content="auto"))
    assert ctx.content.mode == "solid"
    _, d = ctx.source.sample_slab(ctx.grid, 0, ctx.shape_xyz[2])
    assert set(np.unique(d)) <= {0.0, SOLID_SIGMA}
    # occupied where the trilinear mask reaches half (the iso-surface at the midpoint)
    _, plain = ctx.source.inner.sample_slab(ctx.grid, 0, ctx.shape_xyz[2])
    half = 0.5 * plain.max()
    assert np.array_equal(d > 0, plain >= half)


def test_alignment_reads_solid_as_undiluted_colour():
    from dreamprint_gui.core.profile import default_profile
    from dreamprint_gui.gamut import get_tables
    from dreamprint_gui.gamut.alignment import align_density, lookup_and_align_into
    from dreamprint_gui.gamut.tables import lookup

    prof = default_profile()
    tables = get_tables(prof, size=TABLE)
    rng = np.random.default_rng(1)
    rgb = rng.random((500, 3)).astype(np.float32)
    conc = np.empty((500, 6), np.float32)
    counts = lookup_and_align_into(tables, rgb, np.full(500, SOLID_SIGMA), conc)
    assert counts.n_clamped_low == counts.n_clamped_high == 0
    assert np.all(conc[:, CL] == 0)
    c5 = lookup(tables, rgb)
    np.testing.assert_allclose(conc[:, :5], c5, atol=2e-3)  # the node mixture, undiluted
    exact = align_density(tables, rgb, c5, np.full(500, float(SOLID_SIGMA)), prof)
    assert exact.n_clamped_high == 0 and np.all(exact.conc[:, CL] == 0)


def test_preflight_mostly_clear_and_gamut_warnings(knight):
    # the knight's whole declared box (--fit box): 95 % of it is empty, a faint fog
    pf = preflight(ConvertSettings(source=knight, height_mm=10.0, content="fog",
                                   table_size=TABLE, fit="box"))
    codes = {w.code for w in pf.warnings}
    assert "mostly-clear" in codes
    w = next(w for w in pf.warnings if w.code == "mostly-clear")
    assert w.numbers["clear_or_empty_fraction"] > 0.98
    assert pf.grid_shape[2] == pf.slices and pf.total_voxels == math.prod(pf.grid_shape)
    assert abs(sum(pf.fractions.values()) - 1) < 1e-9
    solid = preflight(ConvertSettings(source=knight, height_mm=10.0, content="auto",
                                      table_size=TABLE, fit="box"))
    assert "mostly-clear" not in {w.code for w in solid.warnings}
    assert solid.ink_fraction > 3 * pf.ink_fraction
    j = solid.to_json()
    assert j["content"]["mode"] == "solid" and json.dumps(j)
    assert any("content: solid" in line for line in solid.summary_lines())


def test_preflight_estimates_what_the_job_does(tmp_path):
    """Fractions, clamping and disk of the estimate against the finished job."""
    s = ConvertSettings(source="demo", output=tmp_path / "J", height_mm=1.2, table_size=TABLE,
                        density_scale=50.0, workers=1)
    ctx = prepare_job(s)
    pf = preflight(ctx, sample_voxels=60_000)
    gen = run_conversion(s, context=ctx, preflight=pf)
    events = []
    while True:
        try:
            events.append(next(gen))
        except StopIteration as stop:
            m = stop.value
            break
    n = m["total_voxels"]
    for lab in (*INKS, "empty"):
        p = m["voxel_counts"][lab] / n
        se = math.sqrt(max(p * (1 - p), 1e-6) / pf.sampled_voxels)
        assert abs(pf.fractions[lab] - p) < 5 * se + 0.01, lab
    actual = m["clamped_density"]["n_clamped_high"]
    assert actual > 0 and pf.clamped_voxels == pytest.approx(actual, rel=0.15)
    warn = {w["code"]: w for w in m["warnings"]}
    assert "clamped" in warn and m["preflight"]["clamped_voxels_estimate"] == pf.clamped_voxels
    safe = warn["clamped"]["numbers"]["density_scale_without_clamping"]
    assert 0 < safe < 50
    disk = sum(p.stat().st_size for p in (tmp_path / "J").rglob("*") if p.is_file())
    assert pf.disk_bytes == pytest.approx(disk, rel=0.5)
    # the progress moves with the slabs: >= 32 steps when there are as many layers
    steps = [e.layers_done for e in events if e.stage == "converting" and e.layers_done]
    nz = m["grid_dimensions"][2]
    assert len(steps) == len(range(0, nz, -(-nz // 32))) and steps == sorted(steps)
    # at the scale the warning names, the estimate finds no clamping
    again = preflight(ConvertSettings(source="demo", height_mm=1.2, table_size=TABLE,
                                      density_scale=safe * 0.999), sample_voxels=60_000)
    assert again.clamped_voxels == 0 and "clamped" not in {w.code for w in again.warnings}


def test_cli_prints_warnings_and_clamping(tmp_path, capsys):
    args = ["convert", "demo", "-o", str(tmp_path / "D"), "--height-mm", "0.8", "--table-size",
            str(TABLE), "--density-scale", "50"]
    assert main(args) == 0
    err = capsys.readouterr().err
    assert "warning: about" in err and "--density-scale" in err
    assert "clamped:" in err and "too dense" in err
    assert main([*args[:3], str(tmp_path / "Q"), *args[4:], "--quiet"]) == 0
    cap = capsys.readouterr()
    assert cap.err == "" and cap.out.startswith("wrote")


def test_material_codes_distinct_and_one_definition():
    colour = pytest.importorskip("colour")
    p = load_printer()
    legend = material_legend(p)
    assert [lab for lab, _, _ in legend] == [*INKS, "empty"]
    assert np.array_equal(np.array([rgb for _, _, rgb in legend], np.uint8), p.palette())

    def lab(c):
        return colour.XYZ_to_Lab(colour.sRGB_to_XYZ(np.asarray(c, float) / 255))

    codes = {k: rgb for k, _, rgb in legend}
    # slices carry the Voxel Print legend's code for VeroClear; the screen shows a colour that
    # is told apart from every other at a glance (the code is dE2000 8.7 from White)
    assert codes["Cl"] == (227, 233, 253)
    shown = {k: rgb for k, _, rgb in material_legend(p, display=True)}
    assert shown["Cl"] == (150, 190, 225)
    assert {k: v for k, v in shown.items() if k != "Cl"} == {k: v for k, v in codes.items()
                                                             if k != "Cl"}
    assert len(set(codes.values())) == len(codes)  # a slice can be read back
    for other in ("C", "M", "Y", "K", "W", "empty"):
        de = float(colour.delta_E(lab(shown["Cl"]), lab(shown[other]), method="CIE 2000"))
        assert de > 15, (other, de)
    for name in ("voxelprint-14um", "voxelprint-27um", "j850-paper"):
        assert load_printer(name).palette()[CL].tolist() == list(codes["Cl"])
        assert load_printer(name).display_palette()[CL].tolist() == list(shown["Cl"])
    assert EMPTY_LABEL == len(INKS)


def test_solid_forced_on_a_dense_fog_takes_the_solid_rule():
    """A dense grid's fused path (layer_plan) must not bypass the solid rule."""
    s = ConvertSettings(source="demo", height_mm=0.6, table_size=TABLE, content="solid")
    ctx = prepare_job(s)
    assert ctx.content.mode == "solid" and "auto would pick fog" in ctx.content.reason
    z = ctx.shape_xyz[2] // 2
    lab = halftone_layer(s, z, ctx)
    _, d = open_source("demo").sample_slab(ctx.grid, z, z + 1)
    occupied = d[0] >= ctx.halftoner.threshold
    assert occupied.any() and np.array_equal(lab != CL, occupied)

