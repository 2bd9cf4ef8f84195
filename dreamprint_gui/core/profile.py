"""Ink profiles: per-ink K(lambda), S(lambda) in 1/mm on the profile's wavelength grid.

A profile is what calibration produces and everything else consumes. It is saved as JSON
(``format: dreamprint-ink-profile``, ``format_version: 1``), with the model settings that give
its numbers their meaning:

- ``colour_thickness_mm``: the reference thickness at which a mixture's colour (paper eq. 7,
  on R + T) is evaluated. ``null`` (the default) means optically thick, i.e. R_inf: the colour
  of a radiance voxel is what a thick region of that medium looks like, while at one voxel's
  thickness (0.014 mm) R + T is nearly white for every ink. Used by tables, preview and reports.
- ``layer_thickness_mm``: dt of the scalar density (eq. 9), the printer's layer.
- ``density_t_max_mm``, ``density_samples``: the thickness range and samples of the exponential
  fit (eq. 8).

Optional ``table`` settings choose how the RGB -> ink table is solved for this profile:
``{"objective": "srgb" | "cielab" | "de2000", "intent": "colorimetric" | "perceptual"}``
(either key may be absent: the engine's default applies; a command-line ``--objective`` or
``--intent`` overrides them). They are not part of the fingerprint: tables are cached per
profile fingerprint, objective and intent.

``provenance.ink_origin`` says per ink whether its K and S were ``measured`` (fitted to this
printer's measurements by ``dreamprint calibrate``) or ``modelled`` (assumed: the built-in
Clear, the built-in colour inks' absolute scale); :func:`ink_origins` reads it (profiles
without it: the inks their ``measurements`` name are measured, the others modelled).

Loading validates everything (inks, lengths, finiteness, signs) and raises
:class:`~dreamprint_gui.core.errors.DreamPrintError` naming the file and the problem.
"""

from __future__ import annotations

import copy
import datetime as _dt
import json
import math
import os
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.files import write_atomically
from dreamprint_gui.core.resources import resource_path

__all__ = ["INKS", "COLOUR_INKS", "InkProfile", "load_profile", "save_profile",
           "default_profile", "parse_mix", "DEFAULT_PROFILE_NAME", "INK_ORIGINS", "ink_origins",
           "modelled_inks"]

INKS: tuple[str, ...] = ("C", "M", "Y", "K", "W", "Cl")
COLOUR_INKS: tuple[str, ...] = ("C", "M", "Y", "K", "W")
FORMAT = "dreamprint-ink-profile"
FORMAT_VERSION = 1
DEFAULT_PROFILE_NAME = "polyjet-default"
# 1e6 per mm (one per nanometre) is far beyond any ink; larger values are unit mistakes.
_MAX_COEFFICIENT = 1e6
UNITS = {"wavelength": "nm", "K": "1/mm", "S": "1/mm"}
INK_ORIGINS = ("measured", "modelled")


@dataclass(frozen=True)
class InkProfile:
    """K and S (1/mm) of the six inks ``INKS`` on ``wavelengths_nm``, plus model settings."""

    name: str
    wavelengths_nm: NDArray[np.float64]
    K: NDArray[np.float64]  # (6, n_wl), rows in INKS order
    S: NDArray[np.float64]
    colour_thickness_mm: float = math.inf
    layer_thickness_mm: float = 0.014
    density_t_max_mm: float = 5.0
    density_samples: int = 100
    provenance: dict[str, Any] = field(default_factory=dict)
    residuals: dict[str, Any] = field(default_factory=dict)
    table_settings: dict[str, str] = field(default_factory=dict)
    proof_optics: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        validate_arrays(self.wavelengths_nm, self.K, self.S)

    @property
    def inks(self) -> tuple[str, ...]:
        return INKS

    def ink_index(self, ink: str) -> int:
        return INKS.index(ink)

    def with_settings(self, **changes: Any) -> InkProfile:
        return replace(self, **changes)

    def to_json_dict(self) -> dict[str, Any]:
        return {
            "format": FORMAT,
            "format_version": FORMAT_VERSION,
            "name": self.name,
            "inks": list(INKS),
            "units": UNITS,
            "wavelengths_nm": self.wavelengths_nm.tolist(),
            "K_per_mm": {ink: self.K[i].tolist() for i, ink in enumerate(INKS)},
            "S_per_mm": {ink: self.S[i].tolist() for i, ink in enumerate(INKS)},
            "model": {
                "colour_thickness_mm": None if math.isinf(self.colour_thickness_mm)
                else self.colour_thickness_mm,
                "layer_thickness_mm": self.layer_thickness_mm,
                "density_t_max_mm": self.density_t_max_mm,
                "density_samples": self.density_samples,
            },
            # copies: a caller editing the dict must not edit this profile (the built-in one
            # is shared by the whole process)
            "provenance": copy.deepcopy(self.provenance),
            "residuals": copy.deepcopy(self.residuals),
            **({"table": dict(self.table_settings)} if self.table_settings else {}),
            **({"proof": dict(self.proof_optics)} if self.proof_optics else {}),
        }

    def fingerprint(self) -> str:
        """A hash of everything that changes the profile's numbers (for caches)."""
        import hashlib

        d = self.to_json_dict()
        d.pop("provenance")
        d.pop("residuals")
        d.pop("name")
        d.pop("table", None)
        d.pop("proof", None)
        return hashlib.sha256(json.dumps(d, sort_keys=True).encode()).hexdigest()[:16]


