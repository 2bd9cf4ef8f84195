"""Pre-flight of a print job: what it will be, estimated before any slice is written.

Defines
-------
- :class:`Preflight`: grid, slices, disk and time estimates, material fractions, warnings;
  :meth:`Preflight.summary_lines` (the terminal / dialog text) and :meth:`Preflight.to_json`.
- :class:`PreflightWarning`: a code, a one-line message and its numbers.
- :func:`preflight`: the estimate for a job (a :class:`...job.plan.JobContext`, a
  :class:`...job.plan.ConvertSettings`, or a source spec with the job's options).
- :func:`record_rate` / :func:`measured_rate`: this machine's conversion rate, kept from the
  jobs it has run (the user cache folder, ``rates.json``).

How each figure is estimated
----------------------------
- Material fractions, clamping and gamut: a *systematic* sample of about ``sample_voxels``
  voxels (a lattice with strides ``sx, sy, sz`` over the job's grid and a seeded random offset
  per axis), sampled by the job's own source (its content rule included) and labelled by the
  job's own compiled kernel (:func:`.layer_kernel.slab_labels`: background threshold, lookup,
  density alignment, halftone). The fractions' standard error is at most
  ``sqrt(p (1 - p) / n)``, 0.11 % at n = 200 000.
- Clamping: the kernel's count of sampled voxels clamped high (denser than the inks reach with
  10 % grey, eq. 13) scaled to the job; the density scale that avoids it is the job's scale times
  the smallest ``reachable / target`` over the sampled voxels (the reachable density
  interpolated in the table like the kernel does).
- Out of gamut: the tables' per-node dE2000 (reproduction vs target) at the nearest node of
  each sampled printed voxel's colour; out of gamut means dE2000 > ``IN_GAMUT_DE2000``.
- Disk and time: up to 16 of the job's own slabs (the middle one of each of n equal runs of
  the job's slabs, n as ~:data:`TIMED_SECONDS` allows, at least 4 where they are quick; after
  the middle slab, which warms the caches; in a thread of their own, as the job's workers)
  sampled, labelled and PNG-encoded exactly as the job does them (:func:`.slab.encode_slab`: a
  splat job's several-layer slabs and its set-up per slab included); their layers' mean size
  times the layer count, plus the manifest; their time per voxel times the job's voxels, plus
  the time to write each slice file (up to 64 of their PNGs written into a temporary folder,
  removed at once) times the layer count, shared by the workers (no more than the job's slabs;
  one with ``--scheduler sync``) at :data:`PARALLEL_EFFICIENCY`, plus
  :data:`CONVERT_OVERHEAD_S`. Timing the job's own source and kernels makes the estimate
  follow the source kind (a splat scene's sampling costs several times a dense grid's per
  voxel), the printer's grid, the file system and the machine. First-use builds (compiled
  kernels, colour tables, blue-noise mask) happen in the preparation, before the pre-flight,
  and are announced there with their own estimate (:func:`...job.plan.prepare_job`).
- :func:`record_rate` keeps the finished jobs' rates (``rates.json``) for the record; the
  estimate no longer uses them (they mixed source kinds and sizes: one rate for all misjudged
  a splat scene 12-fold).
"""

from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from dreamprint_gui.core.durations import about_text, seconds_text
from dreamprint_gui.core.files import cache_folder
from dreamprint_gui.core.profile import INKS, load_profile
from dreamprint_gui.core.threads import DaemonCall
from dreamprint_gui.gamut.evaluation import IN_GAMUT_DE2000
from dreamprint_gui.gamut.forward import forward_model, mixtures_lab
from dreamprint_gui.gamut.mapping import intent_map
from dreamprint_gui.gamut.optimise import srgb_to_xyz
from dreamprint_gui.gamut.tables import F_CONC, F_GREY, F_SIGMA, interpolate_fields
from dreamprint_gui.job.plan import (
    ConvertSettings,
    JobContext,
    job_workers,
    prepare_job,
    scheduler_kind,
    slab_plan,
)
from dreamprint_gui.job.sample_label.layer_kernel import slab_labels
from dreamprint_gui.job.slab import encode_slab
from dreamprint_gui.job.write import write_atomic
from dreamprint_gui.physics.colorimetry import delta_E2000

