"""How long the pre-flight takes and how close its estimates come to the finished job.

    PYTHONPATH=. python benchmarks/bench_preflight.py [--source demo] [--heights 5,10]
        [--density-scale 1] [--content auto]
    PYTHONPATH=. python benchmarks/bench_preflight.py --samples [--height 10 | --voxels 1e9]
        [--printer P] [--modes cold,warm] [--kinds demo,vox,...]

Per height: the pre-flight's own time, then a real conversion (into a temporary folder, removed
afterwards) and, side by side, estimated vs actual material fractions (worst absolute
difference), clamped-high voxels, disk bytes and conversion seconds.

``--samples``: every held-out-style kind (:data:`KINDS`: the sample files in ../shared/data,
bench_sources' generated SPZ, NRRD, InstantNGP and fog .vdb, the demo), each converted by
``dreamprint convert --json`` in a fresh process (as an operator runs it) at ``--height`` mm
(or ``--voxels N``), cold (empty table and mask caches: a new profile, printer or intent) and
warm; prints per kind the estimates of preparing (made before it starts,
``job/prepare_time.py``), of the conversion and of the whole command against the actual, and
their ratios (target: within 1.5 x).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_sources import source_path  # noqa: E402

# The held-out-style kinds: the sample files and, for the kinds no sample has, bench_sources'
# generated files (a 1e6-Gaussian SPZ, ironProt as NRRD, an InstantNGP snapshot, a 320 x 256 x
# 288 fog .vdb)
KINDS = ("demo", "openvdb-manta", "openvdb", "vox", "inria-sample", "spz", "metaimage", "nrrd",
         "vtk", "ingp")


def _run(src: str, height: float, printer: str | None, env: dict) -> tuple[dict, float]:
    """``dreamprint convert SRC --json`` in a fresh process: (manifest, wall seconds)."""
    out = Path(tempfile.mkdtemp(prefix="dp-bench-pf-")) / "JOB"
    cmd = [sys.executable, "-m", "dreamprint_gui.cli", "convert", src, "-o", str(out),
           "--height-mm", f"{height:.4f}", "--json"]
    if printer:
        cmd += ["--printer", printer]
    t0 = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    shutil.rmtree(out.parent, ignore_errors=True)
    if r.returncode != 0:
        raise RuntimeError((r.stderr.strip().splitlines() or ["?"])[-1])
    return json.loads(r.stdout), wall


def _height_for(src: str, voxels: float, printer: str | None) -> float:
    """The height (mm) that gives about ``voxels`` voxels (the job's own placement at 10 mm,
    scaled: the voxel count grows with the cube of the height)."""
    from dreamprint_gui.job.plan import ConvertSettings, prepare_job

    ctx = prepare_job(ConvertSettings(source=src, height_mm=10.0, printer=printer))
    nx, ny, nz = ctx.shape_xyz
    return 10.0 * (voxels / (nx * ny * nz)) ** (1 / 3)


def samples(height: float, printer: str | None, modes: list[str], kinds: list[str],
            voxels: float | None) -> None:
    """Per kind and mode (cold: empty table and mask caches, the compiled kernels kept;
    warm: the caches as the previous run left them), a fresh ``dreamprint convert --json``:
    the pre-flight's estimates (preparing, said before it starts: .job.prepare_time; the
    conversion) against the actual, and their ratio (actual / estimate)."""
    import dreamprint_gui  # noqa: F401 - sets NUMBA_CACHE_DIR, kept for the children

    with open("/proc/loadavg") as f:
        print(f"load average at start: {f.read().split()[:3]}; {os.cpu_count()} cores")
    size = f"{voxels:.0e} voxels" if voxels else f"{height:g} mm"
    print(f"at {size}; prep = opening and placing the source, tables, first-use builds "
          "(estimated before it starts); conv = the slabs; all = the job's whole time (the "
          "manifest's total) against prep + conv + the pre-flight's own time; cpu s = the "
          "command's CPU seconds (all threads)")
    print(f"{'kind':14s} {'mode':4s} {'voxels':>13s} {'prep est':>8s} {'act':>6s} {'ratio':>5s} "
          f"{'tables':>6s} {'conv est':>8s} {'act':>6s} {'ratio':>5s} {'all est':>7s} "
          f"{'act':>6s} {'ratio':>5s} {'cpu s':>6s}")
    worst = 1.0
    caches = Path(tempfile.mkdtemp(prefix="dp-bench-cold-"))
    try:
        for kind in kinds:
            src = source_path(kind)
            h = _height_for(src, voxels, printer) if voxels else height
            try:   # compiled kernels (a first run after an install, out of the model) made
                _run(src, 1.0, printer, dict(os.environ))
            except RuntimeError:
                pass
            for mode in modes:
                env = dict(os.environ)
                if mode == "cold":   # empty table and mask caches; the compiled kernels kept
                    env["XDG_CACHE_HOME"] = str(caches / kind)
                t_cpu = os.times()
                try:
                    m, wall = _run(src, h, printer, env)
                except RuntimeError as exc:
                    print(f"{kind:14s} {mode:4s} failed: {exc}")
                    continue
                t_end = os.times()
                cpu = (t_end.children_user - t_cpu.children_user
                       + t_end.children_system - t_cpu.children_system)
                pf = m["preflight"]
                est_p = (pf.get("prepare_estimate") or {}).get("seconds", 0.0)
                act_p = pf["prepared_seconds"]
                est_c, act_c = pf["seconds_estimate"], m["timings_s"]["convert"]
                est_a = est_p + est_c + pf["estimate_seconds"]
                act_a = m["timings_s"]["total"]
                ratios = [a / e if e > 0 else float("inf")
                          for a, e in ((act_p, est_p), (act_c, est_c), (act_a, est_a))]
                worst = max([worst] + [max(r, 1 / r) for r in ratios if r > 0])
                tables = "cold" if pf["prepare_estimate"]["tables_cold"] else "warm"
                print(f"{kind:14s} {mode:4s} {m['total_voxels']:13,d} {est_p:8.1f} "
                      f"{act_p:6.1f} {ratios[0]:5.2f} {tables:>6s} {est_c:8.1f} {act_c:6.1f} "
                      f"{ratios[1]:5.2f} {est_a:7.1f} {act_a:6.1f} {ratios[2]:5.2f} "
                      f"{cpu:6.1f}", flush=True)
                # the parts, each divided by the estimate's slowdown probe (an idle machine's
                # seconds, what SOURCE_MODEL, TABLE_LOAD_SECONDS and SETUP_SECONDS hold; the
                # tables by the every-core probe, what BUILD_SECONDS_100 holds)
                pe, parts = pf["prepare_estimate"], m["timings_s"].get("prepare_parts", {})
                slow = pe.get("slowdown", 1.0)
                par = pe.get("parallel_slowdown", slow)   # the tables' (every core's)
                rest = act_p - parts.get("source", 0.0) - parts.get("tables", 0.0)
                print(f"{'':14s}   slowdown {slow:.2f}, every core {par:.2f}; preparing: "
                      f"idle s est {est_p / slow:.2f}, "
                      f"CPU s {pf.get('prepared_cpu_seconds', 0):.2f}, "
                      f"ratio {pf.get('prepared_cpu_seconds', 0) / max(est_p / slow, 1e-9):.2f}; "
                      f"idle s est/act: source "
                      f"{pe['source_s'] / slow:.2f}/{parts.get('source', 0) / slow:.2f}, "
                      f"tables {pe['tables_s'] / par:.2f}/{parts.get('tables', 0) / par:.2f}, "
                      f"set-up+builds {(est_p - pe['source_s'] - pe['tables_s']) / slow:.2f}/"
                      f"{rest / slow:.2f}", flush=True)
    finally:
        shutil.rmtree(caches, ignore_errors=True)
    with open("/proc/loadavg") as f:
        print(f"load average at end: {f.read().split()[:3]}")
    print(f"worst ratio either way: {worst:.2f} (target 1.5)")


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
    ap.add_argument("--samples", action="store_true", help="every kind, fresh processes")
    ap.add_argument("--height", type=float, default=10.0, help="--samples: the height in mm")
    ap.add_argument("--voxels", type=float, default=None,
                    help="--samples: the height giving about this many voxels instead")
    ap.add_argument("--printer", default=None, help="--samples: the printer")
    ap.add_argument("--modes", default="cold,warm", help="--samples: cold, warm or both")
    ap.add_argument("--kinds", default=",".join(KINDS), help="--samples: bench_sources kinds")
    args = ap.parse_args()
    if args.samples:
        samples(args.height, args.printer, args.modes.split(","), args.kinds.split(","),
                args.voxels)
    else:
        heights(args)


if __name__ == "__main__":
    main()
