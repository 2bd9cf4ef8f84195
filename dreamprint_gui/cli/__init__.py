"""The ``dreamprint`` command line: thin over the engine and the readers.

Every command reports a problem the same way: exit status 2 and one line
``dreamprint: error: <file>: <problem>`` on stderr, no traceback (``--debug`` shows one).
Command groups live in sibling modules, each registering its commands on :data:`cli`.
"""

from __future__ import annotations

import sys

import click

from dreamprint_gui.core.errors import DreamPrintError


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--debug", is_flag=True, help="Show a traceback on error.")
@click.version_option(package_name="dreamprint", prog_name="dreamprint")
def cli(debug: bool) -> None:
    """DreamPrint: radiance volumes to PolyJet print jobs."""


@cli.group()
def evaluate() -> None:
    """Reproduce the paper's evaluations and check finished jobs."""


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``dreamprint``; returns the exit status."""
    args = sys.argv[1:] if argv is None else list(argv)
    debug = "--debug" in args
    try:
        cli.main(args=args, prog_name="dreamprint", standalone_mode=False)
    except click.exceptions.Exit as exc:
        return exc.exit_code
    except click.BadParameter as exc:  # e.g. a path that is missing or a folder
        click.echo(f"dreamprint: error: {exc.format_message()}", err=True)
        return 2
    except click.ClickException as exc:
        exc.show()
        return exc.exit_code
    except (click.Abort, KeyboardInterrupt):
        click.echo("dreamprint: interrupted", err=True)
        return 130
    except DreamPrintError as exc:
        if debug:
            raise
        click.echo(f"dreamprint: error: {exc}", err=True)
        return 2
    except Exception as exc:  # noqa: BLE001 - the operator gets one line, --debug the rest
        if debug:
            raise
        filename = getattr(exc, "filename", None)
        where = f"{filename}: " if filename else ""
        msg = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
        click.echo(f"dreamprint: error: {where}{msg}", err=True)
        return 2
    return 0


# Command modules register themselves on `cli` when imported.
from dreamprint_gui.cli import physics  # noqa: E402,F401,I001
from dreamprint_gui.cli import spectra  # noqa: E402,F401,I001
from dreamprint_gui.cli import volumes  # noqa: E402,F401,I001
from dreamprint_gui.cli import jobs  # noqa: E402,F401,I001
from dreamprint_gui.cli import gamut  # noqa: E402,F401,I001
from dreamprint_gui.cli import proof  # noqa: E402,F401,I001

if __name__ == "__main__":
    sys.exit(main())