__all__ = ["Preflight", "PreflightWarning", "preflight", "record_rate", "measured_rate",
           "BENCHMARK_RATE", "MOSTLY_CLEAR", "OUT_OF_GAMUT_WARN"]

# Voxels per second of `convert` on the 2-core development machine at 1e8 voxels (the demo,
# benchmarks/bench_convert.py): 27.7-45.6 Mvox/s in docs/speed-history.md's rounds; the lower.
BENCHMARK_RATE = 27.7e6
MOSTLY_CLEAR = 0.98      # warn when Clear + empty exceed this fraction of the job
OUT_OF_GAMUT_WARN = 0.01  # warn when more than this fraction of printed voxels is out of gamut
_LABELS = (*INKS, "empty")
_RATES_KEPT = 9


@dataclass(frozen=True)
class PreflightWarning:
    """``code`` (mostly-clear, clamped, out-of-gamut), a one-line ``message``, ``numbers``."""

    code: str
    message: str
    numbers: dict[str, float] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {"code": self.code, "message": self.message, "numbers": dict(self.numbers)}


@dataclass
class Preflight:
    """The estimate of a job (module doc)."""

    grid_shape: tuple[int, int, int]          # voxels x, y, z
    size_mm: tuple[float, float, float]
    slices: int
    total_voxels: int
    disk_bytes: int
    fractions: dict[str, float]               # label -> estimated fraction of the job
    sampled_voxels: int
    clamped_fraction: float                   # of the job, clamped high (too dense)
    clamped_voxels: int                       # estimated, in the whole job
    safe_density_scale: float | None          # the scale that avoids clamping (None: no clamp)
    out_of_gamut_fraction: float              # of the printed (non-background) voxels
    worst_dE2000: float
    seconds: float                            # estimated conversion time (after preparing)
    rate_voxels_per_s: float
    rate_source: str                          # what the time was measured on (slabs, workers)
    content: dict[str, Any]
    density_scale: float
    background: str
    warnings: list[PreflightWarning] = field(default_factory=list)
    estimate_seconds: float = 0.0             # what this pre-flight took
    placement: dict[str, Any] = field(default_factory=dict)  # orientation, fit, object size
    printed_fraction: float = 0.0             # of the job, at or above the background threshold
    clamped_printed_fraction: float = 0.0     # of the printed voxels, clamped high
    # at safe_density_scale, the share of the printed voxels that would fall to the background
    lost_at_safe_scale: float | None = None
    # no clamping: the largest --density-scale that still clamps none of the sampled voxels
    max_unclamped_density_scale: float | None = None
    intent: str = "colorimetric"              # the rendering intent gamut is measured against
    # seconds the job already spent before this estimate: opening the source and loading or
    # building the colour tables (measured; 0 when the job reuses a prepared context)
    prepared_seconds: float = 0.0
    # the CPU seconds of the process meanwhile (all threads): on a shared machine, what the
    # idle machine's estimate is compared with (benchmarks/bench_preflight.py)
    prepared_cpu_seconds: float = 0.0
    # what preparing was estimated to take before it started (.prepare_time.PrepareEstimate's
    # to_json; None when the job reuses a prepared context, or for a context about to be made)
    prepare_estimate: dict | None = None

    @property
    def ink_fraction(self) -> float:
        return sum(self.fractions.get(k, 0.0) for k in INKS if k != "Cl")

    def short_line(self) -> str:
        """One line: the job's size, disk and time estimates and the number of warnings."""
        n = len(self.warnings)
        return (f"pre-flight: {self.total_voxels:,} voxels in {self.slices:,} slices, about "
                f"{_human_bytes(self.disk_bytes)}, {self.time_text()}; "
                + (f"{n} warning{'s' if n != 1 else ''}" if n else "no warnings"))

    def time_text(self) -> str:
        """The conversion's estimate and, when preparing takes a while, the job's whole time
        with it (a first build of the colour tables, a slow source): preparing as estimated
        before it started (:mod:`.prepare_time`) and, once done, as it took."""
        est = (self.prepare_estimate or {}).get("seconds", 0.0)
        if max(est, self.prepared_seconds) < 1:
            return about_text(self.seconds)
        what = "the source, the colour tables, first-use builds"
        if not est:
            how = f"preparing took {seconds_text(self.prepared_seconds)}: {what}"
        else:
            how = f"preparing estimated {seconds_text(est)} before it started: {what}"
            if self.prepared_seconds > 0:
                how += f"; it took {seconds_text(self.prepared_seconds)}"
        return (f"{about_text(self.seconds)} to convert, "
                f"{about_text(self.seconds + (est or self.prepared_seconds))} in all "
                f"({how})")

    def summary_lines(self) -> list[str]:
        """The human-readable summary: one line per figure, then one per warning."""
        nx, ny, nz = self.grid_shape
        sx, sy, sz = self.size_mm
        fr = ", ".join(f"{k} {100 * v:.1f} %" for k, v in self.fractions.items()
                       if v > 0 or k != "empty")
        lines = [
            f"job: {nx} x {ny} x {nz} voxels ({sx:.2f} x {sy:.2f} x {sz:.2f} mm), "
            f"{nz:,} slices, {self.total_voxels:,} voxels",
            f"content: {self.content.get('mode')} ({self.content.get('reason')})",
            *_placement_lines(self.placement),
            f"materials (estimated from {self.sampled_voxels:,} voxels): {fr}",
            f"disk: about {_human_bytes(self.disk_bytes)}; conversion: "
            f"{about_text(self.seconds)} at {self.rate_voxels_per_s / 1e6:.1f} Mvox/s "
            f"({self.rate_source})",
        ]
        if max(self.prepared_seconds, (self.prepare_estimate or {}).get("seconds", 0)) >= 1:
            lines.append(f"time: {self.time_text()}")
        lines += [f"warning: {w.message}" for w in self.warnings]
        return lines

    def to_json(self) -> dict[str, Any]:
        return {
            "grid_dimensions": list(self.grid_shape), "size_mm": list(self.size_mm),
            "slices": self.slices, "total_voxels": self.total_voxels,
            "disk_bytes_estimate": self.disk_bytes, "material_fractions": dict(self.fractions),
            "sampled_voxels": self.sampled_voxels,
            "clamped_fraction_estimate": self.clamped_fraction,
            "clamped_voxels_estimate": self.clamped_voxels,
            "density_scale": self.density_scale,
            "density_scale_without_clamping": self.safe_density_scale,
            "out_of_gamut_fraction": self.out_of_gamut_fraction,
            "worst_dE2000": self.worst_dE2000,
            "seconds_estimate": self.seconds,
            "rate_voxels_per_second": self.rate_voxels_per_s, "rate_source": self.rate_source,
            "content": dict(self.content), "background": self.background,
            "placement": dict(self.placement),
            "warnings": [w.to_json() for w in self.warnings],
            "estimate_seconds": self.estimate_seconds,
            "printed_fraction": self.printed_fraction,
            "clamped_printed_fraction": self.clamped_printed_fraction,
            "printed_lost_at_safe_scale": self.lost_at_safe_scale,
            "max_unclamped_density_scale": self.max_unclamped_density_scale,
            "intent": self.intent,
            "prepared_seconds": self.prepared_seconds,
            "prepared_cpu_seconds": self.prepared_cpu_seconds,
            "prepare_estimate": self.prepare_estimate,
        }


