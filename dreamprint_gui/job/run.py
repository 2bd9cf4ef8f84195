"""The print-job conversion (paper Fig. 2 and section 4), streamed slab by slab.

Defines :func:`run_conversion`: a generator driven by the CLI and the GUI alike; it plans the
job (:mod:`.plan`), runs its slabs (:func:`.slab.run_slab`: sample -> label -> encode -> write)
on Dask, yields progress and returns the manifest dict once the job folder is complete and
renamed into place (:mod:`.write`); an interrupted job is finished by ``--resume``
(:mod:`.resume`). Only a slab is ever in memory per worker. Slabs run through
Dask: the threaded scheduler (default, all cores), the multiprocessing scheduler
(``scheduler="processes"``), or a ``dask.distributed`` cluster (``scheduler="tcp://host:8786"``)
whose workers write the slices into the job's temporary folder directly, so that folder must be
on a path every worker sees (:mod:`.cluster`, docs/cluster.md). Every label is a function of
the voxel's position, the seed and its concentrations, never of the slab or worker, so the
slices are byte-identical whatever the slab size, worker count or scheduler.
"""

from __future__ import annotations

import hashlib
import math
import queue
import threading
import time
from collections import deque
from collections.abc import Generator
from pathlib import Path
from typing import Any

import numpy as np

from dreamprint_gui.core import progress as core_progress
from dreamprint_gui.core.durations import seconds_text
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.threads import DaemonCall
from dreamprint_gui.job.cluster import (
    absolute_paths,
    check_workers,
    cluster_line,
    cluster_threads,
    connect,
    run_distributed,
)
from dreamprint_gui.job.manifest import (
    count_entries,
    grid_entries,
    header,
    labels_entry,
    slices_entry,
    software,
)
from dreamprint_gui.job.plan import (
    ConvertProgress,
    ConvertSettings,
    JobCancelled,
    JobContext,
    check_settings,
    job_workers,
    prepare_job,
    scheduler_kind,
    slab_plan,
)
from dreamprint_gui.job.preflight import preflight as estimate
from dreamprint_gui.job.preflight import record_rate
from dreamprint_gui.job.prepare_time import estimate_preparation
from dreamprint_gui.job.resume import (
    check_identity,
    find_interrupted,
    job_identity,
    layers_in,
    missing_slabs,
    read_slab_records,
    write_identity,
)
from dreamprint_gui.job.slab import load_kernels, run_slab
from dreamprint_gui.job.write import JobWriter, check_target

__all__ = ["run_conversion", "job_description", "TimeLeft"]



# ----------------------------------------------------------------------------- scheduling
def _merge_clamped(acc: dict[str, float], add: dict[str, float]) -> None:
    for k, v in add.items():
        if k.startswith("max"):
            acc[k] = max(acc.get(k, 0.0), v)
        else:
            acc[k] = acc.get(k, 0.0) + v


def _local_results(ctx, slabs, slices_dir, workers, kind, cancel, out_q):
    """Run slabs with Dask's local scheduler; put each result (or the exception) on out_q."""
    from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

    import dask

    stop = threading.Event()

    def pretask(key, dsk, state):
        if stop.is_set() or (cancel is not None and cancel.is_set()):
            raise JobCancelled()

    def posttask(key, result, dsk, state, worker_id):
        if isinstance(key, tuple) and key[0] == "slab":
            out_q.put(("result", result))

    dsk: dict[Any, Any] = {"ctx": ctx}
    keys = []
    for i, (z0, z1) in enumerate(slabs):
        if kind == "processes":
            dsk[("slab", i)] = (run_slab, "ctx", z0, z1, slices_dir)
        else:
            dsk[("slab", i)] = (run_slab, "ctx", z0, z1, slices_dir, cancel)
        keys.append(("slab", i))
    if kind == "processes":
        import multiprocessing as mp

        pool = ProcessPoolExecutor(workers, mp_context=mp.get_context("spawn"))
        get = dask.multiprocessing.get
    else:
        pool = ThreadPoolExecutor(workers)
        get = dask.threaded.get
    # dask.local's callback tuple: (start, start_state, pretask, posttask, finish).
    cb = (None, None, pretask, posttask, None)

    def drive():
        try:
            get(dsk, keys, num_workers=workers, pool=pool, callbacks=[cb])
            out_q.put(("done", None))
        except BaseException as exc:  # noqa: BLE001 - handed to the consuming generator
            out_q.put(("error", exc))
        finally:
            stop.set()
            pool.shutdown(wait=True, cancel_futures=True)  # no task outlives the driver
            out_q.put(("closed", None))

    th = threading.Thread(target=drive, name="dreamprint-dask", daemon=True)
    th.start()
    return th, stop


