"""The common data model of imported spectra, and the meaning given to raw numbers.

Defines:

- :data:`QUANTITIES` - what a spectrum measures: ``reflectance``, ``transmittance`` (fractions
  0-1 after import), ``absorbance`` (decadic, A = -log10 T), ``log_epsilon`` (log10 of the molar
  absorptivity, as JCAMP-DX UV/VIS libraries store it) and ``spd`` (spectral power, any scale).
- :class:`Sample` - one named spectrum on ascending wavelengths in nm.
- :class:`SpectraFile` - what :func:`~dreamprint_gui.io.spectra.read_spectra` returns: format,
  quantity, the conversion applied (as text), samples and the problems found in them.
- :class:`RawSample`, :class:`RawSpectra` and :func:`finish` - what each format reader hands
  over (numbers as written, with what the file *states* about them), and the single place where
  units are detected and converted: percent vs fraction, absorbance to transmittance
  (T = 10^-A, Beer-Lambert in decadic form), micrometres / angstroms / wavenumbers to
  nanometres, descending or duplicated wavelengths; then the impossible-value checks
  (negative, above 100 %, non-finite), each reported with sample name and wavelength.

Resampling onto a profile grid goes through :func:`dreamprint_gui.core.spectral_grid.resample`
(colour-science interpolators, CIE 167:2005), which refuses uncovered ranges unless a stated
extrapolation is allowed.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.spectral_grid import is_uniform, resample

__all__ = ["QUANTITIES", "FRACTION_QUANTITIES", "Sample", "SpectraFile", "RawSample",
           "RawSpectra", "finish", "check_sample", "ValueScale"]

QUANTITIES: tuple[str, ...] = ("reflectance", "transmittance", "absorbance", "log_epsilon", "spd")
FRACTION_QUANTITIES: tuple[str, ...] = ("reflectance", "transmittance")
UNSTATED = "unstated"
ValueScale = Literal["auto", "fraction", "percent"]

# An undeclared reflectance/transmittance whose largest value exceeds this is read as percent.
# Fluorescent or glossy samples reach about 1.1 as fractions; 1.5 % is a very dark patch in
# percent, so a whole file below 1.5 read as percent is the one case this cannot tell apart
# (the caller may state the scale).
PERCENT_THRESHOLD = 1.5
# Tolerance of the impossible-value check: instrument noise makes a black sample read slightly
# negative and a white one slightly above 1; smaller excursions are not reported.
RANGE_TOLERANCE = 1e-3


@dataclass(frozen=True)
class Sample:
    """One spectrum: ``values`` at ascending ``wavelengths_nm`` (both shape (n,))."""

    name: str
    wavelengths_nm: NDArray[np.float64]
    values: NDArray[np.float64]
    # Set only in a file whose samples hold different quantities (a Cary export mixing %T and
    # Abs): what this sample's values are. Empty: the file's quantity.
    quantity: str = ""

    @property
    def range_nm(self) -> tuple[float, float]:
        return float(self.wavelengths_nm[0]), float(self.wavelengths_nm[-1])

    @property
    def step_nm(self) -> float:
        """The wavelength step (the median step when the spacing is uneven)."""
        if self.wavelengths_nm.size < 2:
            return 0.0
        return float(np.median(np.diff(self.wavelengths_nm)))

    @property
    def uniform(self) -> bool:

        return is_uniform(self.wavelengths_nm, rtol=1e-3)

    def resample(self, target_nm: ArrayLike, *, extrapolate_nm: float = 0.0,
                 source: str | None = None) -> NDArray[np.float64]:
        """The values on ``target_nm`` (colour-science interpolation, see spectral_grid).

        Raises :class:`DreamPrintError` naming the covered range when ``target_nm`` reaches
        more than ``extrapolate_nm`` beyond the data.
        """

        try:
            return resample(self.wavelengths_nm, self.values, target_nm,
                            extrapolate_nm=extrapolate_nm, source=source)
        except DreamPrintError as exc:
            raise DreamPrintError(f"sample '{self.name}': {exc.problem}", exc.path) from None


@dataclass(frozen=True)
class SpectraFile:
    """The spectra of one file, with their meaning.

    ``quantity`` is one of :data:`QUANTITIES`, ``"unstated"`` (the file does not say and the
    caller did not either) or ``"mixed"`` (the samples hold different quantities; each
    sample's :attr:`Sample.quantity` says which). A sample whose quantity differs from the
    file's (one that could not be converted to what the caller asked for) is refused by
    :meth:`sample`, naming what it holds. ``conversion`` says, in words, what was done to the
    numbers (``"none"`` when nothing). ``problems`` lists physically impossible values, one
    line each.
    """

    path: str
    format: str
    quantity: str
    conversion: str
    samples: tuple[Sample, ...]
    problems: tuple[str, ...] = ()
    metadata: dict[str, Any] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.samples)

    @property
    def names(self) -> list[str]:
        return [s.name for s in self.samples]

    def sample(self, key: str | int) -> Sample:
        """A sample by name or by 0-based index; a clear error when absent or ambiguous."""
        if isinstance(key, int) and not isinstance(key, bool):
            if -len(self.samples) <= key < len(self.samples):
                return self._usable(self.samples[key])
            raise DreamPrintError(
                f"no sample at index {key}: the file holds {len(self.samples)} sample(s)",
                self.path)
        hits = [s for s in self.samples if s.name == key]
        if not hits:
            hits = [s for s in self.samples if s.name.strip().casefold() == str(key).casefold()]
        if len(hits) == 1:
            return self._usable(hits[0])
        if hits:
            raise DreamPrintError(
                f"{len(hits)} samples are named '{key}': choose one by its position", self.path)
        shown = ", ".join(f"'{n}'" for n in self.names[:8])
        more = f" and {len(self.samples) - 8} more" if len(self.samples) > 8 else ""
        raise DreamPrintError(f"no sample named '{key}' (the file holds {shown}{more})",
                              self.path)

    @property
    def usable(self) -> list[bool]:
        """Per sample, whether it holds the file's quantity (False only for a sample of a
        mixed file that could not be converted to what the caller asked for)."""
        return [not (s.quantity and self.quantity != "mixed" and s.quantity != self.quantity)
                for s in self.samples]

    def _usable(self, s: Sample) -> Sample:
        if s.quantity and self.quantity != "mixed" and s.quantity != self.quantity:
            raise DreamPrintError(f"sample '{s.name}' holds {s.quantity}, not {self.quantity} "
                                  "(the file's samples hold different quantities)", self.path)
        return s

    def resample(self, key: str | int, target_nm: ArrayLike, *,
                 extrapolate_nm: float = 0.0) -> NDArray[np.float64]:
        """Sample ``key`` resampled onto ``target_nm``; see :meth:`Sample.resample`."""
        return self.sample(key).resample(target_nm, extrapolate_nm=extrapolate_nm,
                                         source=self.path)

    def summary(self) -> dict[str, Any]:
        """The ``dreamprint spectra --json`` object."""
        samples = []
        for s in self.samples:
            finite = s.values[np.isfinite(s.values)]
            samples.append({
                "name": s.name,
                "quantity": s.quantity or self.quantity,
                "wavelengths_nm": [s.range_nm[0], s.range_nm[1]],
                "step_nm": s.step_nm,
                "uniform": s.uniform,
                "points": int(s.values.size),
                "min": float(finite.min()) if finite.size else None,
                "max": float(finite.max()) if finite.size else None,
            })
        basis = self.metadata.get("quantity_basis")
        return {"file": self.path, "format": self.format, "quantity": self.quantity,
                **({"quantity_basis": basis} if basis else {}),
                "conversion": self.conversion, "samples": samples,
                "problems": list(self.problems)}


@dataclass
class RawSample:
    """A spectrum as the file writes it (file's wavelength unit and order, file's scale)."""

    name: str
    wavelengths: NDArray[np.float64]
    values: NDArray[np.float64]
    line: int | None = None
    # A file whose samples state different quantities (Cary: one Y mode per sample) sets these
    # per sample; ``None``: the file's (RawSpectra.quantity / .scale).
    quantity: str | None = None
    scale: float | None = None


@dataclass
class RawSpectra:
    """What a format reader found, and what the file states about it.

    ``quantity`` is ``None`` when the file does not say; ``implied`` marks a quantity the file
    only implies (e.g. by reflectance measurement conditions), which a caller may overrule;
    ``scale`` is the stated full scale of
    reflectance/transmittance values (100 for percent, 1 for fractions) or ``None``;
    ``wavelength_unit`` is ``"nm"``, ``"um"``, ``"angstrom"``, ``"cm-1"`` or ``None``.
    """

    format: str
    samples: list[RawSample]
    quantity: str | None = None
    implied: bool = False
    scale: float | None = None
    wavelength_unit: str | None = None
    notes: list[str] = field(default_factory=list)
    metadata: dict[str, Any] = field(default_factory=dict)


def _fmt(x: float) -> str:
    return f"{x:.6g}"


def _to_nm(raw: RawSpectra, path: str, notes: list[str]) -> None:
    unit = raw.wavelength_unit
    if unit is None:
        finite = [s.wavelengths[np.isfinite(s.wavelengths)] for s in raw.samples]
        top = max((float(w.max()) for w in finite if w.size), default=0.0)
        # No spectrophotometer measures beyond 20 um, nor below 20 nm: a file whose largest
        # wavelength is under 20 can only be in micrometres.
        unit = "um" if 0 < top < 20 else "nm"
        if unit == "um":
            notes.append("wavelengths read as micrometres (largest value "
                         f"{_fmt(top)}) and multiplied by 1000")
    elif unit == "um":
        notes.append("wavelengths converted from micrometres to nm")
    elif unit == "angstrom":
        notes.append("wavelengths converted from angstroms to nm")
    elif unit == "cm-1":
        notes.append("wavenumbers converted to wavelengths (nm = 1e7 / cm-1)")
    for s in raw.samples:
        w = s.wavelengths
        bad = ~np.isfinite(w) | (w <= 0)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise DreamPrintError(
                f"sample '{s.name}': wavelength {w[i]!r} (point {i + 1}) is not a positive "
                "number", path, s.line)
        if unit == "um":
            s.wavelengths = w * 1000.0
        elif unit == "angstrom":
            s.wavelengths = w * 0.1
        elif unit == "cm-1":
            s.wavelengths = 1e7 / w


def _ascending(s: RawSample, path: str, notes: list[str]) -> Sample:
    w = np.asarray(s.wavelengths, dtype=np.float64)
    v = np.asarray(s.values, dtype=np.float64)
    if w.shape != v.shape or w.ndim != 1:
        raise DreamPrintError(
            f"sample '{s.name}': {w.size} wavelengths but {v.size} values", path, s.line)
    if w.size < 2:
        raise DreamPrintError(f"sample '{s.name}' has {w.size} point(s); a spectrum needs at "
                              "least 2", path, s.line)
    d = np.diff(w)
    if np.all(d > 0):
        return Sample(s.name, w, v)
    if np.all(d < 0):
        note = "descending wavelengths reversed"
    else:
        note = "wavelengths sorted ascending"
    order = np.argsort(w, kind="stable")
    w, v = w[order], v[order]
    uniq, start, counts = np.unique(w, return_index=True, return_counts=True)
    if uniq.size != w.size:
        merged = np.add.reduceat(np.nan_to_num(v, nan=0.0), start) / counts
        nan_any = np.logical_or.reduceat(~np.isfinite(v), start)
        merged[nan_any] = np.nan
        differ = np.maximum.reduceat(v, start) != np.minimum.reduceat(v, start)
        note += f"; {w.size - uniq.size} repeated wavelength(s) merged"
        if differ.any():
            note += " (differing values averaged)"
        w, v = uniq, merged
        if w.size < 2:
            raise DreamPrintError(f"sample '{s.name}' has one distinct wavelength", path,
                                  s.line)
    if note not in notes:
        notes.append(note)
    return Sample(s.name, w, v)


def check_sample(s: Sample, quantity: str) -> list[str]:
    """Physically impossible values of one sample, one line per kind (empty when none)."""
    v, w = s.values, s.wavelengths_nm
    checks = [(~np.isfinite(v), "non-finite value")]
    with np.errstate(invalid="ignore"):
        if quantity in FRACTION_QUANTITIES:
            checks += [(v < -RANGE_TOLERANCE, f"negative {quantity}"),
                       (v > 1 + RANGE_TOLERANCE, f"{quantity} above 100 %")]
        elif quantity == "spd":
            peak = float(np.max(np.abs(v[np.isfinite(v)]), initial=1.0))
            checks.append((v < -RANGE_TOLERANCE * peak, "negative spectral power"))
    problems = []
    for mask, what in checks:
        idx = np.flatnonzero(mask)
        if idx.size:
            i = int(idx[0])
            more = f" (and {idx.size - 1} more wavelength(s))" if idx.size > 1 else ""
            problems.append(f"sample '{s.name}': {what} {_fmt(v[i])} at {_fmt(w[i])} nm{more}")
    return problems


def _check(samples: Sequence[Sample], quantity: str) -> list[str]:
    return [p for s in samples for p in check_sample(s, quantity)]


def finish(raw: RawSpectra, path: str, *, quantity: str | None = None,
           file_quantity: str | None = None, value_scale: ValueScale = "auto") -> SpectraFile:
    """Give raw numbers their meaning; see the module docstring.

    A file whose samples state different quantities (:attr:`RawSample.quantity`) is finished
    one group of samples at a time (same quantity and scale): each group is converted to
    ``quantity`` when it can be (absorbance <-> transmittance), else keeps its own quantity,
    which :meth:`SpectraFile.sample` then names when such a sample is asked for.
    """
    own = {(s.quantity if s.quantity is not None else raw.quantity,
            s.scale if s.quantity is not None else raw.scale) for s in raw.samples}
    if len(own) <= 1:
        if raw.samples and raw.samples[0].quantity is not None:
            q, sc = own.pop()
            raw = replace(raw, quantity=q, scale=sc)
        return _finish_one(raw, path, quantity=quantity, file_quantity=file_quantity,
                           value_scale=value_scale)
    return _finish_mixed(raw, path, quantity=quantity, file_quantity=file_quantity,
                         value_scale=value_scale)


def _finish_mixed(raw: RawSpectra, path: str, *, quantity: str | None,
                  file_quantity: str | None, value_scale: ValueScale) -> SpectraFile:
    groups: dict[tuple, list[int]] = {}
    for i, s in enumerate(raw.samples):
        key = (s.quantity if s.quantity is not None else raw.quantity,
               s.scale if s.quantity is not None else raw.scale)
        groups.setdefault(key, []).append(i)
    finished: dict[int, Sample] = {}
    notes: list[str] = []
    problems: list[str] = []
    held_by_group = []
    for (q, sc), idx in groups.items():
        sub = replace(raw, samples=[raw.samples[i] for i in idx], quantity=q, scale=sc,
                      implied=False, notes=[])
        try:
            part = _finish_one(sub, path, quantity=quantity, file_quantity=file_quantity,
                               value_scale=value_scale)
            converted = True
        except DreamPrintError:
            if quantity is None:
                raise
            sub = replace(sub, samples=[RawSample(s.name, s.wavelengths, s.values, s.line)
                                        for s in sub.samples])
            part = _finish_one(sub, path, file_quantity=file_quantity, value_scale=value_scale)
            converted = False
        what = q or UNSTATED
        held_by_group.append(what)
        label = f"{len(idx)} {what} sample(s)"
        if part.conversion != "none":
            notes.append(f"{label}: {part.conversion}")
        if not converted:
            notes.append(f"{label} cannot be read as {quantity} and are refused when asked for")
        problems += part.problems
        for i, smp in zip(idx, part.samples, strict=True):
            finished[i] = replace(smp, quantity=part.quantity)
    held = {smp.quantity for smp in finished.values()}
    out_q = quantity if quantity is not None else (held.pop() if len(held) == 1 else "mixed")
    notes.insert(0, "the samples hold different quantities (" + ", ".join(held_by_group) + ")")
    return SpectraFile(
        path=path, format=raw.format, quantity=out_q,
        conversion="; ".join(raw.notes + notes),
        samples=tuple(finished[i] for i in range(len(raw.samples))),
        problems=tuple(problems), metadata=dict(raw.metadata))


def _finish_one(raw: RawSpectra, path: str, *, quantity: str | None = None,
                file_quantity: str | None = None,
                value_scale: ValueScale = "auto") -> SpectraFile:
    """:func:`finish` of samples that hold one quantity.

    ``quantity`` is what the caller wants (``None``: what the file holds); ``file_quantity``
    what the caller says the file holds when the file does not say; ``value_scale`` overrides
    the percent/fraction detection of reflectance and transmittance.
    """
    for q in (quantity, file_quantity):
        if q is not None and q not in QUANTITIES:
            raise DreamPrintError(f"unknown quantity '{q}' (one of {', '.join(QUANTITIES)})")
    if value_scale not in ("auto", "fraction", "percent"):
        raise DreamPrintError(f"unknown value scale '{value_scale}' (auto, fraction, percent)")
    if not raw.samples:
        raise DreamPrintError(f"no spectra found in this {raw.format} file", path)
    notes: list[str] = []

    held = raw.quantity
    if held is not None and raw.implied:
        wanted = file_quantity or quantity
        if wanted in FRACTION_QUANTITIES and wanted != held:
            notes.append(f"the file implies {held}; read as {wanted} as the caller states")
            held = wanted
    if held is not None and file_quantity is not None and file_quantity != held:
        raise DreamPrintError(f"the file states {held}, not {file_quantity}", path)
    if held is None:
        held = file_quantity
        if held is None and quantity in ("reflectance", "transmittance", "absorbance", "spd"):
            held = quantity
        if held is not None:
            notes.append(f"the file does not state its quantity: read as {held}")

    _to_nm(raw, path, notes)
    samples = [_ascending(s, path, notes) for s in raw.samples]

    if held in FRACTION_QUANTITIES:
        finite_max = max((float(np.max(s.values[np.isfinite(s.values)], initial=-np.inf))
                          for s in samples), default=-np.inf)
        if value_scale == "percent":
            scale, why = 100.0, "as the caller states"
        elif value_scale == "fraction":
            scale, why = 1.0, ""
        elif raw.scale is not None:
            scale, why = raw.scale, "as the file states"
        elif finite_max > PERCENT_THRESHOLD:
            scale, why = 100.0, (f"the file does not say; largest value {_fmt(finite_max)} "
                                 f"> {PERCENT_THRESHOLD}")
        else:
            scale, why = 1.0, ""
        if scale != 1.0:
            pct = "percent" if scale == 100 else f"a 0-{_fmt(scale)} scale"
            notes.append(f"{pct} to fraction (divided by {_fmt(scale)}, {why})")
            samples = [Sample(s.name, s.wavelengths_nm, s.values / scale) for s in samples]
    elif held is None and raw.scale not in (None, 1.0):
        # A stated percent scale (e.g. SPECTRAL_PCT) means reflectance or transmittance.
        notes.append(f"percent to fraction (divided by {_fmt(raw.scale)}, as the file states)")
        samples = [Sample(s.name, s.wavelengths_nm, s.values / raw.scale) for s in samples]

    out_q = held if held is not None else UNSTATED
    if quantity is not None and quantity != held:
        if held is None:
            raise DreamPrintError(f"the file does not state what it measures; say whether it "
                                  f"holds {quantity} or another quantity", path)
        if held == "absorbance" and quantity == "transmittance":
            notes.append("absorbance to transmittance (T = 10^-A)")
            samples = [Sample(s.name, s.wavelengths_nm, np.power(10.0, -s.values))
                       for s in samples]
        elif held == "transmittance" and quantity == "absorbance":
            notes.append("transmittance to absorbance (A = -log10 T)")
            with np.errstate(divide="ignore", invalid="ignore"):
                samples = [Sample(s.name, s.wavelengths_nm, -np.log10(s.values))
                           for s in samples]
        elif held == "spd":
            raise DreamPrintError(
                f"this file holds a spectral power distribution (a light source), not a "
                f"{quantity} measurement", path)
        elif held == "log_epsilon":
            raise DreamPrintError(
                f"this file holds log10 of the molar absorptivity; a {quantity} needs the "
                "concentration and path length (A = epsilon c l)", path)
        else:
            raise DreamPrintError(f"this file holds {held}, not {quantity}", path)
        out_q = quantity

    return SpectraFile(
        path=path, format=raw.format, quantity=out_q,
        conversion="; ".join(raw.notes + notes) or "none",
        samples=tuple(samples), problems=tuple(_check(samples, out_q)),
        metadata=dict(raw.metadata))


def parse_float(text: str) -> float:
    """A number as instruments write it: also ``1,5`` (decimal comma) and ``NaN``/``-INF``."""
    t = text.strip()
    try:
        return float(t)
    except ValueError:
        if t.count(",") == 1 and "." not in t:
            return float(t.replace(",", "."))
        raise


def is_number(text: str) -> bool:
    try:
        parse_float(text)
    except ValueError:
        return False
    return True