def _human_bytes(n: float) -> str:
    for unit in ("bytes", "kB", "MB", "GB"):
        if n < 1000 or unit == "GB":
            return f"{n:.0f} {unit}" if unit == "bytes" else f"{n:.1f} {unit}"
        n /= 1000
    return f"{n:.1f} TB"  # pragma: no cover



# ----------------------------------------------------------------------------- rate
def _rates_file() -> Path:
    return cache_folder() / "rates.json"


def record_rate(voxels: int, seconds: float) -> None:
    """Keep a finished job's rate (voxels per second of its conversion, after the preparation)
    for the time estimate; the last few are kept. Jobs under 1e6 voxels are ignored."""
    if voxels < 1_000_000 or not seconds > 0:
        return
    path = _rates_file()
    try:
        rates = json.loads(path.read_text())["rates"] if path.is_file() else []
    except (OSError, ValueError, KeyError, TypeError):
        rates = []
    rates = [float(r) for r in rates if isinstance(r, (int, float))][-(_RATES_KEPT - 1):]
    rates.append(voxels / seconds)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(json.dumps({"rates": rates}))
        os.replace(tmp, path)
    except OSError:
        pass


def measured_rate() -> tuple[float, str]:
    """(voxels per second, where it comes from): the median of this machine's recorded jobs, or
    :data:`BENCHMARK_RATE`."""
    try:
        rates = json.loads(_rates_file().read_text())["rates"]
        rates = [float(r) for r in rates if isinstance(r, (int, float)) and r > 0]
    except (OSError, ValueError, KeyError, TypeError):
        rates = []
    if rates:
        return float(np.median(rates)), f"measured: median of this machine's last {len(rates)} " \
                                        "jobs"
    return BENCHMARK_RATE, "benchmark constant, no job measured on this machine yet"


