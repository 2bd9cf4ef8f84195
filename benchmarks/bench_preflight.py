"""How long the pre-flight takes and how close its estimates come to the finished job.

    PYTHONPATH=. python benchmarks/bench_preflight.py [--source demo] [--heights 5,10]
        [--density-scale 1] [--content auto]
    PYTHONPATH=. python benchmarks/bench_preflight.py --samples [--height 10] [--printer P]
        [--cold]

Per height: the pre-flight's own time, then a real conversion (into a temporary folder, removed
afterwards) and, side by side, estimated vs actual material fractions (worst absolute
difference), clamped-high voxels, disk bytes and conversion seconds.

``--samples``: every sample file (../shared/data: OpenVDB, VTK XML, legacy VTK, MetaImage, the
INRIA splat PLY, MagicaVoxel) and the demo, each converted by ``dreamprint convert --json`` in
a fresh process (as an operator runs it) at ``--height`` mm; prints per file the pre-flight's
conversion estimate vs the conversion's actual time and their ratio, and the preparation's
time (opening the source, tables, mask, kernels). ``--cold`` gives the first file empty table
and mask caches (a new printer or profile): the announced build estimates are printed against
the preparation they were part of.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SAMPLES = {
    "demo": "demo",
    "openvdb": "volumes/blender_mantaflow_fluid_data_0190.vdb",
    "vti": "volumes/hydrogen.vti",
    "vtk": "volumes/ironProt.vtk",
    "mhd": "volumes/HeadMRVolume.mhd",
    "splat ply": "splats/inria3dgs_iter7000_sh3_9080.ply",
    "vox": "voxels/magicavoxel_chr_knight.vox",
}


def _shared() -> Path:
    env = os.environ.get("DREAMPRINT_SAMPLE_DATA")
    return Path(env) if env else Path(__file__).resolve().parents[2] / "shared" / "data"


def samples(height: float, printer: str | None, cold: bool) -> None:
    import dreamprint_gui  # noqa: F401 - sets NUMBA_CACHE_DIR, kept for the children

    with open("/proc/loadavg") as f:
        print(f"load average at start: {f.read().split()[:3]}")
    print(f"{'file':10s} {'voxels':>11s} {'conv est s':>10s} {'conv act s':>10s} "
          f"{'act/est':>7s} {'prepare s':>9s} {'builds est s':>12s} {'wall s':>7s}")
    caches = Path(tempfile.mkdtemp(prefix="dp-bench-cold-"))
    try:
        for i, (name, rel) in enumerate(SAMPLES.items()):
            src = rel if rel == "demo" else str(_shared() / rel)
            env = dict(os.environ)
            if cold and i == 0:  # empty table and mask caches; the compiled kernels kept
                env["DREAMPRINT_CACHE"] = str(caches / "dp")
                env["XDG_CACHE_HOME"] = str(caches / "xdg")
            out = Path(tempfile.mkdtemp(prefix="dp-bench-pf-")) / "JOB"
            cmd = [sys.executable, "-m", "dreamprint_gui.cli", "convert", src, "-o", str(out),
                   "--height-mm", str(height), "--json"]
            if printer:
                cmd += ["--printer", printer]
            t0 = time.perf_counter()
            r = subprocess.run(cmd, capture_output=True, text=True, env=env)
            wall = time.perf_counter() - t0
            shutil.rmtree(out.parent, ignore_errors=True)
            if r.returncode != 0:
                print(f"{name:10s} failed: {r.stderr.strip().splitlines()[-1:]}")
                continue
            m = json.loads(r.stdout)
            est = m["preflight"]["seconds_estimate"]
            act = m["timings_s"]["convert"]
            builds = sum(float(v) * (60 if u == "min" else 1) for v, u in re.findall(
                r"about ([0-9.]+) (s|min); cached after", r.stderr))
            print(f"{name:10s} {m['total_voxels']:11,d} {est:10.2f} {act:10.2f} "
                  f"{act / est:7.2f} {m['timings_s']['prepare']:9.1f} "
                  f"{builds if builds else '-':>12} {wall:7.1f}", flush=True)
    finally:
        shutil.rmtree(caches, ignore_errors=True)
    with open("/proc/loadavg") as f:
        print(f"load average at end: {f.read().split()[:3]}")


def heights(args) -> None:
    from dreamprint_gui.job.plan import ConvertSettings, prepare_job
    from dreamprint_gui.job.preflight import preflight
    from dreamprint_gui.job.run import run_conversion

    print("height_mm voxels preflight_s fraction_max_abs_err clamped_est clamped_job "
          "disk_est_MB disk_job_MB time_est_s time_job_s")
    for h in (float(v) for v in args.heights.split(",")):
        tmp = Path(tempfile.mkdtemp(prefix="dp-bench-pf-"))
        try:
            s = ConvertSettings(source=args.source, output=tmp / "JOB", height_mm=h,
                                density_scale=args.density_scale, content=args.content)
            ctx = prepare_job(s)
            t0 = time.perf_counter()
            pf = preflight(ctx)
            t_pf = time.perf_counter() - t0
            gen = run_conversion(s, context=ctx, preflight=pf)
            while True:
                try:
                    next(gen)
                except StopIteration as stop:
                    m = stop.value
                    break
            n = m["total_voxels"]
            err = max(abs(pf.fractions[k] - m["voxel_counts"][k] / n) for k in pf.fractions)
            disk = sum(p.stat().st_size for p in (tmp / "JOB").rglob("*") if p.is_file())
            print(f"{h:g} {n} {t_pf:.3f} {err:.5f} {pf.clamped_voxels} "
                  f"{int(m['clamped_density']['n_clamped_high'])} {pf.disk_bytes / 1e6:.2f} "
                  f"{disk / 1e6:.2f} {pf.seconds:.1f} {m['timings_s']['convert']:.1f}",
                  flush=True)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--source", default="demo")
    ap.add_argument("--heights", default="5,10")
    ap.add_argument("--density-scale", type=float, default=1.0)
    ap.add_argument("--content", default="auto")
    ap.add_argument("--samples", action="store_true", help="every sample file, fresh processes")
    ap.add_argument("--height", type=float, default=10.0, help="--samples: the height in mm")
    ap.add_argument("--printer", default=None, help="--samples: the printer")
    ap.add_argument("--cold", action="store_true",
                    help="--samples: the first file with empty table and mask caches")
    args = ap.parse_args()
    if args.samples:
        samples(args.height, args.printer, args.cold)
    else:
        heights(args)


if __name__ == "__main__":
    main()
