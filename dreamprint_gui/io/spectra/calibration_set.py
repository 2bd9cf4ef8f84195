"""The calibration set: a small TOML file naming, per ink layer, its measured R and T.

Defines :func:`load_calibration_set` (TOML -> list of
:class:`~dreamprint_gui.core.calibration_types.LayerMeasurement` on the profile's grid) and
:data:`SET_FORMAT`. The layout is documented, with an example, in ``docs/calibration-set.md``;
an example set built from generated files is in ``tests/data/calibration_set/``.

Each ``[[layer]]`` names an ink (``C M Y K W Cl``), the layer thickness in mm (``inf`` for an
optically thick patch, which has a reflectance only) and a reflectance ``R`` and/or a
transmittance ``T`` measurement: ``{ file = "...", sample = "..." }``, the file resolved against
the TOML's folder, read with :func:`~dreamprint_gui.io.spectra.read_spectra` in any supported
format (absorbance files are converted, T = 10^-A; in a file whose samples hold different
quantities, such as a Cary export mixing %T and Abs, each named sample is read as its own
quantity says, and a sample that holds something else is refused by name). Several layers per
ink (several thicknesses, or repeats) are allowed. Options per measurement, or for all of them under
``[defaults]``: ``extrapolate_nm`` (how far the profile grid may reach beyond the data, the end
values held), ``scale`` (``auto``/``fraction``/``percent``) and ``file_quantity`` (what a file
that does not say holds: ``reflectance``, ``transmittance`` or ``absorbance``).

A measurement with impossible values (non-finite, negative, above 100 %) is refused, naming the
sample and the wavelength: calibration must not fit noise it cannot represent.
"""

from __future__ import annotations

import math
import os
import re
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from dreamprint_gui.core.calibration_types import LayerMeasurement
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.profile import INKS
from dreamprint_gui.io.spectra.detect import read_spectra
from dreamprint_gui.io.spectra.model import Sample, SpectraFile, check_sample

__all__ = ["load_calibration_set", "SET_FORMAT", "measured_values"]

SET_FORMAT = "dreamprint-calibration-set"
_TOP_KEYS = {"format", "version", "name", "description", "defaults", "layer"}
_LAYER_KEYS = {"ink", "thickness_mm", "R", "T", "note"}
_OPTION_KEYS = {"extrapolate_nm", "scale", "file_quantity"}
_MEAS_KEYS = {"file", "sample"} | _OPTION_KEYS
_QUANTITY = {"R": "reflectance", "T": "transmittance"}


def _toml(path: str) -> dict[str, Any]:
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except FileNotFoundError:
        raise DreamPrintError("no such file", path) from None
    except tomllib.TOMLDecodeError as exc:
        msg = str(exc)
        m = re.search(r"\(at line (\d+), column \d+\)", msg)
        line = int(m.group(1)) if m else None
        raise DreamPrintError(f"not valid TOML: {re.sub(r' ?[(]at line.*$', '', msg)}", path,
                              line) from None
    except UnicodeDecodeError:
        raise DreamPrintError("not valid TOML: not UTF-8 text", path) from None


def _unknown(keys: Any, allowed: set[str], where: str, path: str) -> None:
    extra = sorted(set(keys) - allowed)
    if extra:
        raise DreamPrintError(f"{where}: unknown key(s) {', '.join(extra)} (allowed: "
                              f"{', '.join(sorted(allowed))})", path)


def _options(d: dict[str, Any], base: dict[str, Any], where: str, path: str) -> dict[str, Any]:
    opts = dict(base)
    for k in _OPTION_KEYS & set(d):
        opts[k] = d[k]
    ext = opts.get("extrapolate_nm", 0.0)
    if isinstance(ext, bool) or not isinstance(ext, int | float) or not (
            math.isfinite(ext) and ext >= 0):
        raise DreamPrintError(f"{where}: extrapolate_nm must be a number >= 0", path)
    if opts.get("scale", "auto") not in ("auto", "fraction", "percent"):
        raise DreamPrintError(f"{where}: scale must be auto, fraction or percent", path)
    fq = opts.get("file_quantity")
    if fq is not None and fq not in ("reflectance", "transmittance", "absorbance"):
        raise DreamPrintError(f"{where}: file_quantity must be reflectance, transmittance or "
                              "absorbance", path)
    return opts