class TimeLeft:
    """The time left of a job from the rate of its last :data:`RATE_WINDOW_S` seconds of
    finished slabs (from its start until then): it follows a cluster that loses or gains
    workers within that window instead of the whole run's average. Layers a resumed job found
    done took no time and are not counted in the rate."""

    def __init__(self, total: int, done: int, start: float) -> None:
        self.total = total
        self.recent: deque[tuple[float, int]] = deque([(start, done)])

    def update(self, done: int, now: float | None = None) -> float:
        now = time.perf_counter() if now is None else now
        self.recent.append((now, done))
        while len(self.recent) > 2 and now - self.recent[1][0] >= RATE_WINDOW_S:
            self.recent.popleft()  # keep one point at or before the window's start
        t0, d0 = self.recent[0]
        rate = (done - d0) / max(1e-9, now - t0)
        return (self.total - done) / rate if rate > 0 else float("inf")


RATE_WINDOW_S = 30.0


# ----------------------------------------------------------------------------- driver
def _sha256(path: str) -> str | None:
    p = Path(path)
    if not p.is_file():
        return None
    h = hashlib.sha256()
    with open(p, "rb") as f:
        for block in iter(lambda: f.read(1 << 22), b""):
            h.update(block)
    return h.hexdigest()


def job_description(ctx: JobContext) -> dict[str, Any]:
    """What a job is, known before any slab runs: its source, profile, placement, printer,
    grid, seed, halftoning, background, compensation, slice files and labels (the manifest's
    fields of the same names; a resumable job's identity, :func:`.resume.job_identity`)."""
    s = ctx.settings
    src_path = s.source if Path(s.source).is_file() else None
    return {
        "software": software(),
        "source": {"path": str(Path(src_path).absolute()) if src_path else s.source,
                   "options": s.source_options,
                   "density_scale": s.density_scale, "sampling": s.sampling,
                   "content": (ctx.content.to_json() if ctx.content is not None else
                               {"mode": "fog", "requested": s.content, "reason": ""})},
        "profile": {"name": ctx.profile_name, "fingerprint": ctx.profile_fingerprint,
                    "path": None if s.profile is None else str(s.profile),
                    "objective": getattr(ctx.tables, "objective", s.objective),
                    "intent": getattr(ctx.tables, "intent", s.intent),
                    "table_size": s.table_size},
        "placement": ctx.placement_json(),
        "printer": ctx.printer.to_json_dict(),
        **grid_entries(ctx.printer, ctx.shape_xyz),
        "requested_size": {"height_mm": s.height_mm,
                           "size_mm": None if s.size_mm is None else list(s.size_mm),
                           "up": s.up, "rotate_deg": s.rotate, "fit": s.fit},
        "seed": s.seed,
        "halftoning": ctx.halftoner.describe(),
        "background": {"mode": s.background, "density_threshold_per_mm":
                       ctx.halftoner.threshold},
        "compensation": (None if ctx.correction is None else
                         {"path": str(Path(s.compensation).absolute()),
                          **ctx.correction.describe(),
                          "proof_figures": ctx.correction.report.get("figures"),
                          "optimise_seconds": ctx.correction.report.get("seconds")}),
        "slices": slices_entry(ctx.printer, ctx.shape_xyz),
        "labels": labels_entry(ctx.printer, ctx.palette),
    }


