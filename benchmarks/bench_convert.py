"""End-to-end conversion speed and peak memory of ``dreamprint convert`` on the demo source.

Prints, per job size (~1e7, 1e8, 1e9 voxels on the j850-paper grid): voxels, wall seconds,
voxels per second end to end (source sampling, table lookup + density alignment, halftoning,
PNG encoding and writing), the peak resident memory of the converting process (its own
``ru_maxrss``, measured in a fresh child process per job so sizes do not mix), and the 1 -> 2
worker speed-up on the 1e8 job. "cores busy" is the process's CPU seconds / wall seconds: with
2 workers it should approach 2; well below 2 while the machine's load average (printed) exceeds
its free cores means the other core was taken by other processes, not that the job serialises.
Targets on a 2-core machine: >= 1e8 voxels/s, flat peak memory < 1.5 GB. "prepare s" is the
job's preparation before the first voxel (open the source, load the colour tables and the
halftone mask from their caches, load the compiled kernels), not included in the voxel rate.
Job folders go to ``benchmarks/.jobs/`` beside this file (where an operator's jobs folder
would be: on the disk, not in the system's temporary folder), or to ``BENCH_DIR`` when set. A
job writes one file per layer, so the disk's cost of creating a file matters for small jobs:
"file us" is that cost, probed just before each job (see :func:`file_probe`), and
``BENCH_DIR=/dev/shm`` separates the conversion's speed from the disk's. On this project's VM,
creating a file anywhere under ``/tmp`` costs 0.1-0.9 ms of kernel time (measured 2026-11-23:
~300 us under /tmp, ~20-35 us in /var/tmp, /root or the checkout, same disk), and so does
creating one in a folder near which thousands of files were deleted in the last few minutes
(:func:`file_probe` says why) - such as a previous run's job folders: enough to halve a
1e7-voxel job's rate. Job folders are removed when the benchmark ends, not between jobs; a
line under a job says when the probe found the disk in that state.

    python benchmarks/bench_convert.py                 # 1e7, 1e8 (best of 3) and 1 -> 2 workers
    python benchmarks/bench_convert.py --sizes 1e7,1e8,1e9
    python benchmarks/bench_convert.py --one 1e8 --workers 2 --out /tmp/job   # one child run
    python benchmarks/bench_convert.py --source openvdb --sizes 1e8,1e9 --repeat 1 --no-speedup
    python benchmarks/bench_convert.py --source all --sizes 1e8,1e9 --repeat 1 --no-speedup
    python benchmarks/bench_convert.py --scale-out --source demo     # 1e9: LocalCluster 1 -> 2

The conversion's CPU seconds per voxel (all its threads) are printed too, with the rate two
fully busy cores would give: on a shared machine, where the wall clock also counts the time
other processes hold the cores, they are the steadier figure.

``--source`` takes a source kind of :mod:`bench_sources` (demo, openvdb, openvdb-manta,
nanovdb, vtk, vtk-legacy, metaimage, nrrd, radiance, radiance-linear, inria, inria-sample,
compressed-ply, spz, vox, ingp; ``all`` for every one; generated files are made on first use),
or a file. The job's height is chosen from the source's bounds so that the job has about the asked
number of voxels. Per job the benchmark prints, besides the line above, the stages in ns per
voxel (worker-seconds / voxels): "load" the source's one-time opening (reading, the OpenVDB
helper's transfer, the Gaussians' set-up) in the converting process, "prepare" the rest of
the preparation (tables, mask, compiled kernels), then sample, label (lookup + alignment +
halftone), sample+label (the fused layer-at-a-time path, one figure for both), encode (PNG) and
write; and "end to end" voxels per second over the whole conversion including load and
preparation. ``--scale-out`` converts one job (``--scale-size``, default 1e9 voxels) through a
``dask.distributed`` LocalCluster of 1 and then 2 worker processes (one thread each), passed to
the conversion as ``--scheduler tcp://...`` exactly as a cluster of machines would be, twice per
cluster (a first job on new worker processes, which load the kernels, source and tables, and a
second one on the same workers), with the CPU seconds of the workers, of the scheduler and
nannies and of the client, and prints the speed-ups.

Before the first job the benchmark waits (at most 7 minutes, saying so) until creating a file
where the jobs go is fast again (:func:`wait_for_disk`); ``--no-wait`` starts at once.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

VOXEL = (0.084, 0.028, 0.014)  # j850-paper
# Jobs are made on the paper's grid over the file's declared box (not the default printer and
# --fit occupied), so that figures stay comparable with earlier rounds; --up turns the source
# (z: no turn; any other axis takes the turned-source path, io/volumes/orient.py).
PRINTER = "j850-paper"
_UP = ["z"]


def height_for(n_voxels: float) -> float:
    # The demo source's bounds are about a unit cube: N ~ h^3 / (vx vy vz).
    return (n_voxels * VOXEL[0] * VOXEL[1] * VOXEL[2]) ** (1 / 3)


def one(n: float, workers: int, out: str, halftone: str, scheduler: str | None,
        source: str = "demo", height: float | None = None, up: str = "z") -> dict:
    from dreamprint_gui.core.generators import drain
    from dreamprint_gui.job import plan
    from dreamprint_gui.job.plan import ConvertSettings
    from dreamprint_gui.job.run import run_conversion

    s = ConvertSettings(source=source, output=out,
                        height_mm=height if height else height_for(n), workers=workers,
                        halftone=halftone, scheduler=scheduler, overwrite=True,
                        printer=PRINTER, fit="box", up=up)
    # Preparation (source, tables and mask from their caches, compiled kernels from numba's
    # cache) is timed on its own: it is per job, not per voxel. The source's opening (its
    # one-time load) is timed inside it.
    from dreamprint_gui.job.plan import prepare_job

    opened = plan._open_source  # prepare_job reads it from job.plan
    load_s = [0.0]

    def timed_open(spec, options, *rest):
        t = time.perf_counter()
        try:
            return opened(spec, options, *rest)
        finally:
            load_s[0] += time.perf_counter() - t

    plan._open_source = timed_open
    tp = time.perf_counter()
    ctx = prepare_job(s)
    prep = time.perf_counter() - tp
    load = os.getloadavg()[0]
    ru0 = resource.getrusage(resource.RUSAGE_SELF)
    t = time.perf_counter()
    gen = run_conversion(s, context=ctx, preflight=False)
    m = drain(gen)
    wall = time.perf_counter() - t
    ru1 = resource.getrusage(resource.RUSAGE_SELF)
    cpu = (ru1.ru_utime - ru0.ru_utime) + (ru1.ru_stime - ru0.ru_stime)
    nx, ny, nz = m["grid_dimensions"]
    return {"voxels": nx * ny * nz, "grid": [nx, ny, nz], "wall_s": wall,
            "voxels_per_s": nx * ny * nz / wall,
            "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
            "stages_s": m["timings_s"]["worker_stage_sum"], "cpu_s": cpu, "load_before": load,
            "prepare_s": prep, "load_s": load_s[0],
            "job_mb": sum(f.stat().st_size for f in Path(out, "slices").iterdir()) / 1e6}


_KEEP: list[str] = []  # job folders, removed when the benchmark ends (see file_probe)


def file_probe(n: int = 200) -> float:
    """Microseconds to create one small file where the jobs go, measured now.

    On this project's VM the root file system is ext4 without a journal
    (``/sys/fs/ext4/vda/journal_task`` says ``<none>``): such an ext4 does not reuse an inode
    freed in the last minutes and steps over each of them, reading its inode table block, when
    it allocates one (``find_inode_bit`` / ``recently_deleted`` in ``fs/ext4/ialloc.c``). In a
    folder (a block group) where thousands of files were just deleted, creating one therefore
    costs up to ~0.9 ms of kernel time instead of ~0.02-0.03, and a job writes one file per
    layer; ``/tmp`` is always in that state. The benchmark removes its job folders only at the
    end, and prints this probe next to each job so a slow disk is seen as such.
    """
    d = tempfile.mkdtemp(prefix="dp-probe-", dir=jobs_dir())
    _KEEP.append(d)
    t = time.perf_counter()
    for i in range(n):
        fd = os.open(os.path.join(d, f"{i:05d}"), os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        os.write(fd, b"x" * 4096)
        os.close(fd)
    return (time.perf_counter() - t) / n * 1e6


def wait_for_disk(limit_us: float = 40.0, max_wait_s: float = 420.0) -> None:
    """Wait (at most ``max_wait_s``) until creating a file where the jobs go costs less than
    ``limit_us``, saying so. A previous run's cleanup deletes thousands of files there, and for
    the next few minutes creating one costs ~0.3 ms instead of ~0.025 (:func:`file_probe`): a
    1e7-voxel job would then measure mostly that (one run right after another: 49 Mvox/s
    against 108-135). ``--no-wait`` measures the disk as it is; every job's line shows the
    probe either way."""
    t0 = time.monotonic()
    us = file_probe()
    if us < limit_us:
        return
    print(f"waiting for the disk: creating a file costs {us:.0f} us in {jobs_dir()} now "
          f"(files were deleted near it minutes ago; see file_probe) ...", flush=True)
    while us >= limit_us and time.monotonic() - t0 < max_wait_s:
        time.sleep(20)
        us = file_probe()
    print(f"... {us:.0f} us per file after {time.monotonic() - t0:.0f} s", flush=True)


def jobs_dir() -> str:
    """Where the benchmark's job folders go: ``BENCH_DIR``, else ``benchmarks/.jobs``."""
    d = os.environ.get("BENCH_DIR") or str(Path(__file__).resolve().parent / ".jobs")
    os.makedirs(d, exist_ok=True)
    return d


