"""A job on a real Dask cluster, and a resumed job (issue 47's targets).

``--scale`` starts ``dask scheduler`` and one, then two ``dask worker`` processes (one thread
each, Dask's own command line: nothing shared with this interpreter) on 127.0.0.1 and converts
the same job (``--size``, default 1e9 voxels of the demo on the j850-paper grid, as
bench_convert.py) through ``--scheduler tcp://...`` twice per cluster (a first job on new
workers, which load the kernels, source and tables; a second on warm workers). It prints each
job's time and rate, the speed-ups 1 -> 2 workers (target >= 1.6x) and the 1-minute load.

``--resume`` runs ``dreamprint convert`` on this computer's threads uninterrupted, then again
killed (SIGKILL) once half its layers are recorded done, then ``--resume``; prints the
uninterrupted and the resumed wall times (whole commands, process start and preparation
included), their ratio (target <= 0.60), the manifests' conversion seconds, and whether the
slices hash the same. Its job (``--resume-size``, default 4e9 voxels of the demo: ~40 s on two
free cores) is larger than the scale job: a command's fixed cost (process start, source,
tables, kernels, pre-flight: ~4 s here) is paid by the resumed run again, and at 1e9 voxels
(~10 s) it alone is 40 % of the job.

    PYTHONPATH=. .venv/bin/python benchmarks/bench_cluster.py --scale --resume
    PYTHONPATH=. .venv/bin/python benchmarks/bench_cluster.py --resume --resume-size 1e9
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_convert  # noqa: E402
from bench_convert import PRINTER, child, height_for, jobs_dir  # noqa: E402

DASK = str(Path(sys.executable).with_name("dask"))
REPO = Path(__file__).resolve().parents[1]


class Cluster:
    """``dask scheduler`` and ``n`` ``dask worker --nthreads 1`` processes on 127.0.0.1."""

    def __init__(self, n_workers: int) -> None:
        self.folder = Path(tempfile.mkdtemp(prefix="dp-dask-"))
        env = dict(os.environ, PYTHONPATH=str(REPO))
        file = self.folder / "scheduler.json"
        self.procs = [subprocess.Popen(
            [DASK, "scheduler", "--host", "127.0.0.1", "--port", "0", "--dashboard-address",
             "127.0.0.1:0", "--scheduler-file", str(file)], env=env, cwd=self.folder,
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
        while not file.exists():
            time.sleep(0.1)
        time.sleep(0.3)
        self.address = json.loads(file.read_text())["address"]
        self.procs += [subprocess.Popen(
            [DASK, "worker", "--scheduler-file", str(file), "--nthreads", "1", "--no-nanny",
             "--no-dashboard"], env=env, cwd=self.folder, stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL) for _ in range(n_workers)]
        from distributed import Client

        with Client(self.address, timeout="60s") as c:
            c.wait_for_workers(n_workers, timeout=120)

    def close(self) -> None:
        for p in reversed(self.procs):
            p.kill()
            p.wait()
        shutil.rmtree(self.folder, ignore_errors=True)


def scale(n: float) -> None:
    rates: dict[str, list[float]] = {"first": [], "second": []}
    for n_workers in (1, 2):
        cluster = Cluster(n_workers)
        try:
            for run in ("first", "second"):
                load = os.getloadavg()[0]
                r = child(n, n_workers, "blue-noise", cluster.address, "demo")
                rates[run].append(r["voxels_per_s"])
                print(f"{r['voxels']:,} voxels, {n_workers} dask worker process(es) x 1 "
                      f"thread via --scheduler {cluster.address}, {run} job: {r['wall_s']:.1f} s"
                      f", {r['voxels_per_s'] / 1e6:.1f} Mvox/s; 1-min load before {load:.1f}",
                      flush=True)
        finally:
            cluster.close()
    for d in bench_convert._KEEP:  # the jobs' folders (kept by child() until now)
        shutil.rmtree(d, ignore_errors=True)
    for run, rr in rates.items():
        print(f"speed-up 1 -> 2 dask worker processes, {run} job: {rr[1] / rr[0]:.2f}x "
              "(target >= 1.6x)", flush=True)


def _digests(job: Path) -> str:
    h = hashlib.sha256()
    for p in sorted((job / "slices").iterdir()):
        h.update(p.read_bytes())
    return h.hexdigest()


def _command(out: Path, n: float, *extra: str) -> list[str]:
    return [sys.executable, "-m", "dreamprint_gui.cli", "convert", "demo", "-o", str(out),
            "--height-mm", repr(height_for(n)), "--printer", PRINTER, "--fit", "box", "-q",
            *extra]


def resume(n: float) -> None:
    env = dict(os.environ, PYTHONPATH=str(REPO))
    tmp = Path(tempfile.mkdtemp(prefix="dp-resume-", dir=jobs_dir()))
    try:
        ref = tmp / "REF"
        load = os.getloadavg()[0]
        t0 = time.perf_counter()
        subprocess.run(_command(ref, n), env=env, check=True, stdout=subprocess.DEVNULL)
        whole = time.perf_counter() - t0
        nz = json.loads((ref / "manifest.json").read_text())["grid_dimensions"][2]
        out = tmp / "JOB"
        proc = subprocess.Popen(_command(out, n), env=env, stdout=subprocess.DEVNULL)
        done = 0
        while done < nz / 2:
            parts = list(tmp.glob(".JOB.partial-*/slabs"))
            done = sum(int(p.stem.split("-")[1]) - int(p.stem.split("-")[0])
                       for p in parts[0].glob("*.json")) if parts else 0
            if proc.poll() is not None:
                raise SystemExit("the job ended before half its layers were recorded")
            time.sleep(0.01)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        t0 = time.perf_counter()
        subprocess.run(_command(out, n, "--resume"), env=env, check=True,
                       stdout=subprocess.DEVNULL)
        resumed = time.perf_counter() - t0
        same = _digests(out) == _digests(ref)
        t_ref = json.loads((ref / "manifest.json").read_text())["timings_s"]
        t_res = json.loads((out / "manifest.json").read_text())["timings_s"]
        print(f"--resume, {n:.0e} voxels ({nz} layers), this computer's threads: uninterrupted "
              f"{whole:.1f} s; killed (SIGKILL) at {done}/{nz} layers ({100 * done / nz:.0f} %), "
              f"--resume {resumed:.1f} s = {resumed / whole:.2f} of the uninterrupted run "
              f"(target <= 0.60); converting alone (manifests) {t_ref['convert']:.1f} -> "
              f"{t_res['convert']:.1f} s, preparing {t_ref['prepare']:.1f} / "
              f"{t_res['prepare']:.1f} s; slices identical: {same}; 1-min load before "
              f"{load:.1f}", flush=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scale", action="store_true", help="1 vs 2 dask worker processes")
    ap.add_argument("--resume", action="store_true", help="--resume after kill -9 at 50 %%")
    ap.add_argument("--size", type=float, default=1e9,
                    help="voxels of the --scale job (default 1e9)")
    ap.add_argument("--resume-size", type=float, default=4e9,
                    help="voxels of the --resume job (default 4e9)")
    a = ap.parse_args()
    if not (a.scale or a.resume):
        ap.error("give --scale, --resume or both")
    if a.scale:
        scale(a.size)
    if a.resume:
        resume(a.resume_size)


if __name__ == "__main__":
    main()