def validate_arrays(wavelengths: ArrayLike, K: ArrayLike, S: ArrayLike,
                    source: str | None = None) -> None:
    w = np.asarray(wavelengths)
    if w.ndim != 1 or w.size < 3:
        raise DreamPrintError("wavelengths_nm must be a list of at least 3 values", source)
    if not np.all(np.isfinite(w)) or np.any(np.diff(w) <= 0):
        raise DreamPrintError("wavelengths_nm must be finite and strictly increasing", source)
    for label, a in (("K", K), ("S", S)):
        a = np.asarray(a)
        if a.shape != (len(INKS), w.size):
            raise DreamPrintError(
                f"{label} must have {len(INKS)} inks x {w.size} wavelengths, got "
                f"{'x'.join(map(str, a.shape))}", source)
        bad = ~np.isfinite(a) | (a < 0) | (a > _MAX_COEFFICIENT)
        if bad.any():
            i, j = np.argwhere(bad)[0]
            raise DreamPrintError(
                f"{label} of ink {INKS[i]} at {w[j]:g} nm is {float(a[i, j])!r}: must be finite, "
                f">= 0 and <= {_MAX_COEFFICIENT:g} per mm", source)


def _ink_table(d: Any, key: str, n: int, source: str) -> NDArray[np.float64]:
    if not isinstance(d, dict):
        raise DreamPrintError(f"'{key}' must map ink names to lists", source)
    unknown = sorted(set(d) - set(INKS))
    missing = [ink for ink in INKS if ink not in d]
    if unknown:
        raise DreamPrintError(f"'{key}' names unknown inks {unknown}; expected {list(INKS)}",
                              source)
    if missing:
        raise DreamPrintError(f"'{key}' lacks inks {missing}", source)
    rows = []
    for ink in INKS:
        row = d[ink]
        if not isinstance(row, list) or len(row) != n:
            got = len(row) if isinstance(row, list) else type(row).__name__
            raise DreamPrintError(f"'{key}' of ink {ink} must have {n} values, got {got}",
                                  source)
        try:
            rows.append([float(x) for x in row])
        except (TypeError, ValueError):
            raise DreamPrintError(f"'{key}' of ink {ink} holds a non-number", source) from None
    return np.asarray(rows, dtype=np.float64)