def _manifest(ctx: JobContext, totals: dict, timings: dict, started: float) -> dict[str, Any]:
    d = job_description(ctx)
    src = d["source"]
    d["source"] = {"path": src.pop("path"), "sha256": totals["source_sha256"], **src}
    return {
        **header(),
        **d,
        **count_entries(totals["counts"], totals["conc_sums"], math.prod(ctx.shape_xyz)),
        "clamped_density": totals["clamped"],
        "timings_s": {"total": time.perf_counter() - started, **timings},
        "execution": {"scheduler": ctx.settings.scheduler or "threads",
                      "workers": totals["workers"], "slabs": totals["slabs"],
                      "resumed_layers": totals["resumed_layers"]},
    }


def _prepare(settings: ConvertSettings, started: float
             ) -> Generator[ConvertProgress, None, JobContext]:
    """:func:`.plan.prepare_job` in a thread, its notices (first-use builds and their progress)
    yielded as "preparing" progress as they come, and the last one again with the elapsed time
    once ``core.progress.HEARTBEAT_S`` passed without a line (placing a slow source, loading
    its tables: 16.6 s silent on the 40 mm demo at load 7); returns the context or raises its
    error."""
    return (yield from _relay(lambda notify: prepare_job(settings, notify=notify),
                              "dreamprint-prepare", started, "preparing", every_notice=True))


def _preflight(ctx: JobContext, seed: int, started: float
               ) -> Generator[ConvertProgress, None, Any]:
    """:func:`.preflight.preflight` in a thread; while it runs, the step under way (its
    notices) is yielded as "preparing" progress once ``core.progress.HEARTBEAT_S`` passed
    since the last line, with the pre-flight's elapsed time: a quick pre-flight says nothing
    more, a slow source's (a minute on a 7.6e8-voxel demo under load) a line every 2 s."""
    return (yield from _relay(lambda notify: estimate(ctx, seed=seed, notify=notify),
                              "dreamprint-preflight", started, "pre-flight",
                              every_notice=False))


def _relay(work, name: str, started: float, step: str, every_notice: bool
           ) -> Generator[ConvertProgress, None, Any]:
    """``work(notify)`` in a thread; its notices become "preparing" progress: each as it
    comes (``every_notice``) or only once ``core.progress.HEARTBEAT_S`` passed since the last
    line; and while none comes, the step under way (the last notice) with the time since this
    began, every ``HEARTBEAT_S``. Returns what ``work`` returned or raises its error."""
    notices: queue.Queue = queue.Queue()

    def run() -> Any:
        try:
            return work(notices.put)
        finally:
            notices.put(None)

    call = DaemonCall(run, name)
    t0 = last = time.monotonic()
    while True:
        try:
            msg = notices.get(timeout=0.25)
        except queue.Empty:
            msg = ""
        if msg is None:
            break
        now = time.monotonic()
        if msg and every_notice:
            step, last = msg, now
            yield ConvertProgress("preparing", 0, 0, 0, 0, time.perf_counter() - started, None,
                                  msg)
            continue
        step = msg or step
        if now - last >= core_progress.HEARTBEAT_S:
            last = now
            yield ConvertProgress("preparing", 0, 0, 0, 0, time.perf_counter() - started, None,
                                  f"{step.removesuffix(' ...')} ({seconds_text(now - t0)})")
    return call.result()


def run_conversion(settings: ConvertSettings, cancel: threading.Event | None = None,
                   context: JobContext | None = None, preflight: Any = True
                   ) -> Generator[ConvertProgress, None, dict[str, Any]]:
    """Convert ``settings.source`` into the job folder ``settings.output``.

    Yields :class:`ConvertProgress`; returns the manifest dict (also written to
    ``manifest.json``). Setting ``cancel`` (or closing the generator) stops the work and
    removes the partial job; nothing is ever left under the final name unless complete. Ctrl-C
    (KeyboardInterrupt), a kill or a lost scheduler (:class:`.write.JobInterrupted`) keep the
    finished slabs in the hidden temporary folder, which ``settings.resume`` finishes
    (:mod:`.resume`); without it such a folder is refused unless ``settings.overwrite``.
    ``preflight``: True estimates the job first (:func:`.preflight.preflight`, yielded once
    with stage "preflight"), a :class:`.preflight.Preflight` already made is used as is, False
    skips it; the manifest records its estimate and warnings (``preflight``).
    """

    started = time.perf_counter()
    if settings.output is None:
        raise DreamPrintError("no output folder given (-o JOB)")
    check_target(settings.output, settings.overwrite)  # before any work
    if not settings.resume and not settings.overwrite:
        left = find_interrupted(settings.output)
        if left is not None:
            raise DreamPrintError(
                f"an interrupted run of this job left {left[1]} of {left[2]} layers done (in "
                f"{left[0].name}): add --resume to finish it, or --overwrite to start again",
                settings.output)
    if context is None:
        check_settings(settings)  # a missing size is reported before "opening the source"
    client = None
    if scheduler_kind(settings) == "distributed":
        settings = absolute_paths(settings)
        client = connect(settings.scheduler)  # an unreachable scheduler: before any work
    try:
        return (yield from _convert(settings, cancel, context, preflight, started, client))
    finally:
        if client is not None:
            client.close()


