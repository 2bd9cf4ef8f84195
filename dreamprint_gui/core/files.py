"""Writing an output file so that a failure never leaves half of it: one place for the rule.

Defines :func:`check_file_target` (refuse a path that cannot be a new file, before any work),
:func:`write_atomically` (a temporary sibling, then a rename) and :func:`cache_folder` (where
the product keeps what it can compute again: ``DREAMPRINT_CACHE`` or the user cache folder).
A written file gets the permissions of any new file (0666 less the umask), not
``tempfile.mkstemp``'s owner-only 0600: profiles are shared with colour daemons, RIPs and
other users.
"""

from __future__ import annotations

import os
import secrets
from pathlib import Path

from dreamprint_gui.core.errors import DreamPrintError

__all__ = ["check_file_target", "write_atomically", "cache_folder"]


def check_file_target(path: str | os.PathLike, example: str = "output.json") -> Path:
    """``path`` as a Path; refuses a folder or a missing parent folder, naming it."""
    p = Path(path)
    if p.is_dir():
        raise DreamPrintError(f"is a folder; give a file name such as {example}", p)
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise DreamPrintError("the folder does not exist", parent)
    return p


def write_atomically(path: str | os.PathLike, data: bytes, example: str = "output.json"
                     ) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder and a rename."""
    p = check_file_target(path, example)
    tmp = p.with_name(f".{p.name}.{os.getpid()}-{secrets.token_hex(4)}.tmp")
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    except FileNotFoundError:
        raise DreamPrintError("the folder does not exist", p.parent) from None
    except OSError as exc:
        raise DreamPrintError(f"cannot write: {exc.strerror or exc}", p) from None
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, p)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise DreamPrintError(f"cannot write: {exc.strerror or exc}", p) from None


def cache_folder(name: str = "") -> Path:
    """The cache sub-folder ``name`` (not created): under ``DREAMPRINT_CACHE`` when it is set,
    else under the platform's user cache folder for dreamprint (platformdirs)."""
    env = os.environ.get("DREAMPRINT_CACHE")
    if env:
        root = Path(env)
    else:
        from platformdirs import user_cache_path

        root = user_cache_path("dreamprint")
    return root / name if name else root
