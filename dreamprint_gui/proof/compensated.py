"""Compensation as part of other work: a compensated export, and open-loop vs compensated proofs.

Defines :func:`compensate_settings_for` (the compensation of a job's ``ConvertSettings``),
:func:`correction_path_for` (where ``convert --compensate`` writes it: beside the job),
:func:`run_compensated_conversion` (optimise, then convert with the correction; the export
dialog's "Compensate appearance" and ``convert --compensate``), :func:`compare_compensation`
(optimise on the training cameras, then the proof of the open-loop job and of the compensated
one on the proof's cameras; the proof tab's "Compensate appearance") and :class:`PhaseClock`
(one progress fraction and time left over several phases of unequal cost).

Cancel or an error leaves nothing: the correction a compensated export wrote is removed with the
partial job, and the proof tab's correction lives in a temporary file removed in any case.
"""

from __future__ import annotations

import os
import tempfile
import threading
import time
from collections.abc import Generator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.generators import relay
from dreamprint_gui.job.correction import save_correction
from dreamprint_gui.job.plan import ConvertProgress, ConvertSettings, JobCancelled
from dreamprint_gui.job.resume import find_interrupted
from dreamprint_gui.job.run import run_conversion
from dreamprint_gui.job.write import check_target
from dreamprint_gui.proof.compensate import CompensateSettings, optimise, run_compensate
from dreamprint_gui.proof.runner import ProofProgress, ProofSettings, render_proof

__all__ = ["compensate_settings_for", "correction_path_for", "run_compensated_conversion",
           "compare_compensation", "PhaseClock", "CompensationProgress"]


def correction_path_for(job_output: str | os.PathLike) -> Path:
    """``JOB.correction.npz`` beside the job folder ``JOB``."""
    return Path(str(job_output).rstrip("/\\") + ".correction.npz")


def compensate_settings_for(s: ConvertSettings, output: str | None = None,
                            **overrides: Any) -> CompensateSettings:
    """The compensation of the job ``s`` (its print spec: source, size, placement, printer,
    profile, content, intent and objective, seed, halftoning, density, background; and its
    background threshold), written to ``output``; ``overrides`` set the optimiser's own
    settings (views, iterations, resolution, spp)."""
    return CompensateSettings.from_spec(replace(s.spec, compensation=None), output=output,
                                        overwrite=s.overwrite,
                                        density_threshold=s.density_threshold, **overrides)


@dataclass(frozen=True)
class CompensationProgress:
    """Progress over all phases: ``fraction`` 0..1, ``eta_s`` None until measurable."""

    stage: str              # "compensating", "converting", "proof (open loop)", ...
    fraction: float
    elapsed_s: float
    eta_s: float | None
    message: str = ""
    inner: Any = None       # the phase's own progress item (ProofProgress, ConvertProgress)


class PhaseClock:
    """One fraction done and time left over phases weighted by their expected cost.

    ``weights`` (name -> relative cost); the time left is the elapsed time scaled by the work
    left over the work done, once some work (``min_done``) is done: the phases' weights only
    need to be right relative to one another, not in seconds.
    """

    def __init__(self, weights: dict[str, float], min_done: float = 0.02) -> None:
        total = sum(weights.values())
        self.start: dict[str, float] = {}
        acc = 0.0
        for k, w in weights.items():
            self.start[k] = acc / total
            acc += w
        self.share = {k: w / total for k, w in weights.items()}
        self.min_done = min_done
        self.t0 = time.perf_counter()

    def elapsed(self) -> float:
        return time.perf_counter() - self.t0

    def fraction(self, phase: str, within: float) -> float:
        return self.start[phase] + self.share[phase] * min(max(within, 0.0), 1.0)

    def progress(self, phase: str, within: float, message: str = "",
                 inner: Any = None) -> CompensationProgress:
        f = self.fraction(phase, within)
        el = self.elapsed()
        eta = el * (1.0 - f) / f if f >= self.min_done else None
        return CompensationProgress(phase, f, el, eta, message, inner)


def _optimise_within(p: ProofProgress, state: dict) -> float:
    """How far the optimiser is (0..1) from its progress items: iterations done, plus the
    current print render's part of one iteration."""
    if p.stage == "iteration":
        state["done"], state["total"] = p.done, max(1, p.total)
        # the optimiser's own "about N s left" is for its iterations alone: the clock says more
        state["msg"] = p.message.split(", about ")[0]
        return p.done / max(1, p.total)
    sub = p.done / p.total if p.stage.startswith("print") and p.total else 0.0
    return (state.get("done", 0) + 0.9 * sub) / state["total"]


def _proof_within(p: ProofProgress) -> float:
    if p.stage == "print" and p.total:
        return 0.1 + 0.8 * p.done / p.total
    return {"preparing": 0.0, "labels": 0.05, "source": 0.08, "compare": 0.95,
            "gamut floor": 0.97, "writing": 0.99}.get(p.stage, 0.0)