def _convert(settings: ConvertSettings, cancel: threading.Event | None,
             context: JobContext | None, preflight: Any, started: float, client: Any
             ) -> Generator[ConvertProgress, None, dict[str, Any]]:
    if client is not None:
        yield ConvertProgress("preparing", 0, 0, 0, 0, 0.0, None,
                              cluster_line(client, settings.scheduler))
    prep_est = None
    started_cpu = time.process_time()
    if context is not None:
        ctx = context
    else:
        prep_est = estimate_preparation(settings)
        yield ConvertProgress("preparing", 0, 0, 0, 0, 0.0, None, prep_est.describe())
        ctx = yield from _prepare(settings, started)
    load_kernels(ctx)  # now, so that the first slab's speed is the conversion's
    identity = job_identity(job_description(ctx), ctx.source_stamp)
    claim = None
    if settings.resume:
        left = find_interrupted(settings.output)
        if left is not None:
            check_identity(left[0], identity)  # before anything is run, moved or removed
            claim = left[0]
        else:
            yield ConvertProgress("preparing", 0, 0, 0, 0, time.perf_counter() - started, None,
                                  "--resume: no interrupted run of this job was found; "
                                  "converting from the first layer")
    pf = None
    t_pf = 0.0
    if preflight is True:
        if prep_est is not None and prep_est.source_s >= 2.0:   # samples a slow source too
            yield ConvertProgress("preparing", 0, 0, 0, 0, time.perf_counter() - started, None,
                                  "pre-flight: sampling the job's materials and timing its "
                                  "slabs ...")
        t0 = time.perf_counter()
        pf = yield from _preflight(ctx, settings.seed, started)
        t_pf = time.perf_counter() - t0
        if context is None:
            pf.prepared_seconds = t0 - started
            pf.prepared_cpu_seconds = time.process_time() - started_cpu
            pf.prepare_estimate = prep_est.to_json()
    elif preflight is not False and preflight is not None:
        pf = preflight
    if pf is not None:
        yield ConvertProgress("preflight", 0, 0, 0, 0, time.perf_counter() - started, None,
                              pf.short_line(), preflight=pf)
    t_prep = time.perf_counter() - started
    kind = scheduler_kind(settings)
    workers = cluster_threads(client) if client is not None else job_workers(settings)
    slabs = slab_plan(ctx, workers)
    nx, ny, nz = ctx.shape_xyz
    # Per-layer sums, added exactly (math.fsum) once all are in: the total is then the same
    # whatever the slab size, the number of workers, the order in which slabs finish, or
    # which run of a resumed job made them.
    layer_sums = np.zeros((nz, 7))
    totals: dict[str, Any] = {"counts": np.zeros(7, np.int64),
                              "clamped": {}, "workers": workers, "slabs": len(slabs)}
    stage_t = {"sample": 0.0, "lookup_halftone": 0.0, "sample_lookup_halftone": 0.0, "png": 0.0,
               "write": 0.0}

    def add(result: dict[str, Any]) -> None:
        totals["counts"] += np.asarray(result["counts"], np.int64)
        layer_sums[result["z0"]:result["z1"]] = result["conc_sums"]
        _merge_clamped(totals["clamped"], result["clamped"])

    with JobWriter(settings.output, settings.overwrite, claim=claim) as writer:
        write_identity(writer.tmp, identity)
        writer.resumable = True
        kept = read_slab_records(writer.tmp, nz, nx * ny) if claim is not None else []
        for rec in kept:
            add(rec)
        todo = missing_slabs(slabs, kept)
        resumed = layers_in(kept)
        totals["resumed_layers"] = resumed
        if claim is not None:
            yield ConvertProgress("preparing", 0, 0, 0, 0, time.perf_counter() - started, None,
                                  f"resuming: {resumed} of {nz} layers were finished by the "
                                  f"interrupted run; converting the other {nz - resumed}")
        slices_dir = str(writer.slices_dir)
        if client is not None:
            check_workers(client, settings.source, slices_dir)
        sha_box: dict[str, str | None] = {}
        sha_th = threading.Thread(target=lambda: sha_box.update(v=_sha256(settings.source)),
                                  daemon=True)
        sha_th.start()  # hashing a big source overlaps the conversion
        yield ConvertProgress("converting", resumed, nz, resumed * nx * ny, nx * ny * nz,
                              time.perf_counter() - started, None)
        out_q: queue.Queue = queue.Queue()
        if client is not None:
            th, stop = run_distributed(client, settings.scheduler, run_slab, ctx, todo,
                                       (slices_dir,), out_q, cancel)
        elif kind == "sync":
            th, stop = _local_results(ctx, todo, slices_dir, 1, "threads", cancel, out_q)
        else:
            th, stop = _local_results(ctx, todo, slices_dir, workers, kind, cancel, out_q)
        error: BaseException | None = None
        layers = resumed
        t_conv = time.perf_counter()
        eta = TimeLeft(nz, resumed, t_conv)
        try:
            while True:
                try:
                    what, payload = out_q.get(timeout=0.2)
                except queue.Empty:
                    if cancel is not None and cancel.is_set():
                        writer.request_cancel()
                        stop.set()
                    continue
                if what == "result":
                    add(payload)
                    for k, v in payload["seconds"].items():
                        stage_t[k] += v
                    layers += payload["z1"] - payload["z0"]
                    el = time.perf_counter() - started
                    yield ConvertProgress("converting", layers, nz, layers * nx * ny,
                                          nx * ny * nz, el, eta.update(layers))
                elif what == "error":
                    error = payload
                elif what == "closed":
                    break
        except BaseException:
            # GeneratorExit (closed by the GUI), KeyboardInterrupt: stop the tasks, wait for
            # them, then JobWriter removes the partial folder (or keeps it for --resume).
            writer.request_cancel()
            stop.set()
            th.join()
            raise
        th.join()
        if error is not None:
            if isinstance(error, JobCancelled) or (cancel is not None and cancel.is_set()):
                raise JobCancelled("the conversion was cancelled") from None
            raise error
        if cancel is not None and cancel.is_set():
            raise JobCancelled("the conversion was cancelled")
        yield ConvertProgress("finishing", nz, nz, nx * ny * nz, nx * ny * nz,
                              time.perf_counter() - started, 0.0, "writing the manifest")
        sha_th.join()
        totals["source_sha256"] = sha_box.get("v")
        timings = {"prepare": t_prep, "preflight": t_pf, "convert": time.perf_counter() - t_conv,
                   "worker_stage_sum": stage_t,
                   "prepare_parts": dict(ctx.prepare_timings) if context is None else {}}
        conc_sums = [math.fsum(layer_sums[:, i]) for i in range(7)]
        manifest = _manifest(ctx, {**totals, "counts": totals["counts"].tolist(),
                                   "conc_sums": conc_sums},
                             timings, started)
        # the voxels this run converted: a resumed job's kept layers took none of its time
        manifest["timings_s"]["voxels_per_second"] = (nx * ny * (nz - resumed)) / max(
            1e-9, manifest["timings_s"]["total"])
        if pf is not None:
            manifest["preflight"] = pf.to_json()
            manifest["warnings"] = [w.to_json() for w in pf.warnings]
        writer.commit(manifest)

    if resumed == 0:  # a resumed job's rate is not the conversion's
        record_rate(nx * ny * nz, timings["convert"])
    yield ConvertProgress("done", nz, nz, nx * ny * nz, nx * ny * nz,
                          time.perf_counter() - started, 0.0, str(writer.target))
    return manifest
