"""`dreamprint icc` (issue 48's command-line contract)."""

import json

import numpy as np
import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.gamut import lcms

pytestmark = pytest.mark.usefixtures("private_cache")


def _run(capsys, *args):
    code = main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


def test_icc_writes_a_profile_and_reports_its_check(capsys, tmp_path):
    out_icc, ti3 = tmp_path / "j850.icc", tmp_path / "j850.ti3"
    code, out, err = _run(capsys, "icc", "-o", str(out_icc), "--size", "9", "--grid", "17",
                          "--printer", "j850-paper", "--intent", "relative", "--cgats",
                          str(ti3), "--patches", "3", "--json")
    assert code == 0, err
    rep = json.loads(out)
    data = out_icc.read_bytes()
    assert rep["bytes"] == len(data) and rep["icc_version"] == 2.4
    assert rep["intent"] == "relative" and "DreamPrinting paper voxel" in rep["description"]
    info = lcms.profile_info(data)
    assert (info["class"], info["colour_space"], info["pcs"]) == ("prtr", "RGB ", "Lab ")
    for key in ("a2b_dE2000", "round_trip_dE2000"):
        assert set(rep["check"][key]) == {"mean", "p95", "max"}
    assert rep["check"]["a2b_dE2000"]["mean"] <= 0.1  # measured 0.046 (p95 0.18)
    # the relative intent prints RGB white as the printable white, the media white: L* 100
    assert lcms.transform(data, np.ones((1, 3)), "relative")[0, 0] == pytest.approx(100, abs=0.1)
    assert rep["cgats"]["layout"] == "argyll" and ti3.read_text().startswith("CTI3")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["j850.icc", "j850.ti3"]
    # the plain report names the file and the figures
    code, out, _ = _run(capsys, "icc", "-o", str(out_icc), "--size", "9", "--grid", "17",
                        "--icc-version", "4")
    assert code == 0 and f"wrote {out_icc}: ICC 4.3 output profile" in out
    assert "A2B vs DreamPrint's print dE2000 mean" in out


def test_icc_errors_name_the_file(capsys, tmp_path):
    missing = tmp_path / "no" / "p.icc"
    code, _, err = _run(capsys, "icc", "-o", str(missing), "--size", "9", "--grid", "9")
    assert code == 2 and str(missing.parent) in err and "does not exist" in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    code, _, err = _run(capsys, "icc", "-o", str(tmp_path / "p.icc"), "--printer", "nope")
    assert code == 2 and "unknown printer 'nope'" in err
    bad = tmp_path / "bad.json"
    bad.write_text("{")
    code, _, err = _run(capsys, "icc", "-o", str(tmp_path / "p.icc"), "--profile", str(bad))
    assert code == 2 and str(bad) in err
    assert not (tmp_path / "p.icc").exists()


def test_icc_refuses_a_characterisation_file_named_as_the_profile(capsys, tmp_path):
    out_icc = tmp_path / "p.icc"
    code, _, err = _run(capsys, "icc", "-o", str(out_icc), "--cgats", str(out_icc))
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "would overwrite the ICC profile" in err and str(out_icc) in err
    assert not list(tmp_path.iterdir())