# ----------------------------------------------------------------------------- sampling
def _lattice(n: int, stride: int, rng: np.random.Generator) -> tuple[int, int]:
    """(offset, count) of a lattice of ``stride`` over ``n`` with a random offset."""
    off = int(rng.integers(0, stride)) if stride > 1 else 0
    off = min(off, n - 1)
    return off, len(range(off, n, stride))


def _sub_grid(grid, strides, offsets, counts):
    """The job grid's voxels ``offset + stride * i`` per axis, as a grid of their own (same
    voxel centres, see ``io.volumes.base.voxel_centres``)."""
    vox = tuple(v * s for v, s in zip(grid.voxel_mm, strides, strict=True))
    origin = tuple(o + (off + 0.5 - 0.5 * s) * v / grid.mm_per_unit
                   for o, off, s, v in zip(grid.origin, offsets, strides, grid.voxel_mm,
                                           strict=True))
    return replace(grid, shape_xyz=tuple(counts), voxel_mm=vox, origin=origin)


def _intent_de(ctx, tables, near: np.ndarray) -> np.ndarray:
    """dE2000 between what each of the nodes ``near`` (N, 3) prints and its target under the
    tables' rendering intent (the node's colour mapped by the intent: white onto the printable
    white for ``relative``, SGCK for ``perceptual``); each distinct node is computed once."""
    import colour

    profile = load_profile(ctx.settings.profile).with_settings(
        layer_thickness_mm=ctx.printer.layer_thickness_mm)
    model = forward_model(profile)
    nodes, inverse = np.unique(near, axis=0, return_inverse=True)
    n = tables.packed.shape[0]
    conc = np.asarray(tables.packed[nodes[:, 0], nodes[:, 1], nodes[:, 2], F_CONC], np.float64)
    target = intent_map(model, tables.intent).map_xyz(srgb_to_xyz(model, nodes / (n - 1)))
    target_lab = colour.XYZ_to_Lab(target, illuminant=colour.XYZ_to_xy(model.white))
    return delta_E2000(mixtures_lab(model, conc), target_lab)[inverse.reshape(-1)]


def _node_fields(tables, rgb: np.ndarray, ctx=None) -> tuple[np.ndarray, np.ndarray]:
    """(reachable density 1/mm with 10 % grey, tetrahedral as the kernel; dE2000 of the nearest
    node to its target under the tables' intent: the source colour for ``colorimetric``) of
    encoded sRGB ``rgb`` (N, 3)."""

    p = tables.packed
    n = p.shape[0]
    s0, sg = interpolate_fields(p, rgb, [F_SIGMA, F_GREY]).T
    c = np.clip(np.nan_to_num(rgb.astype(np.float64)), 0.0, 1.0) * (n - 1)
    # as align_rows: the grey raises the density up to sg, unless it is no denser than s0
    reach = np.maximum(s0, sg)
    near = np.rint(c).astype(np.int64)
    if ctx is not None and getattr(tables, "intent", "colorimetric") != "colorimetric":
        return reach, _intent_de(ctx, tables, near)
    de = np.asarray(tables.dE2000)[near[:, 0], near[:, 1], near[:, 2]].astype(np.float64)
    return reach, de