def child(n: float, workers: int, halftone: str, scheduler: str | None, source: str) -> dict:
    tmp = tempfile.mkdtemp(prefix="dp-bench-", dir=jobs_dir())
    _KEEP.append(tmp)
    probe = file_probe()
    path = source_file(source)
    cmd = [sys.executable, __file__, "--one", str(n), "--workers", str(workers),
           "--out", os.path.join(tmp, "JOB"), "--halftone", halftone, "--source", path,
           f"--up={_UP[0]}"]
    if path != "demo":
        cmd += ["--height", repr(height_of(path, n))]
    if scheduler:
        cmd += ["--scheduler", scheduler]
    res = subprocess.run(cmd, capture_output=True, text=True, check=False)
    # the job folder stays until the benchmark ends (main): deleting its thousands of slices
    # here made creating a file cost 100-260 us instead of ~25 for every later job
    # (file_probe), so each kind after the first measured a slower disk than the demo
    if res.returncode:
        raise SystemExit(res.stderr)
    return {**json.loads(res.stdout.strip().splitlines()[-1]), "file_us": probe}


def source_file(kind: str) -> str:
    """The file (or ``demo``) of a source kind of :mod:`bench_sources`, or ``kind`` itself."""
    if kind == "demo" or os.path.exists(kind):
        return kind
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from bench_sources import source_path

    return source_path(kind)


