"""Load Mitsuba 3 with a CPU LLVM variant when the machine has a usable libLLVM.

Defines :func:`load_mitsuba`: import ``mitsuba``, select a variant and say which and why.

Mitsuba's LLVM (JIT, vectorised, multi-core) variants need a recent libLLVM: with Debian 12's
default libLLVM 14/15, rendering aborts ("LLVM ERROR: Cannot select ... fminimum"); with
Debian's ``libllvm19`` it works (``../shared/MEASURED.md``). Dr.Jit finds the library through
``DRJIT_LIBLLVM_PATH``, which is set here (before the import) when the operator has not set it
and the Debian file exists. Without it the scalar variant renders the same images (same
integrator, same scene) one path at a time, much more slowly; the note says so.
"""

from __future__ import annotations

import os
import threading
from pathlib import Path
from typing import Any

from dreamprint_gui.core.errors import DreamPrintError

__all__ = ["load_mitsuba", "LIBLLVM_CANDIDATES"]

LIBLLVM_CANDIDATES = (
    "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1",
    "/usr/lib/aarch64-linux-gnu/libLLVM.so.19.1",
    "/usr/lib/llvm-19/lib/libLLVM.so.19.1",
)
_LOCK = threading.Lock()
_STATE: dict[str, Any] = {}


def _llvm_path() -> str | None:
    env = os.environ.get("DRJIT_LIBLLVM_PATH")
    if env:
        return env if Path(env).is_file() else None
    for cand in LIBLLVM_CANDIDATES:
        if Path(cand).is_file():
            os.environ["DRJIT_LIBLLVM_PATH"] = cand
            return cand
    return None


def load_mitsuba(prefer: str = "llvm") -> tuple[Any, str, str]:
    """Import Mitsuba and select a variant; returns ``(mitsuba module, variant, note)``.

    ``prefer="llvm"`` takes ``llvm_ad_rgb`` when libLLVM 19 is present (else ``scalar_rgb``,
    with a note saying why and how to fix it); ``prefer="scalar"`` always takes ``scalar_rgb``.
    The first variant chosen in a process stays (Mitsuba's variant is process-wide).
    """
    with _LOCK:
        if "mi" in _STATE:
            return _STATE["mi"], _STATE["variant"], _STATE["note"]
        llvm = _llvm_path() if prefer == "llvm" else None
        try:
            import mitsuba as mi
        except ImportError as exc:
            raise DreamPrintError(f"the print proof needs Mitsuba 3 (pip install mitsuba): "
                                  f"{exc}") from None
        note = ""
        variant = "scalar_rgb"
        if llvm is not None and "llvm_ad_rgb" in mi.variants():
            variant = "llvm_ad_rgb"
            note = f"Mitsuba {mi.__version__} llvm_ad_rgb (libLLVM {llvm})"
        elif prefer == "llvm":
            note = (f"Mitsuba {mi.__version__} scalar_rgb: no libLLVM 19 found (install "
                    "Debian's libllvm19 or set DRJIT_LIBLLVM_PATH); rendering is much slower")
        else:
            note = f"Mitsuba {mi.__version__} scalar_rgb"
        mi.set_variant(variant)
        _STATE.update(mi=mi, variant=variant, note=note)
        return mi, variant, note
