"""A proof's output folder written whole or not at all (the chart proof and the object proof).

:func:`staged_folder` gives a temporary folder beside the target; when the block ends without
an exception the temporary folder replaces the target (an existing one is moved aside first,
then removed), otherwise it is removed and the target is left as it was.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

__all__ = ["staged_folder"]


@contextmanager
def staged_folder(out: Path, tag: str) -> Iterator[Path]:
    """A fresh ``.<name>.<tag>-tmp-<pid>`` folder beside ``out`` that becomes ``out`` when the
    ``with`` block completes (a cancel or an error raised in the block leaves nothing)."""
    parent = out.absolute().parent
    tmp = parent / f".{out.name}.{tag}-tmp-{os.getpid()}"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir()
    try:
        yield tmp
        if out.exists():
            old = parent / f".{out.name}.{tag}-old-{os.getpid()}"
            os.replace(out, old)
            os.replace(tmp, out)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
