"""Print-job folders written atomically: ``JOB/slices/NNNNN.png`` + ``JOB/manifest.json``.

Defines
-------
- :func:`check_target`: refuse an existing job (unless ``overwrite``) or a missing parent
  folder before any work is done.
- :class:`JobWriter`: a context manager that writes into a hidden temporary folder beside the
  target (``.NAME.partial-<pid>-<random>``) and renames it into place only in :meth:`commit`,
  so no folder ever appears under the final name unless it is complete. On an exception or a
  cancel the temporary folder is removed; once the job has stamped it resumable
  (:mod:`.resume`), an interruption (Ctrl-C, SIGTERM, :class:`JobInterrupted` such as a lost
  scheduler) keeps it for ``--resume``, as does a process killed outright (SIGKILL, power
  loss). ``claim`` takes over such a leftover (renamed to this process's name) to finish it.
- :func:`stale_partials`: the temporary folders beside a target whose process is gone (or that
  an earlier export of this process left, as the GUI's after a lost cluster); the
  next export to the same target removes them (:mod:`.run` first refuses to discard one that
  holds finished slabs unless ``--overwrite``).
- :func:`write_atomic`: a new file written under a temporary name, then renamed into place
  (a slice written again by a rescheduled task replaces identical bytes).
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
           "CANCEL_MARKER", "IDENTITY", "SLABS", "JobCancelled", "JobInterrupted", "stale_partials",
           "write_atomic", "TMP_SUFFIX"]

MANIFEST = "manifest.json"
SLICES = "slices"
CANCEL_MARKER = ".cancelled"
TMP_SUFFIX = ".tmp"
IDENTITY = "identity.json"  # a resumable job's identity (.resume)
SLABS = "slabs"             # its finished slabs' records (.resume)
_DISK_FULL = {errno.ENOSPC, getattr(errno, "EDQUOT", errno.ENOSPC)}


class JobCancelled(Exception):
    """The conversion was cancelled (GUI cancel): its partial folder is removed."""


class JobInterrupted(DreamPrintError):
    """The job stopped before its end for a cause outside it (the scheduler lost, a worker
    dying again and again); the finished slabs are kept for ``--resume``."""


def write_atomic(path: str, data: bytes) -> None:
    """Write ``path`` as a new temporary file beside it (never an existing one, never creating
    folders: a straggling task after a cancel must fail rather than recreate the job's
    folder), then rename it into place. os-level calls: a slice costs an open, a write, a close
    and a rename, which matters for small jobs of many layers."""
    tmp = f"{path}.{uuid.uuid4().hex[:12]}{TMP_SUFFIX}"
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o666)
    try:
        view = memoryview(data)
        while view:
            view = view[os.write(fd, view):]
    finally:
        os.close(fd)
    os.replace(tmp, path)


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


def disk_error(exc: OSError, where: str | os.PathLike, kept: bool = False) -> DreamPrintError:
    if exc.errno in _DISK_FULL:
        if kept:
            return DreamPrintError("the disk is full (no space left while writing the job); "
                                   "the finished layers are kept: free some space and run the "
                                   "same command with --resume", where)
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


# The temporary folders this process's JobWriters are writing now. A folder named with this
# process's pid but not in here was left by an earlier export of this process (the GUI's: an
# export stopped by a lost scheduler or a full disk), so it is as stale as a dead process's.
_WRITING: set[Path] = set()


def stale_partials(target: str | os.PathLike) -> list[Path]:
    """The temporary folders of ``target`` whose process is gone, or that an earlier export of
    this process left (no :class:`JobWriter` of it writes them now), newest first."""
    target = Path(target).expanduser().absolute()
    out = []
    for p in target.parent.glob(f".{target.name}.partial-*"):
        try:
            pid = int(p.name.rsplit(".partial-", 1)[1].split("-", 1)[0])
        except (ValueError, IndexError):
            continue
        ours = pid == os.getpid()
        if ((ours and p not in _WRITING) or (not ours and not _pid_alive(pid))) and p.is_dir():
            out.append(p)
    def mtime(p: Path) -> float:
        try:
            return p.stat().st_mtime
        except OSError:  # removed meanwhile
            return 0.0

    return sorted(out, key=mtime, reverse=True)


def _remove_stale_partials(target: Path) -> None:
    for p in stale_partials(target):
        shutil.rmtree(p, ignore_errors=True)


def _remove_temporaries(folder: Path) -> None:
    """Files a killed writer left under their temporary names."""
    for sub in (folder, folder / SLICES, folder / SLABS):
        if sub.is_dir():
            for p in sub.glob(f"*{TMP_SUFFIX}"):
                p.unlink(missing_ok=True)


class JobWriter:
    """Write a job into a temporary folder; :meth:`commit` renames it to ``target``."""

    def __init__(self, target: str | os.PathLike, overwrite: bool = False,
                 claim: Path | None = None) -> None:
        self.target = check_target(target, overwrite)
        self.overwrite = overwrite
        self.claim = claim
        self.tmp = self.target.parent / (f".{self.target.name}.partial-{os.getpid()}-"
                                         f"{uuid.uuid4().hex[:8]}")
        self.committed = False
        self.resumable = False  # set once the folder holds the job's identity (.resume)

    @property
    def slices_dir(self) -> Path:
        return self.tmp / SLICES

    def __enter__(self) -> JobWriter:
        _WRITING.add(self.tmp)
        try:
            return self._enter()
        except BaseException:
            _WRITING.discard(self.tmp)
            raise

    def _enter(self) -> JobWriter:
        if self.claim is not None:
            try:  # this process's name: no other export removes it as stale
                os.rename(self.claim, self.tmp)
            except OSError as exc:
                raise DreamPrintError(f"cannot take over the interrupted run's folder: "
                                      f"{exc.strerror or exc}", self.claim) from None
            (self.tmp / CANCEL_MARKER).unlink(missing_ok=True)
            _remove_temporaries(self.tmp)
        _remove_stale_partials(self.target)
        try:
            self.slices_dir.mkdir(parents=True, exist_ok=self.claim is not None)
        except OSError as exc:
            shutil.rmtree(self.tmp, ignore_errors=True)
            raise disk_error(exc, self.tmp) from None
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        kept = False
        try:
            if not self.committed:
                kept = self.keeps_on(exc)
                if kept:
                    (self.tmp / CANCEL_MARKER).unlink(missing_ok=True)  # for --resume
                else:
                    self.abort()
        finally:
            _WRITING.discard(self.tmp)
        if isinstance(exc, OSError) and not isinstance(exc, FileNotFoundError | FileExistsError):
            raise disk_error(exc, self.target, kept) from exc

    def keeps_on(self, exc: BaseException | None) -> bool:
        """Whether the folder stays for ``--resume`` after ``exc``: a resumable job that has
        finished slabs keeps them on anything but a cancel (an interruption, a lost cluster, a
        full disk, an error); a cancel, or a folder with nothing finished, is removed."""
        if not self.resumable or isinstance(exc, JobCancelled | GeneratorExit):
            return False
        return any((self.tmp / SLABS).glob("*.json"))

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
            _remove_temporaries(self.tmp)
            shutil.rmtree(self.tmp / SLABS, ignore_errors=True)  # .resume's records
            (self.tmp / IDENTITY).unlink(missing_ok=True)
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
