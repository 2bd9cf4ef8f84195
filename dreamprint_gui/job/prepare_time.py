"""The time a job spends before its first slab, estimated before it is spent (issue 46).

Stage 1 of a print job (:func:`.plan.prepare_job`) opens and places the source, then loads or
builds the colour tables and any first-use build; :func:`estimate_preparation` says how long
that will take from what can be known without doing it, and the pre-flight (CLI and GUI)
states it beside the conversion's own estimate. The model, written once here:

* **Opening and placing the source** (reading the file, the up axis's resting-side sampling,
  ``--fit occupied``'s sampling): per kind (file extension), ``seconds = fixed + MB /
  throughput`` (:data:`SOURCE_MODEL`), ``MB`` the file's size (a MetaImage / detached NRRD
  header with its data file, a folder's files), in one thread's CPU seconds (an idle machine's
  wall seconds), measured on this project's 2-core machine in fresh processes with the
  compiled kernels cached (``benchmarks/bench_preflight.py --samples`` prints the estimate
  against the actual per kind, cold and warm).
* **The machine's present speed**: every part is an idle machine's time times
  :func:`machine_slowdown` (a 0.1 s fixed workload timed as the estimate is made: the share of
  a core it gets, wall / CPU time, times how much more CPU time it needs than on the idle
  model machine): on a shared machine a job's steps get the same share of a core as it does,
  and its CPU seconds do as little work (the conversion's own estimate times the job's slabs,
  so it sees the load itself).
* **Colour tables**: cached for this profile, printer layer, objective, intent and size:
  :data:`TABLE_LOAD_SECONDS` (the cache is opened lazily); not cached: a first build,
  :func:`..gamut.tables.build_estimate` (an idle machine's wall seconds with every core busy),
  times :func:`parallel_slowdown` (the build's kernels keep every core busy: on an idle 2-core
  machine it takes half its CPU seconds, under load it shares what one core would get).
* **Setting up**: :data:`SETUP_SECONDS` (the compiled kernels loaded, the mask, the content).
* **First-use builds**: the blue-noise mask for this voxel
  (:func:`.halftone.mask_build_estimate`), the compiled kernels of the job and of the source's
  reader (:func:`compile_estimate`), as :func:`.plan.prepare_job` announces them.
"""

from __future__ import annotations

import hashlib
import importlib
import os
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from dreamprint_gui.core.durations import about_text
from dreamprint_gui.core.kernel_cache import uncached
from dreamprint_gui.core.printer import load_printer
from dreamprint_gui.core.profile import load_profile
from dreamprint_gui.gamut.tables import COMPILE_WHAT, build_estimate, kernels_estimate
from dreamprint_gui.io.volumes.registry import FORMATS, sniff_format
from dreamprint_gui.job.halftone import mask_build_estimate
from dreamprint_gui.job.sample_label import layer_kernel

__all__ = ["SOURCE_MODEL", "TABLE_LOAD_SECONDS", "SETUP_SECONDS", "COMPILE_SECONDS",
           "PROBE_SORT_CPU_S",
           "COMPILE_READER_SECONDS", "PrepareEstimate", "estimate_preparation", "source_bytes",
           "source_seconds",
           "compile_estimate", "machine_slowdown", "parallel_slowdown", "PROBE_HASH_CPU_S",
           "opening_notice"]

