"""ICC output profile of the printer and inks, for soft proofs outside DreamPrint (issue 48).

Defines
-------
- :func:`build_icc`: the profile's bytes, written by LittleCMS (:mod:`.lcms`); device space the
  RGB a job takes, PCS CIELAB D50, device class output (``prtr``):

  - ``A2B0``, ``A2B1``, ``A2B2`` (device -> PCS, one table for every intent: a printer prints
    what it prints; A2B0 is not rescaled to version 4's perceptual reference medium): on an
    n^3 lattice of RGB, the media-relative CIELAB of the print (:class:`.print_pcs.PrintPCS`:
    the table's inks under its intent, eq. 7 colour at the profile's reference thickness,
    Bradford-adapted to D50, divided by the media white).
    A CMM interpolates it tetrahedrally, as DreamPrint's own table lookup.
  - ``B2A1`` (PCS -> device, media-relative colorimetric; ICC-absolute colorimetric is the
    CMM's scaling by ``wtpt``): for every node of an n^3 lattice of the PCS encoding, the RGB
    whose print is nearest (CIEDE2000; :func:`.inverse.nearest_rgb`).
  - ``B2A0`` (perceptual) and ``B2A2`` (saturation, the same table): the PCS colour, taken as a
    colour of the sRGB gamut under D65 (the PCS white onto the sRGB white, inverse ``chad``),
    is first compressed into the printable gamut by DreamPrint's perceptual intent (SGCK in
    CAM16-UCS, :class:`.mapping.PerceptualMap`), then inverted like B2A1.
  - ``gamt``: per PCS node, 0 where its nearest print is within ``IN_GAMUT_DE2000``
    (the gamut figures' rule), else (dE2000 - 1) / 100 clipped to 1.
  - ``wtpt`` (the printable white, D50-adapted), ``chad`` (Bradford D65 -> D50), ``desc``,
    ``cprt``, ``meas`` (CIE 1931 2 degree observer, illuminant D65, geometry unknown: the
    colours are predicted, not measured; no flare), ``tech`` (ink jet).

- :func:`check_profile`: read the bytes back with LittleCMS and compare with DreamPrint's
  prediction (A2B vs the print; B2A then A2B on printable colours), the figures the CLI prints.
- :func:`check_target`: refuse an output path that cannot be written, before any work.
- :func:`write_atomically`: write bytes to a file atomically (temporary file, then rename).

Version: 2.4 by default (``lut16Type`` tables, ``textDescriptionType``): every tool the issue
names reads it, version 2 LUT output profiles are what print RIPs and paper makers still ship,
and version 4 LUT profiles are not read everywhere (Debian's ArgyllCMS 2.3.1: "ICC V4 not
supported"); ``version=4`` writes a version 4.3 profile (``lutAtoBType``/``lutBtoAType``,
``mluc``, profile ID), the current standard. Both hold the same numbers in their own PCS
encoding.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from datetime import UTC, datetime

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.files import check_file_target
from dreamprint_gui.core.files import write_atomically as core_write_atomically
from dreamprint_gui.core.profile import InkProfile
from dreamprint_gui.core.progress import every_heartbeat
from dreamprint_gui.gamut import lcms
from dreamprint_gui.gamut.evaluation import IN_GAMUT_DE2000
from dreamprint_gui.gamut.inverse import nearest_rgb
from dreamprint_gui.gamut.mapping import PerceptualMap
from dreamprint_gui.gamut.print_pcs import PrintPCS, decode_lab, encode_lab, lab_d50
from dreamprint_gui.gamut.print_pcs import xyz_d50 as lab_to_xyz_d50
from dreamprint_gui.gamut.tables import ColourTables
from dreamprint_gui.physics.colorimetry import delta_E2000

__all__ = ["build_icc", "check_profile", "write_atomically", "check_target",
           "ICC_VERSIONS", "DEFAULT_VERSION", "DEFAULT_A2B_GRID", "DEFAULT_B2A_GRID", "rgb_cube"]

ICC_VERSIONS = {2: 2.4, 4: 4.3}
DEFAULT_VERSION = 2
DEFAULT_A2B_GRID = 33
DEFAULT_B2A_GRID = 33
GAMUT_SCALE_DE2000 = 100.0
_MEAS_OBSERVER_1931 = 1
_MEAS_GEOMETRY_UNKNOWN = 0
_MEAS_ILLUMINANT_D65 = 2


def rgb_cube(n: int) -> NDArray[np.float64]:
    """The n^3 lattice of the RGB cube (N, 3), first channel varying slowest (ICC CLUT order)."""
    a = np.linspace(0.0, 1.0, n)
    return np.stack(np.meshgrid(a, a, a, indexing="ij"), axis=-1).reshape(-1, 3)


def _pcs_nodes(n: int, version: int) -> NDArray[np.float64]:
    """CIELAB of the nodes of an n^3 PCS-input CLUT, as LittleCMS places them (16-bit node
    values round(i * 65535 / (n - 1)), decoded in the version's Lab encoding)."""
    v = np.floor(np.arange(n) * 65535.0 / (n - 1) + 0.5)
    g = np.stack(np.meshgrid(v, v, v, indexing="ij"), axis=-1).reshape(-1, 3)
    return decode_lab(g, version)


def _perceptual_targets(pcs: PrintPCS, lab_rel: NDArray) -> NDArray[np.float64]:
    """Media-relative CIELAB targets of B2A0: PCS colours as sRGB-gamut colours under D65,
    compressed by the perceptual intent (module doc)."""
    src = lab_to_xyz_d50(lab_rel) @ np.linalg.inv(pcs.chad).T  # PCS white -> the D65 white
    pmap = PerceptualMap.for_model(pcs.model)
    with np.errstate(all="ignore"):
        mapped = pmap.map_xyz(src)
        out = lab_d50(pcs.relative_xyz_from_absolute(mapped @ pcs.chad.T))
    bad = ~np.all(np.isfinite(out), axis=1)
    out[bad] = lab_rel[bad]  # imaginary colours (no CAM16 appearance): nearest print instead
    return out


def build_icc(profile: InkProfile, tables: ColourTables, *, printer: str = "",
              version: int = DEFAULT_VERSION, a2b_grid: int = DEFAULT_A2B_GRID,
              b2a_grid: int = DEFAULT_B2A_GRID,
              progress: Callable[[str], None] | None = None) -> bytes:
    """The ICC output profile (module doc) of ``tables``' print, as bytes."""
    if version not in ICC_VERSIONS:
        raise DreamPrintError(f"ICC version {version} is not written: choose 2 or 4")
    say = progress or (lambda _msg: None)
    pcs = PrintPCS.for_tables(profile, tables)

    def forward(rgb: NDArray) -> NDArray:
        return pcs.relative_lab(rgb)

    say(f"A2B: the print of {a2b_grid}^3 RGB colours")
    a2b = encode_lab(forward(rgb_cube(a2b_grid)), version).reshape((a2b_grid,) * 3 + (3,))
    nodes = _pcs_nodes(b2a_grid, version)
    def iterations(step: str):
        detail = every_heartbeat(say)
        return lambda i, n: detail(f"{step}: refining, iteration {i} of {n}")

    say(f"B2A colorimetric: the nearest print for {b2a_grid}^3 PCS colours")
    rgb_col, de_col = nearest_rgb(forward, nodes, progress=iterations("B2A colorimetric"))
    say("B2A perceptual: gamut compression, then the nearest print")
    rgb_per, _ = nearest_rgb(forward, _perceptual_targets(pcs, nodes),
                             progress=iterations("B2A perceptual"))

    def device(rgb: NDArray) -> NDArray[np.uint16]:
        v = np.clip(np.round(rgb * 65535.0), 0, 65535).astype(np.uint16)
        return v.reshape((b2a_grid,) * 3 + (3,))

    gamut = np.clip((de_col - IN_GAMUT_DE2000) / GAMUT_SCALE_DE2000, 0.0, 1.0)
    gamt = np.round(gamut * 65535.0).astype(np.uint16).reshape((b2a_grid,) * 3 + (1,))

    name = printer or "PolyJet printer"
    desc = (f"DreamPrint {name}, {profile.name} inks, {tables.intent} intent "
            f"({tables.objective} table)")
    say("writing the profile with Little CMS")
    with lcms.ProfileWriter(ICC_VERSIONS[version], "prtr", "RGB ", "Lab ") as w:
        w.header(rendering_intent=lcms.INTENT_CODES["perceptual"])
        w.text("desc", desc)
        w.text("cprt", f"No copyright, use freely. Made by DreamPrint on "
                       f"{datetime.now(UTC):%Y-%m-%d} from the ink profile '{profile.name}'.")
        w.xyz("wtpt", pcs.media_white)
        w.matrix("chad", pcs.chad)
        w.measurement(_MEAS_OBSERVER_1931, (0.0, 0.0, 0.0), _MEAS_GEOMETRY_UNKNOWN, 0.0,
                      _MEAS_ILLUMINANT_D65)
        w.signature("tech", "ijet")
        w.clut("A2B0", a2b)
        w.link("A2B1", "A2B0")  # the same numbers: stored once
        w.link("A2B2", "A2B0")
        w.clut("B2A1", device(rgb_col))
        w.clut("B2A0", device(rgb_per))
        w.link("B2A2", "B2A0")
        w.clut("gamt", gamt)
        return w.to_bytes()


def check_profile(data: bytes, pcs: PrintPCS, rgb: ArrayLike) -> dict:
    """Figures of a written profile read back by LittleCMS (double precision transforms):

    - ``a2b_dE2000``: RGB through the profile (ICC-absolute colorimetric) vs DreamPrint's own
      prediction of their print (:meth:`.PrintPCS.absolute_lab`), D50 CIELAB;
    - ``round_trip_dE2000``: the prints of ``rgb`` (printable colours) through B2A1 then A2B1
      (media-relative colorimetric), vs themselves.
    """
    rgb = np.asarray(rgb, dtype=np.float64).reshape(-1, 3)
    own = pcs.absolute_lab(rgb)
    via = lcms.transform(data, rgb, "absolute", "to_lab")
    rel = pcs.relative_lab(rgb)
    back = lcms.transform(data, lcms.transform(data, rel, "relative", "from_lab"), "relative",
                          "to_lab")
    return {"colours": len(rgb), "a2b_dE2000": _stats(delta_E2000(via, own)),
            "round_trip_dE2000": _stats(delta_E2000(back, rel))}


def _stats(de: NDArray) -> dict:
    return {"mean": float(np.mean(de)), "p95": float(np.percentile(de, 95)),
            "max": float(np.max(de))}


def check_target(path: str | os.PathLike) -> None:
    """Refuse an output path that cannot be written (a folder, a missing folder), naming it."""
    check_file_target(path, "printer.icc")


def write_atomically(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (:func:`.core.files.write_atomically`)."""
    core_write_atomically(path, data, "printer.icc")