def profile_from_dict(d: Any, source: str = "<profile>") -> InkProfile:
    if not isinstance(d, dict) or d.get("format") != FORMAT:
        raise DreamPrintError(f"not a DreamPrint ink profile (expected format '{FORMAT}')",
                              source)
    if d.get("format_version") != FORMAT_VERSION:
        raise DreamPrintError(f"unsupported format_version {d.get('format_version')!r}; this "
                              f"version reads {FORMAT_VERSION}", source)
    try:
        w = np.asarray([float(x) for x in d["wavelengths_nm"]], dtype=np.float64)
    except (KeyError, TypeError, ValueError):
        raise DreamPrintError("'wavelengths_nm' is missing or not a list of numbers",
                              source) from None
    if "units" in d and d["units"] != UNITS:
        raise DreamPrintError(f"units {d['units']} are not DreamPrint's {UNITS}; convert the "
                              "values (K and S per mm, wavelengths in nm)", source)
    if "inks" in d and list(d["inks"]) != list(INKS):
        raise DreamPrintError(f"inks {d['inks']} do not match the printer's {list(INKS)}", source)
    K = _ink_table(d.get("K_per_mm"), "K_per_mm", w.size, source)
    S = _ink_table(d.get("S_per_mm"), "S_per_mm", w.size, source)
    validate_arrays(w, K, S, source)
    provenance = d.get("provenance", {}) or {}
    if not isinstance(provenance, dict):
        raise DreamPrintError("'provenance' must be an object", source)
    _check_ink_origin(provenance, source)
    model = d.get("model", {}) or {}
    ct = model.get("colour_thickness_mm")
    try:
        ct = math.inf if ct is None else float(ct)
        lt = float(model.get("layer_thickness_mm", 0.014))
        tmax = float(model.get("density_t_max_mm", 5.0))
        ns = int(model.get("density_samples", 100))
    except (TypeError, ValueError):
        raise DreamPrintError("'model' settings must be numbers", source) from None
    if not (ct > 0 and lt > 0 and tmax > 0 and ns >= 3):
        raise DreamPrintError("'model' thicknesses must be > 0 and density_samples >= 3", source)
    return InkProfile(
        name=str(d.get("name", Path(source).stem)), wavelengths_nm=w, K=K, S=S,
        colour_thickness_mm=ct, layer_thickness_mm=lt, density_t_max_mm=tmax,
        density_samples=ns, provenance=dict(provenance),
        residuals=dict(d.get("residuals", {}) or {}),
        table_settings=_table_settings(d.get("table"), source),
        proof_optics=_proof_optics(d.get("proof"), source),
    )


def _check_ink_origin(provenance: dict[str, Any], source: str) -> None:
    origin = provenance.get("ink_origin")
    if origin is None:
        return
    if not isinstance(origin, dict) or set(origin) - set(INKS) or any(
            v not in INK_ORIGINS for v in origin.values()):
        raise DreamPrintError(f"'provenance.ink_origin' must map inks ({', '.join(INKS)}) to "
                              f"{' or '.join(INK_ORIGINS)}", source)


def ink_origins(profile: InkProfile) -> dict[str, str]:
    """Per ink, ``measured`` or ``modelled`` (see the module docstring)."""
    origin = profile.provenance.get("ink_origin")
    if isinstance(origin, dict):
        return {ink: origin.get(ink, "modelled") for ink in INKS}
    meas = profile.provenance.get("measurements")
    measured = set(meas) if isinstance(meas, dict) else set()
    return {ink: "measured" if ink in measured else "modelled" for ink in INKS}


def modelled_inks(profile: InkProfile) -> list[str]:
    """The inks whose K and S are assumed rather than measured, in INKS order."""
    return [ink for ink, o in ink_origins(profile).items() if o == "modelled"]


# The names the ``table`` settings accept (gamut/optimise.py and mapping.py own them;
# listed here so that loading a profile does not import the solver).
TABLE_OBJECTIVES = ("srgb", "cielab", "de2000", "rgb", "lab")
TABLE_INTENTS = ("colorimetric", "relative", "perceptual")


def _table_settings(t: Any, source: str) -> dict[str, str]:
    if t is None:
        return {}
    if not isinstance(t, dict):
        raise DreamPrintError("'table' must be an object with 'objective' and/or 'intent'",
                              source)
    unknown = sorted(set(t) - {"objective", "intent"})
    if unknown:
        raise DreamPrintError(f"'table' has unknown keys {unknown}; expected objective, intent",
                              source)
    for key, allowed in (("objective", TABLE_OBJECTIVES), ("intent", TABLE_INTENTS)):
        if key in t and t[key] not in allowed:
            raise DreamPrintError(f"'table' {key} {t[key]!r} is not one of "
                                  f"{', '.join(allowed)}", source)
    return {k: str(v) for k, v in t.items()}


PROOF_SURFACES = ("none", "glossy", "matte")