def run_compensated_conversion(settings: ConvertSettings, cancel: threading.Event | None = None,
                               preflight: Any = True, **optimiser: Any
                               ) -> Generator[CompensationProgress, None, dict[str, Any]]:
    """Optimise a correction for the job ``settings`` (written to
    :func:`correction_path_for` its output), then convert with it: ``convert --compensate``
    and the export dialog's "Compensate appearance" alike. Yields
    :class:`CompensationProgress` (``inner``: the optimiser's ProofProgress, then the
    conversion's ConvertProgress); returns the job's manifest.

    The correction goes with the job it was made for: a cancel or an error that removes the
    partial job removes the correction too, while an interrupted run that keeps its finished
    layers for ``--resume`` (Ctrl-C, a kill, a full disk) keeps it, and ``settings.resume``
    finishes that run with the correction beside it instead of optimising another. With
    ``settings.overwrite`` the job being replaced keeps its own correction until the new job is
    in place: a run that fails or is cancelled leaves both as they were."""
    if settings.output is None:
        raise DreamPrintError("no output folder given (-o JOB)")
    check_target(settings.output, settings.overwrite)  # before minutes of optimising
    out = correction_path_for(settings.output)
    cs = compensate_settings_for(settings, str(out), **optimiser)
    # the optimiser's renders against one conversion: about 5 parts to 1 (bench_compensate)
    clock = PhaseClock({"compensating": 5.0, "converting": 1.0})
    state: dict = {"total": int(cs.iterations) + 1}
    reuse = settings.resume and out.is_file() and find_interrupted(settings.output) is not None
    aside = None
    if not reuse and settings.overwrite and out.exists():
        # the correction of the job --overwrite replaces: put back if this run does not finish
        aside = out.with_name(f".{out.name}.old-{os.getpid()}")
        os.replace(out, aside)
    try:
        if not reuse:
            yield from _optimise_into(cs, cancel, clock, state)
        if cancel is not None and cancel.is_set():
            raise JobCancelled("the export was cancelled")
        conv = run_conversion(replace(settings, compensation=str(out)), cancel,
                              preflight=preflight)

        def converting(c: ConvertProgress):
            within = c.layers_done / c.layers_total if c.layers_total else 0.0
            return clock.progress("converting", within, c.message, c)

        manifest = yield from relay(conv, converting)
    except BaseException:
        # this run's correction goes with the job it was made for, unless the job is kept
        if (state.get("written") or reuse) and find_interrupted(settings.output) is None:
            out.unlink(missing_ok=True)
        if aside is not None and not out.exists():
            os.replace(aside, out)   # the job left in place keeps its own correction
        elif aside is not None:      # kept for --resume, which replaces the old job
            aside.unlink(missing_ok=True)
        raise
    if aside is not None:
        aside.unlink(missing_ok=True)
    return manifest


def _optimise_into(cs: CompensateSettings, cancel: threading.Event | None, clock: PhaseClock,
                   state: dict) -> Generator[CompensationProgress, None, None]:
    """:func:`.compensate.run_compensate` (the correction written to ``cs.output``) as the
    first phase of ``clock``; ``state["written"]`` once the file is there. The manifest
    records the optimiser's report (``job.run``)."""
    gen = run_compensate(cs, cancel)
    try:
        while True:
            p = next(gen)
            if p.stage == "done":  # run_compensate has saved the correction
                state["written"] = True
            yield clock.progress("compensating", _optimise_within(p, state),
                                 state.get("msg", p.message), p)
    except StopIteration:
        state["written"] = True
    finally:
        gen.close()


def compare_compensation(ps: ProofSettings, cancel: threading.Event | None = None,
                         iterations: int | None = None, training_views: int | None = None,
                         train_resolution: int | None = None, train_spp: int | None = None,
                         field_cells: int | None = None,
                         ) -> Generator[CompensationProgress, None, dict[str, Any]]:
    """Optimise a correction for the proof's job on the training cameras with halftone and
    render seed ``ps.seed + 1`` (:mod:`.compensate`), then render the proof of the open-loop
    job (the paper's method) and of the compensated one on the proof's own cameras at
    ``ps.seed``: figures on cameras and a seed the optimisation did not use.

    Returns ``{"open_loop": render_proof result, "compensated": ..., "optimiser": report}``.
    No file stays behind (the correction lives in a temporary file while the proof reads it).
    The optimiser's options left None are :class:`.compensate.CompensateSettings`' defaults.
    """
    ps = replace(ps, method="paper", compensation=None, output=None)
    given = {"views": training_views, "iterations": iterations, "resolution": train_resolution,
             "spp": train_spp, "field_cells": field_cells}
    cs = CompensateSettings.from_spec(
        replace(ps.spec, seed=ps.seed + 1), max_cells=ps.max_cells,
        **{k: v for k, v in given.items() if v is not None})
    iterations = cs.iterations
    train = (cs.iterations + 1) * cs.views * cs.resolution ** 2 * cs.spp
    proof = ps.views * ps.resolution ** 2 * ps.spp   # its noise floor is free (two halves)
    clock = PhaseClock({"compensating": float(train), "proof (open loop)": float(proof),
                        "proof (compensated)": float(proof)})
    state: dict = {"total": int(iterations) + 1}
    res = yield from relay(optimise(cs, cancel), lambda p: clock.progress(
        "compensating", _optimise_within(p, state), state.get("msg", p.message), p))
    out: dict[str, Any] = {"optimiser": res["report"]}
    fd, tmp = tempfile.mkstemp(prefix="dreamprint-correction-", suffix=".npz")
    os.close(fd)
    try:
        save_correction(res["correction"], tmp)
        for phase, key, comp in (("proof (open loop)", "open_loop", None),
                                 ("proof (compensated)", "compensated", tmp)):
            if cancel is not None and cancel.is_set():
                raise JobCancelled("the compensation was cancelled")
            out[key] = yield from relay(
                render_proof(replace(ps, compensation=comp), cancel),
                lambda p, phase=phase: clock.progress(phase, _proof_within(p),
                                                      p.message or p.stage, p))
    finally:
        Path(tmp).unlink(missing_ok=True)
    if cancel is not None and cancel.is_set():
        raise JobCancelled("the compensation was cancelled")
    return out
