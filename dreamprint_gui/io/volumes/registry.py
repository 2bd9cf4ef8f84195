"""The registry of source kinds: which reader opens which file, and format dispatch.

Defines ``FORMATS`` (format key -> reader module and extensions), :func:`sniff_format`,
:func:`open_source`, :func:`inspect_file` / :func:`inspect_source` and :func:`reader_options`.
Kept apart from :mod:`.base` (the protocol and the printer grid every reader imports) so that
the readers import the base and the registry imports the readers, never the other way round.
"""

from __future__ import annotations

import os
from pathlib import Path

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes.base import VolumeSource
from dreamprint_gui.io.volumes.grids.demo import DESIGN_HEIGHT_MM, DemoCloud
from dreamprint_gui.io.volumes.ingp.exports import is_ingp_volume_dir, is_ingp_volume_name
from dreamprint_gui.io.volumes.splats.formats import is_sog

__all__ = ["FORMATS", "sniff_format", "inspect_file", "inspect_source", "open_source",
           "reader_options", "OPTION_ALIASES", "parse_reader_options", "format_reader_options",
           "interpretation_choices", "default_height_mm"]


# format key -> (module, under io.volumes, extensions)
FORMATS: dict[str, tuple[str, tuple[str, ...]]] = {
    "openvdb": ("vdb.openvdb", (".vdb",)),
    "nanovdb": ("vdb.nanovdb", (".nvdb",)),
    "vtk": ("grids.vtkimage", (".vti", ".vtk", ".mhd", ".mha", ".nrrd", ".nhdr")),
    "radiance-npz": ("grids.radiance", (".npz",)),
    "radiance-exr": ("grids.radiance", (".exr",)),
    "splats": ("splats.cloud", (".ply", ".spz", ".splat", ".ksplat", ".sog")),
    "magicavoxel": ("grids.magicavoxel", (".vox",)),
    "instant-ngp": ("ingp.snapshot", (".ingp", ".msgpack")),
    "ingp-volume": ("ingp.exports", ()),     # told by name: NNNN_WxH.png, WxHxD_C.bin
}


def sniff_format(path: Path) -> str:
    """Format key of ``path`` from its extension, falling back to its first bytes."""
    if path.is_dir() or path.name == "meta.json":

        if is_sog(path):
            return "splats"

    if path.is_dir():
        return "ingp-volume" if is_ingp_volume_dir(path) else "radiance-exr"
    if is_ingp_volume_name(path.name):
        return "ingp-volume"
    suffix = path.suffix.lower()
    for key, (_mod, exts) in FORMATS.items():
        if suffix in exts:
            return key
    try:
        with open(path, "rb") as f:
            head = f.read(64)
    except OSError as exc:
        raise DreamPrintError(f"cannot read: {exc.strerror or exc}", path) from None
    if head[:4] == b"\x20\x42\x44\x56":
        return "openvdb"
    if head[:7] == b"NanoVDB":
        return "nanovdb"
    if head[:4] in (b"ply\n", b"ply\r"):
        return "splats"
    if head[:2] == b"\x1f\x8b" or head[:4] == b"NGSP":
        return "splats"
    if head[:4] == b"VOX ":
        return "magicavoxel"
    if head[:4] == b"PK\x03\x04":
        return "radiance-npz"
    if head[:4] == b"\x76\x2f\x31\x01":
        return "radiance-exr"
    if head[:4] == b"NRRD" or head.startswith(b"# vtk DataFile") or b"<VTKFile" in head \
            or head.startswith(b"ObjectType"):
        return "vtk"
    raise DreamPrintError("not a volume format DreamPrint reads (OpenVDB, NanoVDB, VTK image, "
                          "MetaImage, NRRD, radiance .npz/EXR stack, splat PLY/SPZ/.splat/"
                          ".ksplat/SOG, MagicaVoxel, InstantNGP snapshot or volume export)", path)


def inspect_file(path_or_name: str | os.PathLike) -> dict:
    """The ``inspect`` description of a file, without choosing grids or options (a file whose
    density grid is empty or missing can still be inspected)."""
    return inspect_source(path_or_name)[0]


def default_height_mm(path_or_name: str | os.PathLike) -> float | None:
    """The height a source prints at when no size is given: the built-in demo's design height
    (its densities are set for it), else None (a file's size must be asked for)."""
    return DESIGN_HEIGHT_MM if str(path_or_name) == "demo" else None


