"""Print-job folders written atomically: ``JOB/slices/NNNNN.png`` + ``JOB/manifest.json``.

Defines
-------
- :func:`check_target`: refuse an existing job (unless ``overwrite``) or a missing parent
  folder before any work is done.
- :class:`JobWriter`: a context manager that writes into a hidden temporary folder beside the
  target (``.NAME.partial-<pid>-<random>``) and renames it into place only in :meth:`commit`;
  on any exception, cancel or Ctrl-C the temporary folder is removed, so no folder ever
  appears under the final name unless it is complete. A process killed outright (SIGKILL,
  power loss) leaves only the hidden temporary folder; the next export to the same target
  removes such leftovers whose process is gone.
- :func:`slice_name`: ``slices/00042.png`` naming (5 digits, more when a job has > 99,999 layers).
- :func:`disk_error`: turn ENOSPC/EDQUOT into a clear :class:`DreamPrintError`.

Replacing an existing job (``overwrite``): the old folder is renamed aside first, the new one
renamed into place, then the old one deleted, so a failure in between never loses both.
"""

from __future__ import annotations

import errno
import json
import os
import shutil
import uuid
from pathlib import Path
from typing import Any

from dreamprint_gui.core.errors import DreamPrintError

__all__ = ["JobWriter", "check_target", "slice_name", "disk_error", "MANIFEST", "SLICES",
           "CANCEL_MARKER"]

MANIFEST = "manifest.json"
SLICES = "slices"
CANCEL_MARKER = ".cancelled"
_DISK_FULL = {errno.ENOSPC, getattr(errno, "EDQUOT", errno.ENOSPC)}


def slice_name(layer: int, n_layers: int) -> str:
    """File name of a layer's slice: zero-padded to at least 5 digits."""
    width = max(5, len(str(max(0, n_layers - 1))))
    return f"{layer:0{width}d}.png"


def check_target(target: str | os.PathLike, overwrite: bool = False) -> Path:
    """The absolute target path; raises if it exists (without ``overwrite``) or can't be made."""
    p = Path(target).expanduser().absolute()
    if p.exists() and not overwrite:
        raise DreamPrintError("the job folder already exists (use --overwrite to replace it)", p)
    if p.exists() and not p.is_dir():
        raise DreamPrintError("exists and is not a folder; refusing to replace it", p)
    if not p.parent.is_dir():
        raise DreamPrintError("the folder to write the job into does not exist", p.parent)
    if not os.access(p.parent, os.W_OK):
        raise DreamPrintError("no permission to write here", p.parent)
    return p


def disk_error(exc: OSError, where: str | os.PathLike) -> DreamPrintError:
    if exc.errno in _DISK_FULL:
        return DreamPrintError("the disk is full (no space left while writing the job); the "
                               "partial job was removed", where)
    return DreamPrintError(f"cannot write the job: {exc.strerror or exc}", where)


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _remove_stale_partials(target: Path) -> None:
    for p in target.parent.glob(f".{target.name}.partial-*"):
        try:
            pid = int(p.name.rsplit(".partial-", 1)[1].split("-", 1)[0])
        except (ValueError, IndexError):
            continue
        if pid != os.getpid() and not _pid_alive(pid):
            shutil.rmtree(p, ignore_errors=True)


class JobWriter:
    """Write a job into a temporary folder; :meth:`commit` renames it to ``target``."""

    def __init__(self, target: str | os.PathLike, overwrite: bool = False) -> None:
        self.target = check_target(target, overwrite)
        self.overwrite = overwrite
        self.tmp = self.target.parent / (f".{self.target.name}.partial-{os.getpid()}-"
                                         f"{uuid.uuid4().hex[:8]}")
        self.committed = False

    @property
    def slices_dir(self) -> Path:
        return self.tmp / SLICES

    def __enter__(self) -> JobWriter:
        _remove_stale_partials(self.target)
        try:
            self.slices_dir.mkdir(parents=True)
        except OSError as exc:
            shutil.rmtree(self.tmp, ignore_errors=True)
            raise disk_error(exc, self.tmp) from None
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if not self.committed:
            self.abort()
        if isinstance(exc, OSError) and not isinstance(exc, FileNotFoundError | FileExistsError):
            raise disk_error(exc, self.target) from exc

    def request_cancel(self) -> None:
        """Tell slab tasks (threads, processes or cluster workers) to stop at their next layer."""
        try:
            (self.tmp / CANCEL_MARKER).touch()
        except OSError:
            pass

    def abort(self) -> None:
        shutil.rmtree(self.tmp, ignore_errors=True)
        if self.tmp.exists():  # a straggling writer may have raced the first pass
            shutil.rmtree(self.tmp, ignore_errors=True)

    def commit(self, manifest: dict[str, Any]) -> Path:
        """Write the manifest and move the finished job under its final name."""
        try:
            data = json.dumps(manifest, indent=2, sort_keys=False) + "\n"
            with open(self.tmp / MANIFEST, "w", encoding="utf-8") as f:
                f.write(data)
                f.flush()
                os.fsync(f.fileno())
            (self.tmp / CANCEL_MARKER).unlink(missing_ok=True)
            old = None
            if self.target.exists():
                if not self.overwrite:
                    raise DreamPrintError("the job folder appeared while converting (use "
                                          "--overwrite to replace it)", self.target)
                old = self.target.parent / f".{self.target.name}.old-{uuid.uuid4().hex[:8]}"
                os.replace(self.target, old)
            os.replace(self.tmp, self.target)
            self.committed = True
            if old is not None:
                shutil.rmtree(old, ignore_errors=True)
        except OSError as exc:
            self.abort()
            raise disk_error(exc, self.target) from None
        return self.target
