"""`dreamprint target wedge` (issue 43): slabs of each ink and thickness as a checked job."""

import csv
import json

import numpy as np
import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.core.printer import load_printer
from dreamprint_gui.core.profile import INKS
from dreamprint_gui.job.check import check_job
from dreamprint_gui.job.encode.png_slices import read_png_labels


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
