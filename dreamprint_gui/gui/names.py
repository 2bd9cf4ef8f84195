"""What the GUI calls things: human names for the ids the files and the command line use.

Defines :data:`BACKGROUNDS` (``--background`` ids -> names), :data:`CONTENTS` (``--content``),
:data:`SAMPLINGS` (``--sampling`` of voxel models), :data:`LEVEL_SETS` (``--option
level_set=``), :data:`INTENTS` (``--intent``), :func:`background_name` and
:func:`printer_name` (a printer's human name, ``PrinterProfile.display_name``, for the id
``j850-paper``). The ids stay in the files (manifest, settings); only the screen uses these
names, the same on every page.
"""

from __future__ import annotations

__all__ = ["BACKGROUNDS", "CONTENTS", "SAMPLINGS", "LEVEL_SETS", "INTENTS", "background_name",
           "printer_name", "gui_wording"]

# The command line's options as the GUI's controls are labelled (engine messages name options;
# the reader options first, most specific first)
_OPTIONS = {"--option level_set=solid": "Level set: Solid",
            "--option level_set=shell": "Level set: Shell",
            "--option grid=NAME": "the Grid control",
            "--option ": "Reader options ",
            "--up changes it": "the Up control changes it",
            "--content": "Content", "--density-scale": "Density scale",
            "--background": "Background", "--sampling": "Voxel edges", "--up": "Up",
            "--rotate": "Turn", "--fit": "Size of", "--intent": "Rendering intent"}

# (id, name, what it means) in the order the combo boxes offer them
BACKGROUNDS = (
    ("clear", "Clear resin", "Voxels below the density threshold are printed in Clear resin"),
    ("empty", "Nothing (empty)", "Voxels below the density threshold get no material"),
)


# ``--content`` ids: what the source's density means
CONTENTS = (
    ("auto", "Auto", "Solid for voxel models, level sets and binary masks; fog for smoke, "
     "clouds, radiance fields and splats"),
    ("fog", "Fog", "The source's density as it states it (smoke, clouds): density x scale"),
    ("solid", "Solid", "Occupied voxels print opaque in their colour; the rest is background"),
)
# ``--option level_set=``: how a level set is read (None: as Content implies, solid unless fog)
LEVEL_SETS = (
    (None, "As Content", "Solid for Content Auto or Solid; refused for Fog"),
    ("solid", "Solid", "The inside of the surface, filled"),
    ("shell", "Shell", "A hollow object: the wall inside the surface, Wall voxels thick"),
)
# ``--sampling`` of voxel models: None is the reader's own (nearest: sharp voxel edges)
SAMPLINGS = (
    (None, "Sharp", "Each voxel keeps its colour and its edges (nearest neighbour)"),
    ("linear", "Smooth", "Colours and edges blended between voxels (trilinear)"),
)


# ``--up`` ids: the source axis that becomes the print's up (+z)
UPS = (
    ("auto", "Auto", "What the file says (an OpenVDB writer: Houdini and Maya y-up, Blender "
     "z-up, or an up axis in its metadata; the cameras.json beside a 3DGS splat; MagicaVoxel "
     "z-up), else a guess said under the controls: the object on its largest flat side, else "
     "on its longest axis, else its kind's convention (splats -y, SPZ +y, InstantNGP +z, "
     "otherwise the file's z)"),
    ("z", "+z (file's z)", "The file's z axis points up"),
    ("-z", "-z", "The file's -z axis points up (turned upside down)"),
    ("y", "+y", "The file's y axis points up (y-up scenes)"),
    ("-y", "-y", "The file's -y axis points up (y-down scenes: COLMAP, 3DGS)"),
    ("x", "+x", "The file's x axis points up"),
    ("-x", "-x", "The file's -x axis points up"),
)
# ``--rotate``: quarter turns about the print's z, counter-clockwise seen from above
TURNS = ((0, "0 degrees"), (90, "90 degrees"), (180, "180 degrees"), (270, "270 degrees"))
# ``--fit``: what the height (or box) measures
FITS = (
    ("occupied", "The object", "The size asked is the object's: its non-empty bounds, empty "
     "margins cropped"),
    ("box", "The file's box", "The size asked is the file's declared box, empty margins "
     "included"),
)


# ``--intent`` ids (gamut.mapping.INTENTS) as the Rendering intent controls offer them
INTENTS = (
    ("colorimetric", "Colorimetric", "Each colour as the nearest printable colour"),
    ("relative", "Relative", "The source white mapped to the printable white, the rest "
     "colorimetric (ICC media-relative)"),
    ("perceptual", "Perceptual", "sRGB compressed into the printable gamut"),
)


# ``--fit MODE`` and ``--intent I`` named as their control's choice (before the bare flags: the
# longest flag first)
_OPTIONS = {**{f"--fit {key}": f"Size of: {name}" for key, name, _ in FITS},
            **{f"--intent {key}": f"Rendering intent: {name}" for key, name, _ in INTENTS},
            **_OPTIONS}


def background_name(background_id: str) -> str:
    for key, name, _ in BACKGROUNDS:
        if key == background_id:
            return name
    return background_id


def printer_name(printer) -> str:
    """A printer's human name from a ``PrinterProfile`` or a built-in id (else the id)."""
    if printer is None:
        return ""
    if isinstance(printer, str):
        from dreamprint_gui.core.errors import DreamPrintError
        from dreamprint_gui.core.printer import builtin_printers, load_printer

        if printer not in builtin_printers():
            return printer
        try:
            printer = load_printer(printer)
        except DreamPrintError:
            return str(printer)
    return getattr(printer, "display_name", None) or printer.name


def gui_wording(message: str) -> str:
    """An engine message with command-line options named as the GUI's controls."""
    for flag, control in _OPTIONS.items():
        message = message.replace(flag, control)
    return message
