"""The ``dreamprint`` command group, its ``evaluate`` subgroup and :func:`main`, the entry point.

Every command reports a problem the same way: exit status 2 and one line
``dreamprint: error: <file>: <problem>`` on stderr, no traceback (``--debug`` shows one).
The command modules (siblings of this one) register their commands on :data:`cli`; the
package's ``__init__`` imports them, and nothing in ``cli/`` imports the package itself.
"""

from __future__ import annotations

import os
import sys

import click

from dreamprint_gui.core.errors import DreamPrintError

__all__ = ["cli", "evaluate", "main"]


class _Group(click.Group):
    """The top-level group: a reader that closes the pipe early (``dreamprint ... | head -1``)
    ends the command quietly with status 0, as for any Unix filter."""

    def invoke(self, ctx: click.Context):
        try:
            return super().invoke(ctx)
        except BrokenPipeError:
            _stdout_to_devnull()
            raise click.exceptions.Exit(0) from None


def _stdout_to_devnull() -> None:
    """Point stdout at /dev/null so that the interpreter's final flush of what is still buffered
    does not fail on the closed pipe (Python's documented recipe, library/signal.html)."""
    try:
        fd = os.open(os.devnull, os.O_WRONLY)
        os.dup2(fd, sys.stdout.fileno())
        os.close(fd)
    except (OSError, ValueError, AttributeError):  # no real file descriptor (tests)
        pass


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
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
    except (click.Abort, KeyboardInterrupt) as exc:
        # click turns Ctrl-C into Abort; a command's KeyboardInterrupt may say what was kept
        why = str(exc if isinstance(exc, KeyboardInterrupt) else exc.__cause__ or "")
        click.echo(f"dreamprint: interrupted{' ' + why if why else ''}", err=True)
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