def _proof_optics(t: Any, source: str) -> dict[str, Any]:
    """The optional ``proof`` section: the optics the K and S were fitted through (the print
    proof renders with them, proof/optics.py)."""
    if t is None:
        return {}
    if not isinstance(t, dict):
        raise DreamPrintError("'proof' must be an object (surface, refractive_index, roughness, "
                              "phase)", source)
    unknown = sorted(set(t) - {"surface", "refractive_index", "roughness", "phase"})
    if unknown:
        raise DreamPrintError(f"'proof' has unknown keys {unknown}; expected surface, "
                              "refractive_index, roughness, phase", source)
    if "surface" in t and t["surface"] not in PROOF_SURFACES:
        raise DreamPrintError(f"'proof' surface {t['surface']!r} is not one of "
                              f"{', '.join(PROOF_SURFACES)}", source)
    for key, lo, hi in (("refractive_index", 1.0, 3.0), ("roughness", 0.001, 1.0)):
        if key in t:
            v = t[key]
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not lo <= v <= hi:
                raise DreamPrintError(f"'proof' {key} must be a number in [{lo:g}, {hi:g}], "
                                      f"got {v!r}", source)
    if "phase" in t:
        ph = t["phase"]
        ok = isinstance(ph, str) and (ph == "isotropic" or ph.startswith("hg:"))
        if ok and ph.startswith("hg:"):
            try:
                ok = abs(float(ph[3:])) <= 0.95
            except ValueError:
                ok = False
        if not ok:
            raise DreamPrintError(f"'proof' phase {ph!r} must be 'isotropic' or 'hg:G' with "
                                  "|G| <= 0.95", source)
    return dict(t)


def load_profile(path: str | os.PathLike | None = None) -> InkProfile:
    """Load and validate a profile; ``None`` or ``"default"`` gives the built-in one."""
    if path is None or str(path) == "default":
        return default_profile()
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise DreamPrintError("no such file", p) from None
    except OSError as exc:
        raise DreamPrintError(f"cannot read: {exc.strerror or exc}", p) from None
    except UnicodeDecodeError:
        raise DreamPrintError("not a text file (expected a JSON ink profile)", p) from None
    try:
        d = json.loads(text)
    except json.JSONDecodeError as exc:
        raise DreamPrintError(f"invalid JSON: {exc.msg}", p, exc.lineno) from None
    return profile_from_dict(d, str(p))


def save_profile(profile: InkProfile, path: str | os.PathLike) -> None:
    """Write the profile as JSON atomically (temporary file renamed into place)."""
    text = json.dumps(profile.to_json_dict(), indent=1) + "\n"
    write_atomically(path, text.encode("utf-8"), "profile.json")


_DEFAULT: InkProfile | None = None


def default_profile() -> InkProfile:
    """The built-in profile shipped in ``resources/profiles/`` (see its SOURCES.md)."""
    global _DEFAULT
    if _DEFAULT is None:
        ref = resource_path("profiles", "polyjet_default.json")
        _DEFAULT = profile_from_dict(json.loads(ref.read_text(encoding="utf-8")), str(ref))
    return _DEFAULT


def parse_mix(text: str) -> NDArray[np.float64]:
    """``"C=0.2,M=0.3,W=0.5"`` -> concentrations in INKS order; percent allowed (``C=20%``).

    Absent inks are 0. The fractions must sum to 1 (within 1e-6); values summing to 100 are read
    as percent, with or without the ``%`` sign.
    """
    c = np.zeros(len(INKS))
    seen = set()
    parts = [p.strip() for p in text.split(",") if p.strip()]
    if not parts:
        raise DreamPrintError(f"empty mixture {text!r}; write e.g. C=0.2,M=0.3,W=0.5")
    for part in parts:
        if "=" not in part:
            raise DreamPrintError(f"'{part}' in the mixture is not INK=VALUE")
        name, value = (s.strip() for s in part.split("=", 1))
        match = {ink.lower(): ink for ink in INKS}.get(name.lower())
        if match is None:
            raise DreamPrintError(f"unknown ink '{name}'; inks are {', '.join(INKS)}")
        if match in seen:
            raise DreamPrintError(f"ink {match} given twice")
        seen.add(match)
        pct = value.endswith("%")
        try:
            v = float(value.rstrip("%"))
        except ValueError:
            raise DreamPrintError(f"'{value}' for ink {match} is not a number") from None
        c[INKS.index(match)] = v / 100.0 if pct else v
    if abs(c.sum() - 100.0) <= 1e-4:
        c /= 100.0
    return check_concentrations(c, f"mixture {text!r}")


def check_concentrations(c: NDArray[np.float64], what: str = "mixture") -> NDArray[np.float64]:
    if np.any(~np.isfinite(c)) or np.any(c < 0):
        raise DreamPrintError(f"{what}: concentrations must be finite and >= 0")
    total = float(c.sum())
    if abs(total - 1.0) > 1e-6:
        raise DreamPrintError(f"{what}: concentrations sum to {total:g}, not 1")
    return c


def now_iso() -> str:
    return _dt.datetime.now(_dt.UTC).replace(microsecond=0).isoformat()