# Per kind (extension), (fixed seconds, seconds per MB) of opening and placing a source, in CPU
# seconds of one thread (an idle machine's wall seconds: reading and placing run on one core),
# measured in fresh processes with the kernels cached (2026-12-02, 2 cores): .vdb 0.22 / 8.6 /
# 50 MB: 0.32 / 0.65 / 1.56 s; INRIA .ply 2.25 / 68 MB: 0.24 / 3.2-4.5 s; .spz 16 MB (1e6
# Gaussians): 3.8 s; .mhd 0.13 / 67 MB (raw): 0.60 / 1.05 s; .nrrd, .vti, .vtk 0.3 MB:
# 0.48-0.54 s; .vox 0.01 s (and 0.33-1.11 s more than the other kinds once placed, 2026-12-02
# at load 6-10: counted here); .ingp 22 MB: 0.84 s; the demo 0.5-1.0 s (0.55 and 0.67 quiet).
# Radiance grids and folders were not measured (their family's figures).
SOURCE_MODEL: dict[str, tuple[float, float]] = {
    ".vdb": (0.3, 0.025), ".nvdb": (0.3, 0.025),
    ".ply": (0.15, 0.05), ".splat": (0.15, 0.1), ".ksplat": (0.15, 0.1),
    ".spz": (0.15, 0.23), ".sog": (0.15, 0.23),
    ".vti": (0.5, 0.02), ".vtk": (0.5, 0.02), ".mhd": (0.6, 0.007), ".mha": (0.6, 0.007),
    ".nrrd": (0.5, 0.007), ".nhdr": (0.5, 0.007),
    ".npz": (0.3, 0.03), ".exr": (0.3, 0.03),
    ".vox": (0.5, 0.05),    # its kernels' loading: 0.3-1.1 s beyond SETUP_SECONDS (4 runs)
    # an InstantNGP snapshot's network kernels load from numba's cache beyond SETUP_SECONDS:
    # warm, its set-up took 0.99 s against the other kinds' 0.3 (2026-12-02, load 5-8)
    ".ingp": (0.9, 0.025), ".msgpack": (0.9, 0.025),
    "folder": (0.3, 0.03),
    "demo": (0.55, 0.0),
}
_DEFAULT_MODEL = (0.5, 0.05)
# Loading cached 100^3 tables (a lazily read .npz: the arrays are read as they are used;
# bench_preflight.py --samples, warm, quiet machine 2026-12-02: 0.03-0.05 s)
TABLE_LOAD_SECONDS = 0.05
# Setting the job up once the source is placed: the compiled kernels loaded from numba's cache,
# the blue-noise mask, the content's threshold (bench_preflight.py --samples, warm: 0.30-0.33 s
# beyond the source's and the tables' on a quiet machine, 0.2-0.6 s under load, 2026-12-02)
SETUP_SECONDS = 0.35
# Seconds numba takes to compile, on the 2-core development machine (bench_preflight --samples
# after a source change: 16-38 s under load 15): the job's kernels, and a reader's own.
COMPILE_SECONDS = 30.0
COMPILE_READER_SECONDS = 15.0
# Header formats whose data sit in a file of the same name beside them
_DATA_BESIDE = {".mhd": (".raw", ".zraw", ".raw.gz"), ".nhdr": (".raw", ".raw.gz", ".gz")}


def source_bytes(spec: str) -> int:
    """Bytes of a source: the file (with a MetaImage / detached NRRD header's data file of
    the same name beside it), or the files directly in a source folder; 0 for "demo"."""
    try:
        if os.path.isdir(spec):
            return sum(e.stat().st_size for e in os.scandir(spec) if e.is_file())
        n = os.path.getsize(spec)
    except OSError:
        return 0
    p = Path(spec)
    for ext in _DATA_BESIDE.get(p.suffix.lower(), ()):
        data = p.with_suffix(ext)
        if data.is_file():
            n += data.stat().st_size
            break
    return n


def compile_estimate(reader: ModuleType | None) -> dict[str, float]:
    """The kernels numba has not compiled yet and their estimated seconds: the conversion's
    (``layer_kernel``'s: the first run after an install or upgrade) and the ``reader``
    module's own when it has any (the first use of a source kind), by
    :func:`..core.kernel_cache.uncached` (the cache's index files, ``*.nbi``)."""
    out = {}
    if uncached(layer_kernel):
        out["compiling the conversion kernels"] = COMPILE_SECONDS
    if reader is not None and uncached(reader):
        name = reader.__name__.rsplit(".", 1)[-1]
        out[f"compiling the {name} reader's kernels"] = COMPILE_READER_SECONDS
    return out


def _kind(spec: str) -> str:
    if str(spec) == "demo":
        return "demo"
    if os.path.isdir(spec):
        return "folder"
    return Path(spec).suffix.lower()


