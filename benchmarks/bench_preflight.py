"""How long the pre-flight takes and how close its estimates come to the finished job.

    PYTHONPATH=. python benchmarks/bench_preflight.py [--source demo] [--heights 5,10]
        [--density-scale 1] [--content auto]

Per height: the pre-flight's own time, then a real conversion (into a temporary folder, removed
afterwards) and, side by side, estimated vs actual material fractions (worst absolute
difference), clamped-high voxels, disk bytes and conversion seconds.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from pathlib import Path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--source", default="demo")
    ap.add_argument("--heights", default="5,10")
    ap.add_argument("--density-scale", type=float, default=1.0)
    ap.add_argument("--content", default="auto")
    args = ap.parse_args()

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


if __name__ == "__main__":
    main()