def _slab_estimate(ctx, workers: int, say: Callable[[str], None] = lambda _m: None
                   ) -> tuple[int, float, int, int, float, int]:
    """(bytes of the job's slices, seconds per voxel on one worker, slabs and layers timed,
    seconds to write one slice file, the job's slab count).

    Timed on the job's own slabs (:func:`...plan.slab_plan` for ``workers``), each sampled,
    labelled and PNG-encoded by the job's :func:`.slab.encode_slab`: a sampler's set-up per slab (a
    Gaussian-splat job's slabs are several layers thick, and it bins and sets up its Gaussians
    once per slab) and the fused samplers' per-call costs count as in the job. The middle slab
    goes first, to warm the source's and the kernels' caches and to size the sample: then
    ``n`` slabs (as many as :data:`TIMED_SECONDS` allows at the middle slab's speed, at least 4
    where 4 take at most ten times that, at most 16 and the job's count), the middle one of each
    of ``n`` equal runs of slabs, are timed: the sparse ends of an object count as much as its
    dense middle. The slices' size is the timed layers' mean PNG size times the layer count; up
    to 64 of their PNGs are written as the slabs write slices (:func:`_write_seconds`)."""
    # In a thread of its own, as the job's workers run slabs: a source that spreads one call
    # over the cores when called from the main thread (InstantNGP) then runs one thread, as in
    # the job (timed on the main thread, a CLI's InstantNGP job was estimated 1.6x too fast).
    # A daemon thread, so that an interrupted pre-flight (Ctrl-C) need not wait for its slabs.
    return DaemonCall(lambda: _time_slabs(ctx, workers, say),
                      "dreamprint-preflight-timing").result()


