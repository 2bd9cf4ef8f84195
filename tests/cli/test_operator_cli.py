"""The command line as an operator meets it: closed pipes, summaries of large files, a missing
size reported before any work."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from dreamprint_gui.cli import main

ROOT = Path(__file__).resolve().parents[2]


def run(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def _big_csv(path: Path, n: int) -> Path:
    wl = np.arange(380, 731, 10)
    lines = ["wavelength," + ",".join(f"s{i}" for i in range(n))]
    lines += [f"{w}," + ",".join(f"{0.2 + 0.6 * i / n:.4f}" for i in range(n)) for w in wl]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_spectra_summarises_a_large_file_and_lists_all_on_request(tmp_path, capsys):
    f = _big_csv(tmp_path / "big.csv", 40)
    code, out, _ = run(capsys, "spectra", f)
    assert code == 0
    rows = [ln for ln in out.splitlines() if ln.startswith("  s")]
    assert [r.split()[0] for r in rows] == [f"s{i}" for i in range(8)]
    assert "... and 32 more samples (s8 to s39: 380-730 nm, values 0.32 to 0.785)" in out
    code, out, _ = run(capsys, "spectra", f, "--all")
    assert code == 0 and "more samples" not in out
    assert [ln.split()[0] for ln in out.splitlines() if ln.startswith("  s")] == \
        [f"s{i}" for i in range(40)]
    code, out, _ = run(capsys, "spectra", _big_csv(tmp_path / "small.csv", 12))
    assert code == 0 and "more samples" not in out and "  s11 " in out


def test_a_closed_pipe_is_not_an_error(tmp_path):
    # Far more than a pipe buffer (64 kB), so the writer meets the closed pipe.
    f = _big_csv(tmp_path / "big.csv", 3000)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    p = subprocess.Popen([sys.executable, "-m", "dreamprint_gui.cli", "spectra", str(f), "--all"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    first = p.stdout.readline()
    p.stdout.close()
    err = p.stderr.read()
    assert p.wait(timeout=120) == 0, err
    assert first.startswith(b"file: ") and err == b""


def test_missing_size_is_reported_before_opening_the_source(tmp_path, capsys, shared_data):
    src = shared_data / "volumes" / "hydrogen.vti"
    code, _, err = run(capsys, "convert", src, "-o", tmp_path / "JOB")
    assert code == 2
    assert err == "dreamprint: error: give exactly one of --height-mm and --size-mm\n"
    assert not (tmp_path / "JOB").exists()


def test_evaluate_job_explains_its_columns(tmp_path, capsys):
    job = tmp_path / "JOB"
    code, _, err = run(capsys, "convert", "demo", "-o", job, "--height-mm", "0.3",
                       "--table-size", "17", "-q")
    assert code == 0, err
    code, out, err = run(capsys, "evaluate", "job", job, "-q")
    assert code == 0 and err == "", err
    lines = out.splitlines()
    header = next(ln for ln in lines if ln.split()[:1] == ["material"])
    assert header.split() == ["material", "voxels", "fraction", "intended", "z", "volume", "ml",
                              "mass", "g"]
    legend = out[out.index("  columns: "):]
    for column in ("voxels = ", "fraction = ", "intended = ", "z = ", "volume ml = ",
                   "mass g = "):
        assert column in legend, column


def test_evaluate_job_says_how_reading_the_slices_goes(tmp_path, capsys, monkeypatch):
    """A 1e9-voxel job's slices take minutes to read back (issue 46: 187 s without a line):
    progress on stderr while reading, the JSON alone on stdout."""
    from dreamprint_gui.core import progress

    job = tmp_path / "JOB"
    code, _, err = run(capsys, "convert", "demo", "-o", job, "--height-mm", "0.3",
                       "--table-size", "17", "-q")
    assert code == 0, err
    nz = json.loads((job / "manifest.json").read_text())["grid_dimensions"][2]
    monkeypatch.setattr(progress, "HEARTBEAT_S", 0.0)
    code, out, err = run(capsys, "evaluate", "job", job, "--json")
    assert code == 0 and json.loads(out)["consistent"] is True
    lines = [ln for ln in err.splitlines() if ln.startswith(f"{job}: reading the slices back")]
    assert lines[0].endswith(": 0/1, started") and lines[-1].endswith(", done)")
    assert [ln.split(": ")[-1].split(" (")[0] for ln in lines[1:-1]] == [
        f"{z} of {nz} slices read" for z in range(1, nz)]


def test_a_logged_conversion_says_how_it_goes_every_heartbeat(monkeypatch, capsys):
    """No terminal (a log, a pipe): a converting line once HEARTBEAT_S passed since the last
    (was every 10 s: 10 s gaps on the 40 mm demo and smoke, issue 46's walk), and the last."""
    import time
    from types import SimpleNamespace as NS

    from dreamprint_gui.cli.jobs import _Progress
    from dreamprint_gui.core import progress

    monkeypatch.setattr(progress, "HEARTBEAT_S", 0.05)
    bar = _Progress(tty=False, quiet=False)
    for k in range(1, 5):
        time.sleep(0.06)
        bar.update(NS(layers_done=10 * k, layers_total=40, voxels_done=1000 * k,
                      elapsed_s=0.06 * k, eta_s=0.06 * (4 - k)))
    lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("converting:")]
    assert [ln.split()[1] for ln in lines] == ["10/40", "20/40", "30/40", "40/40"]


def test_the_demo_prints_at_its_design_height_when_no_size_is_given(capsys):
    """`dreamprint convert demo -o J` needs no size: the demo's densities are made for its design
    height, which it then prints at (said on stderr); a file still has to be given one."""
    from dreamprint_gui.cli.options import print_spec
    from dreamprint_gui.io.volumes.grids.demo import DESIGN_HEIGHT_MM

    spec = print_spec("demo", {"height_mm": None, "size_mm": None})
    assert spec.height_mm == DESIGN_HEIGHT_MM and spec.size_mm is None
    assert f"design height, {DESIGN_HEIGHT_MM:g} mm" in capsys.readouterr().err
    assert print_spec("demo", {"height_mm": 12.0, "size_mm": None}).height_mm == 12.0
    assert print_spec("demo", {"height_mm": None, "size_mm": "10,10,10"}).height_mm is None
    assert print_spec("knight.vox", {"height_mm": None, "size_mm": None}).height_mm is None
