"""Load Mitsuba 3 with the variant the proof renders with: which one, and why.

Defines :func:`load_mitsuba` (import ``mitsuba``, select a variant, say which and why),
:func:`requested_variant` (the variant asked for: the caller's, else ``$DREAMPRINT_MITSUBA``,
else :data:`DEFAULT_VARIANT`) and :func:`find_libllvm` (which LLVM shared library Dr.Jit's
LLVM backend is given). Every Mitsuba render of the product (print proof, chart proof, thick
patches) asks this module, so one place decides.

The default is ``llvm_ad_rgb`` (JIT-compiled, vectorised, multi-core); ``DREAMPRINT_MITSUBA=
scalar`` (or ``prefer="scalar"``) takes ``scalar_rgb``: one path at a time per thread of
Dr.Jit's pool (all cores), the same integrator and scene (the same images in expectation, other
random streams), no LLVM and nothing compiled. Measured at the proof's settings (256 px, 64 spp,
one view; ``benchmarks/bench_proof.py --variant``, ``docs/proof-measurements.md`` 2026-12-02)
the scalar variant is not faster: 4-42 % more CPU seconds per view on the demo, the knight and
the smoke, although an LLVM wavefront waits for its longest lane; it is faster on small images
(128 px, where the LLVM variant's cost per render that does not grow with the image weighs
more), and it compiles nothing where the LLVM variant compiles a scene's kernels once (tens of
seconds, then kept in ``~/.drjit``).
Two closed-form tests of the print render miss by about 2 % (low) with the scalar variant at
their seed (``docs/proof-measurements.md``): not settled, so it stays the fallback.
Nothing in the product differentiates a render (compensation iterates proofs,
``proof/compensate.py``): the ``_ad_`` of ``llvm_ad_rgb`` is not what it is chosen for.

The LLVM variant loads LLVM's C API from a shared library at run time; Dr.Jit
takes its path from ``DRJIT_LIBLLVM_PATH``, set here before the import when the operator has
not set it. Measured (``../shared/MEASURED.md``, Dr.Jit 1.5): LLVM 17, 18, 19 and 23 render;
Debian 12's LLVM 14 and 15 abort the process while compiling ("LLVM ERROR: Cannot select ...
fminimum"), so a library whose version is known to be older than :data:`MIN_LLVM` is never
given to Dr.Jit. Looked for, in this order:

1. ``DRJIT_LIBLLVM_PATH`` (the operator's choice, used as given);
2. the desktop bundle's own copy (under ``llvm/`` in a PyInstaller bundle, ``packaging/``);
3. the ``karellen-llvm-core`` wheel (a dependency on Linux x86_64: ``libLLVM.so.23.1`` under
   the environment's ``lib/``);
4. the platform's usual installs, newest first: Linux distribution packages
   (``/usr/lib/*-linux-gnu``, ``/usr/lib/llvm-N``, ``/usr/lib64``), Homebrew's ``llvm`` on
   macOS (``/opt/homebrew/opt/llvm``, ``/usr/local/opt/llvm``, ``llvm@N``) and MacPorts, the
   LLVM Windows installer's ``LLVM-C.dll`` (``%ProgramFiles%\\LLVM\\bin``, or on ``PATH``).

Without one the scalar variant renders, and the note says why and what to install.
"""

from __future__ import annotations

import glob
import os
import re
import sys
import threading
from pathlib import Path
from typing import Any

from dreamprint_gui.core.errors import DreamPrintError

__all__ = ["load_mitsuba", "requested_variant", "find_libllvm", "libllvm_candidates",
           "MIN_LLVM", "INSTALL_HINT", "DEFAULT_VARIANT", "VARIANTS", "VARIANT_ENV",
           "fell_back"]

MIN_LLVM = 17
"""Oldest LLVM major version measured to render with Dr.Jit 1.5 (17.0.6; 14 and 15 abort)."""

INSTALL_HINT = ("pip install karellen-llvm-core on Linux x86_64, Debian's libllvm19, "
                "`brew install llvm` on macOS, the LLVM Windows installer (LLVM-C.dll) on "
                "Windows, or set DRJIT_LIBLLVM_PATH")