def _time_slabs(ctx, workers: int, say: Callable[[str], None]
                ) -> tuple[int, float, int, int, float, int]:
    nx, ny, nz = ctx.shape_xyz
    slabs = slab_plan(ctx, workers)
    say(f"pre-flight: timing the job's middle slab (layers {slabs[len(slabs) // 2][0]}-"
        f"{slabs[len(slabs) // 2][1] - 1} of {nz})")

    def convert(z0: int, z1: int) -> tuple[float, list[bytes]]:
        t0 = time.perf_counter()
        pngs = encode_slab(ctx, z0, z1)[0]
        return time.perf_counter() - t0, pngs

    t_mid, _ = convert(*slabs[len(slabs) // 2])
    n = _timed_count(len(slabs), t_mid)
    picks = {int((i + 0.5) * len(slabs) / n) for i in range(n)}  # one per stratum
    timed = 0.0
    layers = 0
    png_bytes = 0
    sample: list[bytes] = []  # the PNGs whose writing is timed: at most 64
    for k, i in enumerate(sorted(picks)):
        say(f"pre-flight: timing slab {k + 1} of {len(picks)} (layers {slabs[i][0]}-"
            f"{slabs[i][1] - 1})")
        t, pngs = convert(*slabs[i])
        timed += t
        layers += len(pngs)
        png_bytes += sum(len(p) for p in pngs)
        sample += pngs[:max(0, 64 - len(sample))]
    disk = int(png_bytes / layers * nz) + 16_384
    return disk, timed / (layers * nx * ny), len(picks), layers, _write_seconds(sample), len(slabs)


def _timed_count(n_slabs: int, t_mid: float) -> int:
    """How many of a job's ``n_slabs`` slabs the pre-flight times, the middle one having taken
    ``t_mid`` s: as many as :data:`TIMED_SECONDS` allows, at least 4 where 4 take at most ten
    times that (an InstantNGP job's slabs, or a user's thick ones, may take seconds each), at
    most 16 and ``n_slabs``."""
    fit = TIMED_SECONDS / max(t_mid, 1e-9)
    return min(n_slabs, 16, max(1, int(fit), min(4, int(10 * fit))))


def _write_seconds(pngs: list[bytes]) -> float:
    """Mean seconds to write one of ``pngs`` as a new file, as the slabs write slices.

    Timed in the system's temporary folder, never beside the job's output: a pre-flight runs
    while the operator edits or cancels an export, and nothing of it may appear in (or be left
    in) the folder the job goes to."""
    folder = tempfile.mkdtemp(prefix=".dp-preflight-")
    try:
        t0 = time.perf_counter()
        for i, png in enumerate(pngs):
            write_atomic(os.path.join(folder, f"{i:05d}.png"), png)
        return (time.perf_counter() - t0) / max(1, len(pngs))
    except OSError:
        return 0.0
    finally:
        shutil.rmtree(folder, ignore_errors=True)


# Share of the workers' time that is useful work when a job's slabs run on every core (slab
# scheduling, the writer thread, the source's hash; the cores' shared memory bandwidth), and
# the fixed cost of a conversion besides its slabs (the scheduler's start, each worker's first
# slab buffers, the manifest): fitted to benchmarks/bench_preflight.py --samples at 30 and
# 60 mm on the sample files (2 cores, 2e8-4e9 voxels; actual / estimated 0.9-1.15 with them).
PARALLEL_EFFICIENCY = 0.88
CONVERT_OVERHEAD_S = 0.15
# About the seconds the pre-flight spends timing the job's slabs (:func:`_timed_count`)
TIMED_SECONDS = 0.3


def preflight(source: JobContext | ConvertSettings, *, sample_voxels: int = 200_000,
              seed: int = 0, notify: Callable[[str], None] | None = None) -> Preflight:
    """The pre-flight estimate of a job (module doc for how each figure is made).

    ``source``: a prepared :class:`...job.plan.JobContext` (the CLI and the GUI pass the job's
    own, so nothing is opened twice), or a :class:`...job.plan.ConvertSettings` to prepare.
    ``sample_voxels``: the size of the material sample; ``seed``: its lattice offset.
    ``notify(message)``: each step as it starts (sampling, each timed slab: seconds each on a
    slow source; called from a worker thread too).
    """
    say = notify or (lambda _m: None)

    t0 = time.perf_counter()
    ctx = source if isinstance(source, JobContext) else prepare_job(source)
    s = ctx.settings
    src, tables = ctx.resources()
    nx, ny, nz = ctx.shape_xyz
    total = nx * ny * nz
    # Strides: equal factor per axis (at least 1) so that about sample_voxels are sampled.
    f = max(1.0, (total / max(1, sample_voxels)) ** (1 / 3))
    strides = [max(1, int(math.floor(f))) for _ in range(3)]
    while math.prod(math.ceil(n / st) for n, st in zip((nx, ny, nz), strides, strict=True)) \
            > 1.5 * sample_voxels:
        a = int(np.argmax([n / st for n, st in zip((nx, ny, nz), strides, strict=True)]))
        strides[a] += 1
    rng = np.random.default_rng(seed)
    lat = [_lattice(n, st, rng) for n, st in zip((nx, ny, nz), strides, strict=True)]
    sub = _sub_grid(ctx.grid, strides, [o for o, _ in lat], [c for _, c in lat])
    snx, sny, snz = sub.shape_xyz
    say(f"pre-flight: sampling {snx * sny * snz:,} voxels of the job's materials")
    rgb, dens = src.sample_slab(sub, 0, snz, density_scale=s.density_scale)
    rgb = np.ascontiguousarray(np.asarray(rgb, np.float32).reshape(snz, -1, 3))
    dens = np.ascontiguousarray(np.asarray(dens, np.float32).reshape(snz, -1))
    labels = np.empty((snz, sny, snx), np.uint8)
    counts = np.zeros(7, np.int64)
    stats = np.zeros(4)
    slab_labels(rgb, dens, 0, *ctx.kernel_args(), labels, counts, np.zeros((snz, 7)), stats)
    n = int(labels.size)
    fractions = {lab: float(counts[i]) / n for i, lab in enumerate(_LABELS)}
    # Clamping (high: denser than reachable) and the scale that avoids it.
    fg = (dens >= ctx.halftoner.threshold).reshape(-1)
    frgb = rgb.reshape(-1, 3)[fg]
    ftarget = dens.reshape(-1)[fg].astype(np.float64)
    reach, de = _node_fields(tables, frgb, ctx) if fg.any() else (np.zeros(0), np.zeros(0))
    clamped_frac = float(stats[1]) / n
    printed = int(fg.sum())
    fog = ctx.content is None or ctx.content.mode == "fog"
    safe = lost = up = None
    if stats[1] > 0 and s.density_scale > 0:
        over = ftarget > reach
        if over.any():
            f_safe = float(np.min(reach[over] / ftarget[over]))
            safe = float(s.density_scale * f_safe)
            # what the safe scale costs: printed voxels it would thin below the background
            lost = float(np.mean(ftarget * f_safe < ctx.halftoner.threshold))
    elif fog and printed and s.density_scale > 0:
        pos = ftarget > 0
        if pos.any():
            up = float(s.density_scale * np.min(reach[pos] / ftarget[pos]))
    oog = float(np.mean(de > IN_GAMUT_DE2000)) if len(de) else 0.0
    worst = float(de.max()) if len(de) else 0.0
    n_workers = job_workers(s)
    disk, spv, n_slabs, n_layers, write_s, job_slabs = _slab_estimate(ctx, n_workers, say)
    # the slabs that run at once: no more than the job has, one with --scheduler sync
    workers = 1 if scheduler_kind(s) == "sync" else max(1, min(n_workers, job_slabs))
    seconds = CONVERT_OVERHEAD_S + (spv * total + write_s * nz) / (workers * PARALLEL_EFFICIENCY)
    rate = total / seconds
    rate_source = (f"timed on {n_slabs} of this job's slabs, {n_layers} layer"
                   f"{'s' if n_layers > 1 else ''}, {workers} worker{'s' if workers > 1 else ''}")
    content_json = (ctx.content.to_json() if ctx.content is not None
                    else {"mode": "fog", "requested": s.content, "reason": ""})
    vx, vy, vz = ctx.printer.voxel_mm
    pf = Preflight(
        grid_shape=(nx, ny, nz), size_mm=(nx * vx, ny * vy, nz * vz), slices=nz,
        total_voxels=total, disk_bytes=disk, fractions=fractions, sampled_voxels=n,
        clamped_fraction=clamped_frac, clamped_voxels=int(round(clamped_frac * total)),
        safe_density_scale=safe, out_of_gamut_fraction=oog, worst_dE2000=worst,
        seconds=seconds, rate_voxels_per_s=rate, rate_source=rate_source,
        content=content_json, density_scale=s.density_scale, background=s.background,
        printed_fraction=printed / n,
        clamped_printed_fraction=float(stats[1]) / printed if printed else 0.0,
        lost_at_safe_scale=lost, max_unclamped_density_scale=up,
        intent=getattr(tables, "intent", "colorimetric"),
        placement=ctx.placement_json())
    pf.warnings = _warnings(pf)
    pf.estimate_seconds = time.perf_counter() - t0
    return pf


def _placement_lines(place: dict) -> list[str]:
    """``orientation: ...`` and ``size: ...`` of a job's placement (``JobContext.placement_json``)
    : how it stands and what the printed object measures."""
    if not place:
        return []
    fit = place.get("fit") or {}
    size = " x ".join(f"{v:.2f}" for v in place.get("object_size_mm", ()))
    what = ("the object's occupied bounds, empty margins cropped" if fit.get("mode") ==
            "occupied" else "the file's declared box" + (f" ({fit['note']})"
                                                         if fit.get("note") else ""))
    return [f"orientation: {place.get('orientation_text', '')}",
            f"printed object: {size} mm (x, y, z; --fit {fit.get('mode', 'box')}: {what})"]


# A lower --density-scale is suggested against clamping only when it keeps the content's look:
# at most this share of the printed voxels may fall to the background at the suggested scale,
# and at most this share of them may be clamped now (more means the object is meant dense).
KEEP_PRINTED = 0.05
SUGGEST_BELOW_CLAMPED = 0.10


def _at_most(limit: float) -> str:
    """``limit`` to three significant digits, rounded down: a scale the warnings name as one
    that clamps nothing must not exceed the limit they measured (0.24750 reads 0.247, not
    0.248; the 1e-12 spares exact values such as 0.25 from reading 0.249)."""
    if not limit > 0 or not math.isfinite(limit):
        return f"{limit:.3g}"
    step = 10.0 ** (math.floor(math.log10(limit)) - 2)
    return f"{math.floor(limit / step * (1 + 1e-12)) * step:.3g}"


def _warnings(pf: Preflight) -> list[PreflightWarning]:
    """The warnings of a pre-flight, made together so that they never contradict each other:

    - mostly Clear with clamped cores: only ``--content solid`` is suggested (a lower scale would
      thin the haze further, a higher one clamp more), and the clamp warning then suggests no
      scale;
    - clamping: a scale that avoids it is suggested only if it keeps the content's look (at most
      :data:`KEEP_PRINTED` of the printed voxels fall to the background, fewer than
      :data:`SUGGEST_BELOW_CLAMPED` clamped now); otherwise the warning says why the scale is
      kept (a dense object prints at the inks' densest) and what a lower one would do;
    - a solid job gets no density-scale advice (its density is not the source's);
    - a faint fog without clamping is told how far the scale can rise without clamping.
    """
    out = []
    fog = pf.content.get("mode", "fog") == "fog"
    clear = pf.fractions.get("Cl", 0.0) + pf.fractions.get("empty", 0.0)
    mostly_clear = clear > MOSTLY_CLEAR
    clamped = pf.clamped_voxels > 0
    if mostly_clear:
        if not fog:
            hint = "little of the grid is occupied: check the source and its bounds"
        elif clamped:  # a lower scale thins the haze, a larger one clamps more: only solid helps
            hint = ("the source prints as a faint haze around cores denser than the inks: "
                    "try --content solid")
        else:
            up = pf.max_unclamped_density_scale
            if up is not None and up > 1.5 * pf.density_scale:
                hint = (f"the source prints as a faint haze: try --content solid, or a larger "
                        f"--density-scale (up to {_at_most(up)} clamps none of the sampled "
                        "voxels)")
            else:
                hint = "the source prints as a faint haze: try --content solid"
        nums = {"clear_or_empty_fraction": clear, "ink_fraction": pf.ink_fraction}
        if fog and not clamped and pf.max_unclamped_density_scale is not None:
            nums["max_unclamped_density_scale"] = pf.max_unclamped_density_scale
        out.append(PreflightWarning(
            "mostly-clear", f"the job would be {100 * clear:.1f} % Clear or empty "
            f"(ink {100 * pf.ink_fraction:.2f} %): {hint}", nums))
    if clamped:
        msg = (f"about {pf.clamped_voxels:,} voxels ({100 * pf.clamped_fraction:.2f} % of the job, "
               f"{100 * pf.clamped_printed_fraction:.1f} % of the printed voxels) are denser "
               "than the inks can print and will print at the inks' densest")
        nums = {"clamped_voxels": pf.clamped_voxels, "clamped_fraction": pf.clamped_fraction,
                "clamped_printed_fraction": pf.clamped_printed_fraction,
                "density_scale": pf.density_scale}
        safe, lost = pf.safe_density_scale, pf.lost_at_safe_scale
        if safe is not None:
            nums["density_scale_without_clamping"] = safe
        if lost is not None:
            nums["printed_lost_at_that_scale"] = lost
        if not fog:
            pass  # a solid's density is not the source's: no scale to suggest
        elif mostly_clear:
            msg += " (see the Clear warning: --content solid, not a lower scale)"
        elif safe is not None and lost is not None and lost <= KEEP_PRINTED \
                and pf.clamped_printed_fraction < SUGGEST_BELOW_CLAMPED:
            msg += (f"; --density-scale {_at_most(safe)} or less avoids it in the sampled voxels "
                    "(the densest voxels may be unsampled: a little less is safer)")
        elif safe is not None:
            msg += ("; the dense parts read as solid, so the scale is kept: "
                    f"--density-scale {_at_most(safe)} would avoid clamping but thin the whole "
                    f"object {pf.density_scale / max(safe, 1e-300):.3g}-fold"
                    + (f" ({100 * lost:.0f} % of its printed voxels would turn to background)"
                       if lost else "")
                    + "; --content solid prints it solid on purpose")
        out.append(PreflightWarning("clamped", msg, nums))
    if pf.out_of_gamut_fraction > OUT_OF_GAMUT_WARN:
        pct = f"{100 * pf.out_of_gamut_fraction:.1f} % of the printed voxels' colours"
        if pf.intent == "colorimetric":
            msg = (f"{pct} are outside the printable gamut (worst dE2000 {pf.worst_dE2000:.1f} "
                   "from the source colour, the colorimetric target; the printable white itself "
                   "is sRGB about 0.77, 0.81, 0.82): they print as the nearest printable colour; "
                   "--intent relative maps the source white to the printable white")
        else:
            msg = (f"{pct} print more than dE2000 {_in_gamut_de():g} from the {pf.intent} "
                   f"intent's target (worst {pf.worst_dE2000:.1f})")
        out.append(PreflightWarning(
            "out-of-gamut", msg,
            {"out_of_gamut_fraction": pf.out_of_gamut_fraction,
             "worst_dE2000": pf.worst_dE2000}))
    return out


def _in_gamut_de() -> float:
    return float(IN_GAMUT_DE2000)
