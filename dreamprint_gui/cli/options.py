"""The command line's shared options, each declared once: the print's size (``--height-mm`` /
``--size-mm``), its placement (``--up`` / ``--rotate`` / ``--fit``) and its rendering
(``--content`` / ``--sampling`` / ``--objective`` / ``--intent``), and their parsing.

``convert``, ``proof``, ``evaluate methods``, ``compensate`` and ``inspect`` take them from
here, so a print is stated the same way by every command.
"""

from __future__ import annotations

import math

import click

from dreamprint_gui.core.errors import DreamPrintError

__all__ = ["OBJECTIVES", "INTENTS", "OBJECTIVE_HELP", "INTENT_HELP", "size_options",
           "placement_options", "rendering_options", "placement_values", "parse_size",
           "print_spec"]

# the colour table objective and rendering intent (also of lookup, gamut and icc)
OBJECTIVES = click.Choice(["srgb", "cielab", "de2000"])
INTENTS = click.Choice(["colorimetric", "relative", "perceptual"])
OBJECTIVE_HELP = ("Table objective: srgb (paper eq. 10), cielab (dE76) or de2000 (CIEDE2000). "
                  "Default: the profile's, else de2000 (see docs/physics.md).")
INTENT_HELP = ("Rendering intent for colours outside the printable gamut: colorimetric "
               "(nearest printable colour), relative (ICC relative colorimetric: the source "
               "white maps to the printable white, then colorimetric) or perceptual (SGCK "
               "compression in CAM16-UCS). Default: the profile's, else colorimetric.")


def _apply(f, opts: list):
    for o in reversed(opts):
        f = o(f)
    return f


def size_options(f):
    """``--height-mm`` and ``--size-mm``: the print's size (exactly one of them)."""
    return _apply(f, [
        click.option("--height-mm", type=float, default=None,
                     help="Height (z) of the print in mm."),
        click.option("--size-mm", default=None,
                     help="Fit into the box X,Y,Z mm (aspect kept)."),
    ])


def placement_options(f):
    """``--up``, ``--rotate`` and ``--fit``: how a source stands and what its size measures
    (:mod:`..io.volumes.orient`)."""
    return _apply(f, [
        click.option("--up", type=click.Choice(["auto", "x", "-x", "y", "-y", "z", "-z"]),
                     default="auto", show_default=True,
                     help="The source axis that becomes the print's up (+z). auto: what "
                          "the file says (OpenVDB: Houdini/Maya y, Blender z, or an up axis in "
                          "its metadata; a 3DGS splat: its cameras.json; MagicaVoxel z), else "
                          "a guess said as one: on its largest flat side, else its longest "
                          "axis up, else the kind's convention (splats PLY/.splat/SOG -y, SPZ "
                          "y, InstantNGP z, else z)."),
        click.option("--rotate", default="0", show_default=True,
                     help="Turn the print about its z: 0, 90, 180 or 270 degrees "
                          "(counter-clockwise seen from above)."),
        click.option("--fit", type=click.Choice(["occupied", "box"]), default="occupied",
                     show_default=True,
                     help="What --height-mm / --size-mm measure: occupied (the object's "
                          "non-empty bounds, empty margins cropped) or box (the file's "
                          "declared box)."),
    ])


def rendering_options(f):
    """``--content``, ``--sampling``, ``--objective`` and ``--intent``: how the source's colour
    and density become inks (a correction is made for, and checked against, these)."""
    return _apply(f, [
        click.option("--content", type=click.Choice(["auto", "fog", "solid"]), default="auto",
                     show_default=True,
                     help="Material intent: fog (density as the source states it), solid "
                          "(occupied voxels printed as undiluted colour, the rest empty/Clear), "
                          "or auto (solid for voxel models, level sets and binary masks; fog "
                          "otherwise)."),
        click.option("--sampling", type=click.Choice(["nearest", "linear"]), default=None,
                     help="Voxel models (.vox): nearest (default, sharp edges) or linear "
                          "(smooth)."),
        click.option("--objective", type=OBJECTIVES, default=None, help=OBJECTIVE_HELP),
        click.option("--intent", type=INTENTS, default=None, help=INTENT_HELP),
    ])


def placement_values(up: str, rotate: str) -> tuple[str | None, int]:
    """(up or None for auto, rotate in degrees) from the CLI's values."""
    from dreamprint_gui.io.volumes.orient import parse_rotate

    return (None if up == "auto" else up), parse_rotate(rotate)


def parse_size(text: str | None) -> tuple[float, float, float] | None:
    """``--size-mm X,Y,Z`` (or ``XxYxZ``) as three positive millimetres; None when not given."""
    if text is None:
        return None
    try:
        v = tuple(float(x) for x in text.replace("x", ",").split(","))
    except ValueError:
        raise DreamPrintError(f"--size-mm must be X,Y,Z in mm, got '{text}'") from None
    if len(v) != 3 or not all(math.isfinite(x) and x > 0 for x in v):
        raise DreamPrintError(f"--size-mm must be three positive numbers X,Y,Z, got '{text}'")
    return v


def print_spec(source: str, kw: dict, compensation: str | None = None):
    """The :class:`..job.spec.PrintSpec` of a command's options (``kw``: its keywords; an
    option the command does not take keeps the spec's default)."""
    from dataclasses import fields

    from dreamprint_gui.io.volumes.registry import default_height_mm, parse_reader_options
    from dreamprint_gui.job.spec import PrintSpec

    up, rotate = placement_values(kw.get("up", "auto"), kw.get("rotate", "0"))
    spec = {f.name: kw[f.name] for f in fields(PrintSpec) if f.name in kw}
    design = default_height_mm(source)
    if design is not None and kw.get("height_mm") is None and kw.get("size_mm") is None \
            and "height_mm" in kw:
        spec["height_mm"] = design
        click.echo(f"{source}: printed at its design height, {design:g} mm (--height-mm or "
                   "--size-mm changes it)", err=True)
    spec.update(source=source, up=up, rotate=rotate, size_mm=parse_size(kw.get("size_mm")),
                source_options=tuple(sorted(parse_reader_options(
                    kw.get("source_options", ())).items())),
                compensation=compensation)
    return PrintSpec(**spec)
