"""The print a job, a proof and a compensation are about, stated once: :class:`PrintSpec`.

Defines
-------
- :class:`PrintSpec`: the frozen description of a print's shared choices: the source and its
  reader options, the size (``--height-mm`` or ``--size-mm``) and placement (``--up``,
  ``--rotate``, ``--fit``), printer and ink profile, the rendering (content, sampling, colour
  table objective and intent, table size), the density scale, halftoning and seed, the
  background and the correction file applied.
- :class:`HasSpec`: the mixin of every settings class that carries those fields
  (``ConvertSettings``, ``ProofSettings``, ``CompensateSettings``): ``settings.spec`` reads
  them out, ``Settings.from_spec(spec, **own)`` builds settings from a spec and the class's
  own options. A field added to :class:`PrintSpec` travels through every surface (convert,
  proof, compensate, the Preview, the Print proof tab, the export) without another copy.

The size is checked by :func:`..core.print_size.check_print_size`, the one rule for it.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass, fields
from typing import Any, TypeVar

from dreamprint_gui.core.print_size import check_print_size
from dreamprint_gui.core.printer import printer_choice

__all__ = ["PrintSpec", "HasSpec", "spec_field_names"]

T = TypeVar("T")


def _path(v: Any) -> str | None:
    return None if v is None else os.fspath(v)


@dataclass(frozen=True)
class PrintSpec:
    """A print's shared choices (module docstring); the defaults are the CLI's."""

    source: str
    height_mm: float | None = None
    size_mm: tuple[float, float, float] | None = None
    up: str | None = None                 # source axis that becomes +z; None: auto
    rotate: int = 0                       # degrees about the print's z (quarter turns)
    fit: str = "occupied"                 # "occupied" | "box"
    printer: str | None = None            # name or .toml; None: the default printer
    profile: str | None = None            # ink profile JSON; None: built-in
    content: str = "auto"                 # "fog" | "solid" | "auto"
    sampling: str | None = None           # None: the reader's; "nearest" | "linear"
    objective: str | None = None          # colour table objective; None: profile's/default
    intent: str | None = None             # rendering intent; None: profile's/colorimetric
    table_size: int = 100
    density_scale: float = 1.0
    halftone: str = "blue-noise"
    seed: int = 0
    background: str = "clear"             # "clear" | "empty"
    compensation: str | None = None       # a correction file (job.correction)
    source_options: tuple[tuple[str, Any], ...] = ()

    @classmethod
    def of(cls, settings: Any) -> PrintSpec:
        """The spec of any object with the spec's fields (paths as text, the box as a tuple,
        the reader options as sorted pairs)."""
        kw = {f.name: getattr(settings, f.name) for f in fields(cls)}
        kw["source"] = str(kw["source"])
        kw["printer"] = printer_choice(kw["printer"])
        kw["profile"] = _path(kw["profile"])
        kw["compensation"] = _path(kw["compensation"])
        if kw["size_mm"] is not None:
            kw["size_mm"] = tuple(float(v) for v in kw["size_mm"])
        kw["source_options"] = tuple(sorted(dict(kw["source_options"]).items()))
        return cls(**kw)

    def check_size(self) -> None:
        check_print_size(self.height_mm, self.size_mm)


def spec_field_names() -> tuple[str, ...]:
    return tuple(f.name for f in fields(PrintSpec))


class HasSpec:
    """Mixin of a frozen settings dataclass holding every :class:`PrintSpec` field."""

    @property
    def spec(self) -> PrintSpec:
        return PrintSpec.of(self)

    @classmethod
    def from_spec(cls: type[T], spec: PrintSpec, **own: Any) -> T:
        """Settings of this class for ``spec`` and the class's own options ``own``."""
        kw = {f.name: getattr(spec, f.name) for f in fields(PrintSpec)}
        types = {f.name: f for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
        if isinstance(_default(types["source_options"]), dict):
            kw["source_options"] = dict(spec.source_options)
        return cls(**kw, **own)


def _default(f: dataclasses.Field) -> Any:
    if f.default_factory is not dataclasses.MISSING:  # type: ignore[misc]
        return f.default_factory()  # type: ignore[misc]
    return f.default
