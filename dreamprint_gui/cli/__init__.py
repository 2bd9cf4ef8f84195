"""The ``dreamprint`` command line: thin over the layers below (proof, job, gamut, physics, io).

:mod:`.group` holds the command group and :func:`main`; :mod:`.options` the options every
command shares (the print's size, placement and rendering, stated once); :mod:`.progress` the
progress lines; the sibling modules register their commands on the group when this package
imports them. A command imports the layers it calls inside its function, so that
``dreamprint --help`` and a mistyped option answer at once, without loading numba,
colour-science and the colour tables (the one reason for an import of the package's own
modules inside a function).
"""

from __future__ import annotations

import sys

from dreamprint_gui.cli import (  # noqa: F401 - each registers its commands on the group
    gamut,
    icc,
    jobs,
    physics,
    proof,
    spectra,
    target,
    volumes,
)
from dreamprint_gui.cli.group import cli, main

__all__ = ["cli", "main"]

if __name__ == "__main__":
    sys.exit(main())