def height_of(path: str, n: float) -> float:
    """The height (mm) giving a job of about ``n`` voxels for this source's bounds."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from job_hashes import height_for as by_bounds

    return by_bounds(path, n)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", default="1e7,1e8")
    ap.add_argument("--one", type=float)
    ap.add_argument("--workers", type=int, default=os.cpu_count())
    ap.add_argument("--out")
    ap.add_argument("--halftone", default="blue-noise")
    ap.add_argument("--scheduler", default=None)
    ap.add_argument("--no-speedup", action="store_true")
    ap.add_argument("--repeat", type=int, default=3, help="runs per size: the best is "
                    "printed, with the median and the slowest (a shared VM's speed varies)")
    ap.add_argument("--source", default="demo", help="demo, or a volume file (a cube-ish one: "
                    "the job size assumes equal extents)")
    ap.add_argument("--no-wait", action="store_true", help="start at once even when creating a "
                    "file is slow where the jobs go (see wait_for_disk)")
    ap.add_argument("--height", type=float, help=argparse.SUPPRESS)
    ap.add_argument("--scale-out", action="store_true", help="the --scale-size job on a "
                    "dask.distributed LocalCluster of 1, then 2 worker processes")
    ap.add_argument("--scale-size", type=float, default=1e9)
    ap.add_argument("--up", default="z", help="the source axis that becomes the print's up "
                    "(z: unturned; e.g. -y: the turned-source path)")
    a = ap.parse_args()
    _UP[0] = a.up
    if a.one:
        print(json.dumps(one(a.one, a.workers, a.out, a.halftone, a.scheduler, a.source,
                             a.height, a.up)))
        return
    if a.source == "all":
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from bench_sources import KINDS

        kinds = list(KINDS)
    else:
        kinds = a.source.split(",")
    if a.scale_out:
        try:
            if not a.no_wait:
                wait_for_disk()
            for kind in kinds:
                scale_out(kind, a.scale_size, a.halftone)
        finally:
            for d in _KEEP:
                shutil.rmtree(d, ignore_errors=True)
        return
    print(f"machine: {os.cpu_count()} cores; source {a.source} on {PRINTER}, --fit box, "
          f"--up {a.up}; halftone {a.halftone}")
    print(f"{'voxels':>12} {'grid (x,y,z)':>20} {'workers':>7} {'wall s':>8} {'Mvox/s':>8} "
          f"{'peak RSS MB':>11} {'job MB':>8} {'cores busy':>10} {'load':>5} {'prepare s':>9} "
          f"{'file us':>7}")
    try:
        if not a.no_wait:
            wait_for_disk()
        for kind in kinds:
            if len(kinds) > 1 or kind != "demo":
                print(f"-- {kind}: {source_file(kind)}", flush=True)
            _run(a, kind)
    finally:
        for d in _KEEP:
            shutil.rmtree(d, ignore_errors=True)


def _run(a: argparse.Namespace, source: str) -> None:
    for n in (float(x) for x in a.sizes.split(",")):
        runs = sorted((child(n, a.workers, a.halftone, a.scheduler, source)
                       for _ in range(max(1, a.repeat))), key=lambda r: -r["voxels_per_s"])
        r = runs[0]
        print(f"{r['voxels']:>12,} {str(tuple(r['grid'])):>20} {a.workers:>7} "
              f"{r['wall_s']:>8.1f} {r['voxels_per_s'] / 1e6:>8.1f} {r['peak_rss_mb']:>11.0f} "
              f"{r['job_mb']:>8.0f} {r['cpu_s'] / r['wall_s']:>10.2f} {r['load_before']:>5.1f} "
              f"{r['prepare_s']:>9.2f} {r['file_us']:>7.0f}",
              flush=True)
        if r["file_us"] > 60:
            print(f"{'':>12} (creating a file costs {r['file_us']:.0f} us here now, not ~25: "
                  "files were deleted near this folder minutes ago; see file_probe)", flush=True)
        st = r["stages_s"]
        rates = [f"{x['voxels_per_s'] / 1e6:.1f}" for x in runs]
        names = {"sample": "sample", "lookup_halftone": "lookup+halftone",
                 "sample_lookup_halftone": "sample+lookup+halftone (one pass)", "png": "png",
                 "write": "write"}
        stages = ", ".join(f"{label} {st[k]:.1f}" for k, label in names.items()
                           if st.get(k) or k in ("png", "write"))
        print(f"{'':>12} worker-seconds: {stages}; "
              f"Mvox/s of the {len(runs)} runs: {', '.join(rates)} (median "
              f"{runs[len(runs) // 2]['voxels_per_s'] / 1e6:.1f}); peak RSS max "
              f"{max(x['peak_rss_mb'] for x in runs):.0f} MB", flush=True)
        print(f"{'':>12} {stage_line(r)}", flush=True)
    if not a.no_speedup:
        r1 = child(1e8, 1, a.halftone, a.scheduler, source)
        r2 = child(1e8, 2, a.halftone, a.scheduler, source)
        print(f"1 -> 2 workers on {r1['voxels']:,} voxels: {r1['voxels_per_s'] / 1e6:.1f} -> "
              f"{r2['voxels_per_s'] / 1e6:.1f} Mvox/s, speed-up "
              f"{r2['voxels_per_s'] / r1['voxels_per_s']:.2f}x; cores busy "
              f"{r1['cpu_s'] / r1['wall_s']:.2f} -> {r2['cpu_s'] / r2['wall_s']:.2f} "
              f"(1-min load before: {r1['load_before']:.1f}, {r2['load_before']:.1f})")


def stage_line(r: dict) -> str:
    """ns per voxel per stage and the end-to-end rate (load and preparation included)."""
    v = r["voxels"]
    st = r["stages_s"]
    parts = [("load", r["load_s"]), ("prepare", r["prepare_s"] - r["load_s"]),
             ("sample", st.get("sample", 0.0)), ("label", st.get("lookup_halftone", 0.0)),
             ("sample+label", st.get("sample_lookup_halftone", 0.0)),
             ("encode", st.get("png", 0.0)), ("write", st.get("write", 0.0))]
    text = ", ".join(f"{k} {s / v * 1e9:.1f}" for k, s in parts if s > 0)
    end = v / (r["wall_s"] + r["prepare_s"])
    cpu = r["cpu_s"] / v * 1e9
    return (f"ns/voxel: {text}; end to end (load included) {end / 1e6:.1f} Mvox/s; "
            f"conversion CPU {cpu:.1f} ns/voxel (2 cores busy: {2e3 / cpu:.0f} Mvox/s)")


def _peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _cpu_s() -> float:
    """CPU seconds (user + system) of the calling process so far."""
    ru = resource.getrusage(resource.RUSAGE_SELF)
    return ru.ru_utime + ru.ru_stime


def scale_out(kind: str, n: float, halftone: str) -> None:
    """The same job through a LocalCluster of 1 and of 2 worker processes (one thread each),
    given to the conversion as its ``--scheduler`` address, twice per cluster; prints the
    rates, the speed-ups and CPU seconds per process (the workers' peak RSS is over their life,
    so the second job's includes the first). The workers open the source and write the slices
    themselves, as on a cluster of machines sharing the job folder (docs/print-jobs.md)."""
    from distributed import Client, LocalCluster

    rates: dict[str, list[float]] = {"first": [], "second": []}
    for n_workers in (1, 2):
        with LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                          dashboard_address=None) as cluster, Client(cluster) as client:
            # The first job on new worker processes also loads the compiled kernels, the
            # source and the tables in each worker (per process, in parallel: a fixed cost
            # that more workers do not shorten); a cluster's workers live on, so a second
            # job finds its kernels loaded (and, for the same source, its source and tables).
            # CPU seconds: on this one machine the scheduler and the nannies (threads of this
            # process) and the converting client share the cores with the workers.
            for run in ("first", "second"):
                w0 = sum(client.run(_cpu_s).values())
                s0 = _cpu_s()
                r = child(n, n_workers, halftone, cluster.scheduler_address, kind)
                sched_s = _cpu_s() - s0
                work_s = sum(client.run(_cpu_s).values()) - w0
                worker_mb = max(client.run(_peak_rss_mb).values())
                rates[run].append(r["voxels_per_s"])
                print(f"{kind}: {r['voxels']:,} voxels on a LocalCluster of {n_workers} worker "
                      f"process(es) via --scheduler {cluster.scheduler_address}, {run} job: "
                      f"{r['wall_s']:.1f} s, {r['voxels_per_s'] / 1e6:.1f} Mvox/s, peak RSS "
                      f"client {r['peak_rss_mb']:.0f} MB, worker {worker_mb:.0f} MB; 1-min "
                      f"load before {r['load_before']:.1f}; CPU s: workers {work_s:.1f}, "
                      f"this process (scheduler, nannies, the benchmark's file probe and "
                      f"clean-up) {sched_s:.1f}, client {r['cpu_s']:.1f}", flush=True)
    for run, rr in rates.items():
        print(f"{kind}: speed-up 1 -> 2 worker processes, {run} job on the cluster: "
              f"{rr[1] / rr[0]:.2f}x", flush=True)


if __name__ == "__main__":
    main()