def source_seconds(spec: str) -> float:
    """Seconds of opening and placing ``spec`` on an idle machine (:data:`SOURCE_MODEL`)."""
    fixed, per_mb = SOURCE_MODEL.get(_kind(spec), _DEFAULT_MODEL)
    return fixed + per_mb * source_bytes(spec) / 1e6


@dataclass(frozen=True)
class PrepareEstimate:
    """What preparing a job will take, estimated before it starts (module doc)."""

    source_s: float
    tables_s: float
    tables_cold: bool                  # no cached tables: a first build
    builds: dict[str, float] = field(default_factory=dict)   # first-use builds, seconds
    source_text: str = ""
    slowdown: float = 1.0              # machine_slowdown() when estimated: one thread's parts
    parallel_slowdown: float = 1.0     # parallel_slowdown(): the table build's (every core)

    setup_s: float = 0.0               # SETUP_SECONDS, scaled

    @property
    def total_s(self) -> float:
        return self.source_s + self.tables_s + self.setup_s + sum(self.builds.values())

    def describe(self) -> str:
        """One line: the whole estimate, then its parts."""
        parts = [f"the source{self.source_text} {about_text(self.source_s)}"]
        if self.slowdown >= 1.5:
            parts.append(f"the machine {self.slowdown:.1f} x slower than idle now")
        if self.tables_cold:
            parts.append(f"the colour tables: a first build for this profile, printer layer "
                         f"and intent, {about_text(self.tables_s)}")
        parts += [f"{what}: first use, {about_text(s)}" for what, s in self.builds.items()]
        return f"preparing: {about_text(self.total_s)} (" + "; ".join(parts) + ")"

    def to_json(self) -> dict[str, Any]:
        return {"seconds": self.total_s, "source_s": self.source_s, "tables_s": self.tables_s,
                "tables_cold": self.tables_cold, "builds_s": dict(self.builds),
                "slowdown": self.slowdown, "parallel_slowdown": self.parallel_slowdown}


def _reader_module(spec: str) -> ModuleType | None:
    """The reader module that will open ``spec`` (imported: opening it would import it)."""
    if spec == "demo":
        return sys.modules.get("dreamprint_gui.io.volumes.grids.demo")
    try:
        return importlib.import_module(
            f"dreamprint_gui.io.volumes.{FORMATS[sniff_format(Path(spec))][0]}")
    except Exception:  # noqa: BLE001 - an unreadable source is refused when it is opened
        return None


_PROBE = np.random.default_rng(0).random(50_000)
# CPU seconds of one sort of _PROBE on the development machine at its quickest (the model's
# machine): the least of 36 windows of 0.1 s, 0.200 ms, at load 5.9-6.1 (2026-12-02; most
# 0.20-0.23 ms there, 0.27-0.33 ms at load 7.6: a CPU second does less work when the other
# helpers keep both cores busy)
PROBE_SORT_CPU_S = 2.0e-4


def machine_slowdown(cpu_seconds: float = 0.1) -> float:
    """How much slower than the model's idle machine one thread runs now, from a fixed
    workload of about ``cpu_seconds`` (sorting a 50,000-number array again and again): the
    share of a core it gets (wall / CPU time; on a shared machine the job's steps get the same
    share) times how much longer each sort takes in CPU time than :data:`PROBE_SORT_CPU_S`
    (each at least 1). Measured on the 2-core machine under the other helpers' load: 30 ms of
    probe read 2.86-8.11 against a following 0.5 CPU s's 3.0-3.5, 100 ms 3.11-3.37; the share
    alone missed the slower CPU seconds (jobs prepared 1.4-2.2 x the CPU seconds the idle
    estimate holds at load 7-8)."""
    t0, c0 = time.perf_counter(), time.thread_time()
    n = 0
    while time.thread_time() - c0 < cpu_seconds:
        np.sort(_PROBE)
        n += 1
    wall, cpu = time.perf_counter() - t0, time.thread_time() - c0
    if cpu <= 0:
        return 1.0
    return max(1.0, wall / cpu) * max(1.0, cpu / n / PROBE_SORT_CPU_S)