def inspect_source(path_or_name: str | os.PathLike) -> tuple[dict, VolumeSource | None]:
    """(the ``inspect`` description, the source opened with default options for it, or None
    for the formats described without opening a source: OpenVDB, NanoVDB)."""
    import importlib

    if str(path_or_name) == "demo":
        src = open_source("demo")
        return src.info(), src
    path = Path(path_or_name)
    if not path.exists():
        raise DreamPrintError("no such file", path)
    key = sniff_format(path)
    module = importlib.import_module(f"{__package__}.{FORMATS[key][0]}")
    if hasattr(module, "inspect_path"):
        return module.inspect_path(path), None
    try:
        src = module.open_path(path, fmt=key)
    except DreamPrintError:
        if not hasattr(module, "describe_path"):  # a reader that can describe what it can't map
            raise
        return module.describe_path(path), None
    return src.info(), src


def open_source(path_or_name: str | os.PathLike, **options) -> VolumeSource:
    """Open a volume file (or ``"demo"``, the built-in procedural planet) as a source.

    ``options`` are passed to the format's reader (e.g. ``density_grid="density"``,
    ``window=(lo, hi)``, ``level_set="solid"``); unknown options are refused by the reader.
    """
    import importlib

    if str(path_or_name) == "demo":
        return DemoCloud(**_checked_options(DemoCloud, options, "demo"))
    path = Path(path_or_name)
    if not path.exists():
        raise DreamPrintError("no such file", path)
    key = sniff_format(path)
    module = importlib.import_module(f"{__package__}.{FORMATS[key][0]}")
    return module.open_path(path, fmt=key, **_checked_options(module.open_path, options, path))


def reader_options(path_or_name: str | os.PathLike) -> set[str]:
    """The option names the reader of ``path_or_name`` takes (empty for an unknown format)."""
    import importlib
    import inspect

    if str(path_or_name) == "demo":
        func = DemoCloud
    else:
        path = Path(path_or_name)
        if not path.exists():
            return set()
        module = importlib.import_module(f"{__package__}.{FORMATS[sniff_format(path)][0]}")
        func = module.open_path
    return {p.name for p in inspect.signature(func).parameters.values()
            if p.name not in ("self", "path", "fmt")}


OPTION_ALIASES = {"grid": "density_grid", "color": "colour", "colormap": "colormap",
                  "cmap": "colormap"}


def interpretation_choices(path_or_name: str | os.PathLike) -> dict:
    """What an operator may choose about how a file is read, for the GUI's controls (the
    CLI's ``--option``): ``options`` (every option name its reader takes), ``grids`` (the
    scalar grids a density may come from, when the reader takes ``density_grid`` and the
    file holds more than one), ``level_set`` (the file holds a level set: read it as a solid
    or a shell, ``level_set=``)."""
    takes = reader_options(path_or_name)
    out = {"options": sorted(takes), "grids": [], "level_set": False}
    if "density_grid" not in takes:
        return out
    try:
        grids = inspect_file(path_or_name).get("grids", [])
    except DreamPrintError:
        return out  # an unreadable file is reported when it is opened
    scalar = [g for g in grids if str(g.get("dtype", "")).split()[0] in ("float", "double",
                                                                        "half")]
    if len(scalar) > 1:
        out["grids"] = [g["name"] for g in scalar]
    out["level_set"] = "level_set" in takes and any(g.get("class") == "level set"
                                                     for g in scalar)
    return out


def _option_value(v: str):
    for conv in (int, float):
        try:
            return conv(v)
        except ValueError:
            pass
    return {"true": True, "false": False}.get(v.lower(), v)


def parse_reader_options(items) -> dict:
    """Reader options from ``KEY=VALUE`` texts (the CLI's repeated ``--option``, the GUI's
    Reader options field, comma-separated): numbers and true/false converted."""
    if isinstance(items, str):
        items = [t for t in items.split(",") if t.strip()]
    out = {}
    for kv in items:
        if "=" not in kv:
            raise DreamPrintError(f"--option must be KEY=VALUE, got '{kv.strip()}'")
        k, v = kv.split("=", 1)
        out[k.strip()] = _option_value(v.strip())
    return out


def format_reader_options(options: dict) -> str:
    """The ``KEY=VALUE, ...`` text of reader options (what :func:`parse_reader_options`
    reads back)."""
    return ", ".join(f"{k}={v}" for k, v in options.items())


def _checked_options(func, options: dict, where) -> dict:
    """Refuse options the reader does not take, naming the ones it does (``grid`` is accepted
    for ``density_grid``, ``color`` for ``colour``)."""
    import inspect

    params = [p for p in inspect.signature(func).parameters.values()
              if p.kind == p.KEYWORD_ONLY or (p.name not in ("self", "path", "fmt")
                                              and p.kind == p.POSITIONAL_OR_KEYWORD)]
    names = {p.name for p in params}
    out = {}
    for k, v in options.items():
        k2 = k if k in names else OPTION_ALIASES.get(k, k)
        if k2 not in names:
            known = ", ".join(sorted(names)) or "none"
            raise DreamPrintError(f"unknown reader option {k!r} (this format takes: {known})",
                                  where)
        out[k2] = v
    return out