VARIANTS = {"scalar": "scalar_rgb", "llvm": "llvm_ad_rgb"}
"""The variants the proof renders with, by the name an operator gives."""
DEFAULT_VARIANT = "llvm"
"""The proof's variant unless asked otherwise: at the proof's settings the scalar one is not
faster (module docstring; ``docs/proof-measurements.md``)."""
VARIANT_ENV = "DREAMPRINT_MITSUBA"
_WHEEL = "karellen-llvm-core"
_LOCK = threading.Lock()
_STATE: dict[str, Any] = {}


def llvm_major(path: str | Path) -> int | None:
    """LLVM major version a library's path states (``libLLVM.so.19.1``, ``libLLVM-17.so``,
    ``.../llvm@19/lib/libLLVM.dylib``, ``.../Cellar/llvm/21.1.8/...``), else None."""
    p = Path(path)
    try:
        real = p.resolve()
    except OSError:
        real = p
    names = [real.name, p.name]  # a link's own name may carry only the ABI number
    parts = [*p.parts, *real.parts]
    for n in names:
        m = re.match(r"libLLVM(?:-|\.so\.|\.)(\d+)", n)
        if m:
            return int(m.group(1))
    for part in reversed(parts):
        m = re.fullmatch(r"(?:llvm[@-](\d+)(?:\.\d+)*|(\d+)\.\d+\.\d+(?:_\d+)?)", part)
        if m:
            return int(m.group(1) or m.group(2))
    return None


def _wheel_library() -> list[tuple[Path, int | None]]:
    from importlib import metadata

    try:
        dist = metadata.distribution(_WHEEL)
    except metadata.PackageNotFoundError:
        return []
    major = int(dist.version.split(".")[0])
    out = []
    for f in dist.files or ():
        if re.fullmatch(r"libLLVM\.so\.\d+\.\d+|libLLVM\.dylib|LLVM-C\.dll", Path(str(f)).name):
            out.append((Path(str(dist.locate_file(f))).resolve(), major))
    return out


def _system_libraries() -> list[str]:
    if sys.platform.startswith("linux"):
        pats = ["/usr/lib/*-linux-gnu/libLLVM*.so*", "/usr/lib/llvm-*/lib/libLLVM*.so*",
                "/usr/lib64/libLLVM*.so*", "/usr/lib/libLLVM*.so*",
                "/usr/lib/wsl/lib/libLLVM*.so*"]
    elif sys.platform == "darwin":
        pats = [f"{root}/opt/{f}/lib/libLLVM.dylib" for root in ("/opt/homebrew", "/usr/local")
                for f in ("llvm", "llvm@*")] + ["/opt/local/libexec/llvm-*/lib/libLLVM.dylib"]
    elif sys.platform == "win32":
        roots = [os.environ.get(v) for v in ("ProgramFiles", "ProgramW6432", "ProgramFiles(x86)")]
        pats = [str(Path(r) / "LLVM" / "bin" / "LLVM-C.dll") for r in roots if r]
        pats += [str(Path(d) / "LLVM-C.dll") for d in os.environ.get("PATH", "").split(os.pathsep)
                 if d]
    else:
        pats = []
    seen: dict[str, None] = {}
    for pat in pats:
        for f in sorted(glob.glob(pat)):
            if Path(f).is_file():
                seen.setdefault(f, None)
    return list(seen)


def libllvm_candidates() -> list[tuple[Path, int | None, str]]:
    """Every LLVM library found, as ``(path, major version or None, where)`` in the order they
    are tried (bundle, wheel, then the system's, newest version first)."""
    out: list[tuple[Path, int | None, str]] = []
    if hasattr(sys, "_MEIPASS"):
        for f in sorted((Path(sys._MEIPASS) / "llvm").rglob("*")):
            if re.fullmatch(r"libLLVM\.so\.\d+\.\d+|libLLVM\.dylib|LLVM-C\.dll", f.name):
                out.append((f, llvm_major(f), "the bundle"))
    out += [(p, v, f"the {_WHEEL} wheel") for p, v in _wheel_library()]
    system = [(Path(f), llvm_major(f), "the system") for f in _system_libraries()]
    system.sort(key=lambda c: -(c[1] if c[1] is not None else MIN_LLVM - 0.5))
    return out + system