_HASH_BLOCK = np.random.default_rng(1).bytes(1 << 18)
# CPU seconds of one SHA-256 of _HASH_BLOCK (256 KiB) on the development machine at its quickest:
# 0.150 ms (the least of 12 runs of 100, 2026-12-02, load 4-5; hashlib releases the GIL, so
# threads hashing at once run on as many cores as they get)
PROBE_HASH_CPU_S = 1.5e-4


def parallel_slowdown(cpu_seconds: float = 0.05, threads: int | None = None) -> float:
    """How much slower than the model's idle machine a step that keeps every core busy (a
    ``prange`` kernel: the colour tables' build) runs now: ``threads`` (default: the cores this
    process may use) threads each hash :data:`_HASH_BLOCK` the same number of times, about
    ``cpu_seconds`` of an idle core's work each, and the wall time until the last one is done is
    divided by that work (at least 1). One thread's :func:`machine_slowdown` cannot tell this:
    on an idle 2-core machine a step's two threads run at once, under load they share what one
    core would get (2026-12-02 at load 4-5: one thread 3.1-4.3 x slower than idle, two threads
    together 5.4-8.4 x; idle, the 100^3 de2000 build took 17.6-22.0 s wall for 40 CPU s)."""
    if threads is None:
        threads = (len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
                   else os.cpu_count() or 1)
    reps = max(1, round(cpu_seconds / PROBE_HASH_CPU_S))

    def work() -> None:
        for _ in range(reps):
            hashlib.sha256(_HASH_BLOCK).digest()

    pool = [threading.Thread(target=work, daemon=True) for _ in range(max(1, threads))]
    t0 = time.perf_counter()
    for t in pool:
        t.start()
    for t in pool:
        t.join()
    return max(1.0, (time.perf_counter() - t0) / (reps * PROBE_HASH_CPU_S))


def opening_notice(spec: str, at_least_s: float = 2.0) -> str | None:
    """``opening NAME (N MB): about T (reading it, its up axis, its occupied bounds) ...``
    when opening and placing ``spec`` is estimated at ``at_least_s`` or more now
    (:func:`source_seconds` times :func:`machine_slowdown`), else None: what a command that
    opens a source says before the wait."""
    est = source_seconds(str(spec))
    if est < at_least_s / 8:      # not worth a probe: quick even on a busy machine
        return None
    slow = machine_slowdown()
    if est * slow < at_least_s:
        return None
    name = os.path.basename(str(spec).rstrip("/")) or str(spec)
    size = source_bytes(str(spec))
    return (f"opening {name}{f' ({size / 1e6:.0f} MB)' if size else ''}: "
            f"{about_text(est * slow)} (reading it, its up axis, its occupied bounds) ...")



def estimate_preparation(settings: Any) -> PrepareEstimate:
    """How long :func:`.plan.prepare_job` will take for ``settings`` (a
    :class:`.plan.ConvertSettings`: this module is below it), from the source's size and kind
    and what the caches hold (nothing is opened or built)."""
    s = settings
    printer = load_printer(s.printer)
    profile = load_profile(s.profile).with_settings(layer_thickness_mm=printer.layer_thickness_mm)
    cold = build_estimate(profile, s.objective, s.table_size, s.intent)
    builds: dict[str, float] = {}
    if s.halftone == "blue-noise":
        mask = mask_build_estimate(printer.voxel_mm)
        if mask is not None:
            builds["the blue-noise mask"] = mask
    builds.update(compile_estimate(_reader_module(str(s.source))))
    if cold is not None and (colour := kernels_estimate()) is not None:
        builds[COMPILE_WHAT] = colour          # the table build's kernels, first
    size = source_bytes(str(s.source))
    text = "" if str(s.source) == "demo" else f" ({size / 1e6:.1f} MB)"
    slow = machine_slowdown()
    # a first build runs on every core (its prange kernels); loading a cached one on one
    par = parallel_slowdown() if cold is not None else slow
    tables = par * cold if cold is not None else slow * TABLE_LOAD_SECONDS
    return PrepareEstimate(source_s=slow * source_seconds(str(s.source)),
                           tables_s=tables, tables_cold=cold is not None,
                           builds={k: slow * v for k, v in builds.items()}, source_text=text,
                           slowdown=slow, parallel_slowdown=par, setup_s=slow * SETUP_SECONDS)
