"""Run a built desktop bundle's command line on one file of every volume format, then a convert
and a proof, and print what each says (packaging/README.md, "Check the bundle").

    PYTHONPATH=. .venv/bin/python scripts/check_bundle.py /tmp/bundle/dist/dreamprint \\
        [--data ../shared/data] [--work /tmp/bundle-check]

The files are the sample files and those the clean-install test writes
(tests/install/test_clean_install.py); the bundle's ``dreamprint`` runs with an environment
that has no PYTHONPATH, virtual environment or DRJIT_LIBLLVM_PATH, so it uses only what it
carries. Exit status 1 if any command failed.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _writers():
    path = ROOT / "tests" / "install" / "test_clean_install.py"
    spec = importlib.util.spec_from_file_location("_clean_install", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("bundle", type=Path, help="the bundle's folder (dist/dreamprint)")
    ap.add_argument("--data", type=Path, default=ROOT.parent / "shared" / "data")
    ap.add_argument("--work", type=Path, default=Path("/tmp/bundle-check"))
    args = ap.parse_args()
    exe = args.bundle / ("dreamprint.exe" if sys.platform == "win32" else "dreamprint")
    if args.work.exists():
        shutil.rmtree(args.work)
    (args.work / "samples").mkdir(parents=True)
    ci = _writers()
    files = ci._write_samples(args.work / "samples", args.data)
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "VIRTUAL_ENV", "DRJIT_LIBLLVM_PATH", "PYTHONHOME")}
    failed = 0

    def run(*cmd, timeout=1800):
        t0 = time.perf_counter()
        r = subprocess.run([str(exe), *map(str, cmd)], capture_output=True, text=True, env=env,
                           cwd=args.work, timeout=timeout)
        return r, time.perf_counter() - t0

    print(f"bundle: {exe}")
    for fmt, path in files.items():
        r, t = run("inspect", "--json", path)
        if r.returncode == 0:
            info = json.loads(r.stdout)
            what = (f"{len(info['grids'])} grid(s)" if info.get("grids") else
                    f"{info['gaussians']} Gaussians" if info.get("gaussians") else "networks")
            print(f"inspect {fmt:16s} ok   {t:5.1f} s  {info['format']}: {what}")
        else:
            failed += 1
            print(f"inspect {fmt:16s} FAIL {t:5.1f} s  {r.stderr.strip()[-300:]}")
    for fmt in ("vox", "openvdb"):
        job = args.work / f"job-{fmt}"
        r, t = run("convert", files[fmt], "-o", job, "--height-mm", "2", "--seed", "1",
                   "--quiet", "--json")
        if r.returncode == 0:
            m = json.loads((job / "manifest.json").read_text())
            print(f"convert {fmt:16s} ok   {t:5.1f} s  grid {m['grid_dimensions']}, "
                  f"{len(list((job / 'slices').glob('*.png')))} slices")
        else:
            failed += 1
            print(f"convert {fmt:16s} FAIL {t:5.1f} s  {r.stderr.strip()[-300:]}")
    r, t = run("proof", files["vox"], "-o", args.work / "proof", "--height-mm", "3", "--views",
               "1", "--resolution", "48", "--spp", "4", "--json")
    if r.returncode == 0:
        p = json.loads((args.work / "proof" / "proof.json").read_text())
        print(f"proof   {'vox':16s} ok   {t:5.1f} s  {p['renderer']['note']}")
    else:
        failed += 1
        print(f"proof   {'vox':16s} FAIL {t:5.1f} s  {r.stderr.strip()[-300:]}")
    print(f"{failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