def find_libllvm() -> tuple[str | None, str]:
    """``(library path or None, why)``: the library Dr.Jit's LLVM backend gets.

    ``DRJIT_LIBLLVM_PATH`` wins when it names a file (None when it names none: the operator
    asked for that library). Otherwise the first candidate whose version is unknown or at
    least :data:`MIN_LLVM`; it is put into ``DRJIT_LIBLLVM_PATH`` for Dr.Jit.
    """
    env = os.environ.get("DRJIT_LIBLLVM_PATH")
    if env:
        if Path(env).is_file():
            return env, "DRJIT_LIBLLVM_PATH"
        return None, f"DRJIT_LIBLLVM_PATH names no file ({env})"
    too_old = []
    for path, major, where in libllvm_candidates():
        if major is not None and major < MIN_LLVM:
            too_old.append(f"{path.name} ({major})")
            continue
        os.environ["DRJIT_LIBLLVM_PATH"] = str(path)
        return str(path), where
    if too_old:
        return None, (f"only LLVM older than {MIN_LLVM} found ({', '.join(too_old)}), which "
                      "aborts Dr.Jit")
    return None, "no LLVM library found"


def requested_variant(prefer: str | None = None) -> str:
    """The variant asked for, ``"scalar"`` or ``"llvm"`` (:data:`VARIANTS`): ``prefer``, else
    ``$DREAMPRINT_MITSUBA``, else :data:`DEFAULT_VARIANT`. One line naming the setting when it
    is neither."""
    name = prefer if prefer is not None else os.environ.get(VARIANT_ENV) or DEFAULT_VARIANT
    if name not in VARIANTS:
        where = "the variant" if prefer is not None else VARIANT_ENV
        raise DreamPrintError(f"{where} must be {' or '.join(VARIANTS)}, not '{name}'")
    return name


def load_mitsuba(prefer: str | None = None) -> tuple[Any, str, str]:
    """Import Mitsuba and select a variant; returns ``(mitsuba module, variant, note)``.

    The variant asked for (:func:`requested_variant`): ``"scalar"`` takes ``scalar_rgb``;
    ``"llvm"`` takes ``llvm_ad_rgb`` when :func:`find_libllvm` finds a library and Dr.Jit's
    LLVM backend starts with it, else ``scalar_rgb`` with a note saying why and what to
    install. The first variant chosen in a process stays (Mitsuba's variant is process-wide).
    """
    with _LOCK:
        if "mi" in _STATE:
            return _STATE["mi"], _STATE["variant"], _STATE["note"]
        asked = requested_variant(prefer)
        llvm, why = find_libllvm() if asked == "llvm" else (None, "")
        try:
            import drjit as dr
            import mitsuba as mi
        except ImportError as exc:
            raise DreamPrintError(f"the print proof needs Mitsuba 3 (pip install mitsuba): "
                                  f"{exc}") from None
        variant = "scalar_rgb"
        if llvm is not None and "llvm_ad_rgb" in mi.variants():
            if dr.has_backend(dr.JitBackend.LLVM):
                variant = "llvm_ad_rgb"
                note = f"Mitsuba {mi.__version__} llvm_ad_rgb (libLLVM {llvm}, from {why})"
            else:
                note = (f"Mitsuba {mi.__version__} scalar_rgb: Dr.Jit could not start its LLVM "
                        f"backend with {llvm} ({why}). For the LLVM variant install: "
                        f"{INSTALL_HINT}")
        elif asked == "llvm":
            note = (f"Mitsuba {mi.__version__} scalar_rgb: {why}. For the LLVM variant "
                    f"install: {INSTALL_HINT}")
        else:
            note = (f"Mitsuba {mi.__version__} scalar_rgb ({VARIANT_ENV}=scalar), "
                    f"{dr.thread_count()} threads")
        mi.set_variant(variant)
        _STATE.update(mi=mi, variant=variant, note=note, requested=VARIANTS[asked])
        return mi, variant, note


def fell_back() -> bool:
    """Whether the loaded variant is not the one asked for (LLVM asked, no usable libLLVM):
    the note then says what to install."""
    return "mi" in _STATE and _STATE["variant"] != _STATE["requested"]
