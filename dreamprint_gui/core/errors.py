"""The one error type the command line and the GUI turn into a message for the operator."""

from __future__ import annotations

import os


class DreamPrintError(Exception):
    """A problem the operator can act on: names the file (if any), the line, and the problem.

    ``str(error)`` is ``"<file>:<line>: <problem>"`` (file and line when known), which is what
    ``dreamprint`` prints after ``dreamprint: error:``.
    """

    def __init__(self, problem: str, path: str | os.PathLike | None = None,
                 line: int | None = None) -> None:
        self.problem = problem
        self.path = None if path is None else os.fspath(path)
        self.line = line
        super().__init__(str(self))

    def __str__(self) -> str:
        where = ""
        if self.path is not None:
            where = self.path if self.line is None else f"{self.path}:{self.line}"
            where += ": "
        return f"{where}{self.problem}"
