"""The README's test command (`./quickstart.sh test`, which CI runs) and what it installs agree:
the pytest options it passes come from plugins in pyproject's ``test`` extras."""

import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _test_command() -> str:
    text = (ROOT / "quickstart.sh").read_text()
    branch = text.split("\n  test)", 1)[1].split(";;", 1)[0]
    (line,) = [ln for ln in branch.splitlines() if "-m pytest" in ln]
    return line


def test_the_parallel_test_command_installs_its_plugin():
    """`-n 2 --dist loadfile` are pytest-xdist's options: without it in the extras that
    quickstart installs, the command fails on a fresh machine ("unrecognized arguments")."""
    line = _test_command()
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]["test"]
    names = {re.split(r"[<>=!~;\[ ]", e, maxsplit=1)[0].lower() for e in extras}
    assert re.search(r"\s-n\s+\d", line) and "--dist loadfile" in line, line
    assert "pytest-xdist" in names, names
    # a developer's extra arguments come last, so `./quickstart.sh test -n 0` wins
    assert line.rstrip().endswith('"$@"'), line