def load_calibration_set(path: str | os.PathLike,
                         wavelengths_nm: ArrayLike) -> list[LayerMeasurement]:
    """Read a calibration set and return its layers with R/T resampled to ``wavelengths_nm``.

    Raises :class:`DreamPrintError` with one line naming the file (the TOML, or the measurement
    file with its line) and the problem, including which layer it concerns.
    """
    p = os.fspath(path)
    grid = np.asarray(wavelengths_nm, dtype=np.float64)
    if grid.ndim != 1 or grid.size < 2 or not np.all(np.diff(grid) > 0):
        raise DreamPrintError("the profile grid must be ascending wavelengths in nm")
    doc = _toml(p)
    _unknown(doc, _TOP_KEYS, "top level", p)
    if "format" in doc and doc["format"] != SET_FORMAT:
        raise DreamPrintError(f"format is '{doc['format']}', expected '{SET_FORMAT}'", p)
    if doc.get("version", 1) != 1:
        raise DreamPrintError(f"version {doc['version']!r} is not supported (1 is)", p)
    defaults = doc.get("defaults", {})
    if not isinstance(defaults, dict):
        raise DreamPrintError("[defaults] must be a table", p)
    _unknown(defaults, _OPTION_KEYS, "[defaults]", p)
    defaults = _options(defaults, {}, "[defaults]", p)
    layers = doc.get("layer")
    if not isinstance(layers, list) or not layers:
        raise DreamPrintError("no [[layer]] entries: name at least one ink layer and its "
                              "measurements", p)
    folder = Path(p).resolve().parent
    cache: dict[tuple, SpectraFile] = {}
    out: list[LayerMeasurement] = []
    for i, layer in enumerate(layers, 1):
        where = f"layer {i}"
        if not isinstance(layer, dict):
            raise DreamPrintError(f"{where}: must be a table", p)
        _unknown(layer, _LAYER_KEYS, where, p)
        ink = layer.get("ink")
        if ink not in INKS:
            raise DreamPrintError(f"{where}: ink {ink!r} is not one of {' '.join(INKS)}", p)
        t = layer.get("thickness_mm")
        if isinstance(t, bool) or not isinstance(t, int | float) or math.isnan(t) or t <= 0:
            raise DreamPrintError(f"{where} (ink {ink}): thickness_mm must be a number > 0 "
                                  "(inf for an optically thick patch)", p)
        where = f"layer {i} (ink {ink}, {t:g} mm)"
        if "R" not in layer and "T" not in layer:
            raise DreamPrintError(f"{where}: give R, T or both", p)
        if math.isinf(t) and "T" in layer:
            raise DreamPrintError(f"{where}: an optically thick layer transmits nothing; give "
                                  "only R", p)
        spectra: dict[str, np.ndarray] = {}
        sources = []
        for key in ("R", "T"):
            if key not in layer:
                continue
            m = layer[key]
            w = f"{where} {key}"
            if isinstance(m, str):
                m = {"file": m}
            if not isinstance(m, dict) or not isinstance(m.get("file"), str):
                raise DreamPrintError(f"{w}: give {{ file = \"...\", sample = \"...\" }}", p)
            _unknown(m, _MEAS_KEYS, w, p)
            opts = _options(m, defaults, w, p)
            file = Path(m["file"]).expanduser()
            file = file if file.is_absolute() else folder / file
            ck = (str(file), _QUANTITY[key], opts.get("file_quantity"), opts.get("scale"))
            try:
                if ck not in cache:
                    cache[ck] = read_spectra(file, quantity=_QUANTITY[key],
                                             file_quantity=opts.get("file_quantity"),
                                             value_scale=opts.get("scale", "auto"))
                sf = cache[ck]
                sample = _pick(sf, m.get("sample"), w, p)
                values = measured_values(sf, sample, grid, extrapolate_nm=float(opts.get(
                    "extrapolate_nm", 0.0)))
            except DreamPrintError as exc:
                if exc.path == p:
                    raise
                raise DreamPrintError(f"{exc.problem} ({w} in {Path(p).name})", exc.path,
                                      exc.line) from None
            spectra[key] = values
            sources.append(f"{key}: {m['file']} [{sample.name}]")
        out.append(LayerMeasurement(ink=ink, thickness_mm=float(t), R=spectra.get("R"),
                                    T=spectra.get("T"), source="; ".join(sources)))
    return out


def measured_values(sf: SpectraFile, sample: Sample, grid: ArrayLike, *,
                    extrapolate_nm: float = 0.0) -> np.ndarray:
    """The R or T of ``sample`` (one of ``sf``'s) on ``grid``, for calibration.

    Only this sample's own values are checked (another sample's problem in the same file is
    not its problem): impossible values are refused naming it and the wavelength. The
    resampled curve is clipped to [0, 1]: its values passed the range check, so an excursion
    is the interpolator's overshoot between points (a filter's edge, a noisy blocked band).
    """
    bad = check_sample(sample, sample.quantity or sf.quantity)
    if bad:
        raise DreamPrintError(f"{bad[0]}: fix or remeasure it", sf.path)
    values = sample.resample(grid, extrapolate_nm=extrapolate_nm, source=sf.path)
    return np.clip(values, 0.0, 1.0)


def _pick(sf: SpectraFile, sample: Any, where: str, path: str):
    if sample is None:
        if len(sf.samples) != 1:
            raise DreamPrintError(f"{where}: the file holds {len(sf.samples)} samples; say which "
                                  "with sample = \"name\" (or its position, 1 = first)", path)
        return sf.sample(0)
    if isinstance(sample, bool) or not isinstance(sample, str | int):
        raise DreamPrintError(f"{where}: sample must be a name or a position (1 = first)", path)
    if isinstance(sample, int):
        if not 1 <= sample <= len(sf.samples):
            raise DreamPrintError(f"{where}: sample position {sample} is outside 1-"
                                  f"{len(sf.samples)}", path)
        return sf.sample(sample - 1)
    return sf.sample(sample)
