"""`dreamprint target wedge` (issue 43): slabs of each ink and thickness as a checked job."""

import csv
import json
import re

import numpy as np
import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.core.printer import load_printer
from dreamprint_gui.core.profile import INKS, default_profile, load_profile
from dreamprint_gui.job.check import check_job
from dreamprint_gui.job.encode.png_slices import read_png_labels
from dreamprint_gui.physics.slab_fit import simulate_slabs


def run(capsys, *args):
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def test_wedge_job_slabs_labels_and_sheet(tmp_path, capsys):
    job = tmp_path / "wedge"
    code, out, err = run(capsys, "target", "wedge", "-o", str(job), "--inks", "cl,W",
                         "--thickness-mm", "0.5,1", "--slab-mm", "8")
    assert code == 0, err
    assert "4 slabs" in out and "Cl 0.5 mm: 19 layers = 0.513 mm" in out
    report = check_job(job)
    assert report["consistent"], report["problems"]
    m = json.loads((job / "manifest.json").read_text())
    prn = load_printer("voxelprint-27um")
    nx, ny, nz = m["grid_dimensions"]
    assert nz == 37  # 1 mm / 27 um
    rows = list(csv.DictReader(open(job / "wedge-sheet.csv")))
    assert [(r["ink"], r["nominal_mm"], r["layers"]) for r in rows] == [
        ("Cl", "0.5", "19"), ("Cl", "1.0", "37"), ("W", "0.5", "19"), ("W", "1.0", "37")]
    vx, vy, _ = prn.voxel_mm
    for z, present in ((0, 4), (18, 4), (19, 2), (36, 2)):
        lab = read_png_labels(job / "slices" / f"{z:05d}.png", prn.palette())
        found = 0
        for r in rows:
            cx = int(float(r["centre_x_mm"]) / vx)
            cy = int(float(r["centre_y_mm"]) / vy)
            block = lab[cy - 40:cy + 40, cx - 80:cx + 80]  # 6.8 mm of the 8 mm slab
            if z < int(r["layers"]):
                assert np.all(block == INKS.index(r["ink"]))
                found += 1
            else:
                assert np.all(block == 6)  # empty above a thinner slab
        assert found == present
    # the label tabs: White with Black glyphs, in the slices' margin only
    lab0 = read_png_labels(job / "slices" / "00000.png", prn.palette())
    counts = np.bincount(lab0.ravel(), minlength=7)
    assert counts[INKS.index("K")] > 500 and counts[INKS.index("W")] > counts[INKS.index("Cl")]
    template = (job / "slabs-template.toml").read_text()
    assert template.count("[[layer]]") == 4 and 'sample = "Cl 0.5 mm"' in template
    assert (job / "wedge-sheet.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("args, message", [
    (("--inks", "Cl,Z"), "unknown ink 'Z' in --inks"),
    (("--thickness-mm", "1,0"), "--thickness-mm must be numbers > 0"),
    (("--thickness-mm", "1,two"), "--thickness-mm must be numbers in mm"),
    (("--slab-mm", "2"), "--slab-mm must be at least 5 mm"),
    (("--thickness-mm", "300"), "tray"),
    (("--thickness-mm", "1,0.5,1"), "--thickness-mm 1 and 1 both print 37 layer(s), 0.999 mm"),
    (("--thickness-mm", "0.01,0.02"), "0.01 and 0.02 both print 1 layer(s)"),
])
def test_wedge_bad_input_one_line_no_folder(tmp_path, capsys, args, message):
    job = tmp_path / "w"
    code, _, err = run(capsys, "target", "wedge", "-o", str(job), *args)
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1
    assert not job.exists() and not list(tmp_path.iterdir())


def test_filled_template_is_what_calibrate_slabs_reads(tmp_path, capsys):
    """The operator's path: the wedge's slabs-template.toml, its R and T lines filled with
    instrument files (CGATS, one sample per slab, named as the template names them), is the
    calibration set `calibrate --slabs` fits; a Clear's K comes back at the printed
    thicknesses the template states."""
    job = tmp_path / "wedge"
    code, _, err = run(capsys, "target", "wedge", "-o", str(job), "--inks", "Cl",
                       "--thickness-mm", "1,2,4", "--slab-mm", "5")
    assert code == 0, err
    text = (job / "slabs-template.toml").read_text()
    thick = [float(x) for x in re.findall(r"thickness_mm = ([0-9.]+)", text)]
    labels = re.findall(r'# R = \{ file = "FILE", sample = "([^"]+)" \}', text)
    assert labels == ["Cl 1 mm", "Cl 2 mm", "Cl 4 mm"] and thick == [0.999, 1.998, 3.996]
    wl = default_profile().wavelengths_nm
    K = 0.02 + 0.25 * np.exp(-(wl - 380.0) / 25.0)
    slabs = simulate_slabs("Cl", K, np.full(wl.size, 0.05), thick, 0.04, 0.596, 0.002,
                           np.random.default_rng(0))
    head = "\t".join(f"SPECTRAL_NM{w:.0f}" for w in wl)
    for q in ("R", "T"):
        rows = "".join(f'"{lab}"\t' + "\t".join(f"{100 * v:.5f}" for v in getattr(m, q)) + "\n"
                       for lab, m in zip(labels, slabs, strict=True))
        (job / f"{q}.txt").write_text(
            f"CGATS.17\nNUMBER_OF_FIELDS\t{wl.size + 1}\nBEGIN_DATA_FORMAT\nSAMPLE_NAME\t{head}\n"
            f"END_DATA_FORMAT\nNUMBER_OF_SETS\t{len(slabs)}\nBEGIN_DATA\n{rows}END_DATA\n")
    filled = (text.replace('# R = { file = "FILE"', 'R = { file = "R.txt"')
              .replace('# T = { file = "FILE"', 'T = { file = "T.txt"'))
    (job / "slabs.toml").write_text(filled)
    out = tmp_path / "p.json"
    code, stdout, err = run(capsys, "calibrate", str(job / "slabs.toml"), "--slabs", "-o",
                            str(out))
    assert code == 0, err
    assert "Cl: 3 slab(s)" in stdout and "DOES NOT FIT" not in stdout
    band = (wl >= 450) & (wl <= 700)
    got = load_profile(out).K[INKS.index("Cl")]
    assert np.max(np.abs(got / K - 1)[band]) < 0.05
