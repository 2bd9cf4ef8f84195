"""What the GUI calls things: human names for the ids the files and the command line use.

Defines :data:`BACKGROUNDS` (``--background`` ids -> names), :func:`background_name` and
:func:`printer_name` (a printer's title, e.g. "Stratasys J850 (paper profile)", for the id
``j850-paper``). The ids stay in the files (manifest, settings); only the screen uses these
names, the same on every page.
"""

from __future__ import annotations

__all__ = ["BACKGROUNDS", "background_name", "printer_name"]

# (id, name, what it means) in the order the combo boxes offer them
BACKGROUNDS = (
    ("clear", "Clear resin", "Voxels below the density threshold are printed in Clear resin"),
    ("empty", "Nothing (empty)", "Voxels below the density threshold get no material"),
)


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
        from ..engine.printer import builtin_printers, load_printer
        from ..errors import DreamPrintError

        if printer not in builtin_printers():
            return printer
        try:
            printer = load_printer(printer)
        except DreamPrintError:
            return str(printer)
    return getattr(printer, "display_name", None) or printer.name
