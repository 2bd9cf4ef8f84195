"""DreamPrint: volumetric radiance content to per-voxel PolyJet material labels."""

import os as _os
from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("dreamprint")
except PackageNotFoundError:  # running from a source tree that was not installed
    __version__ = "0.0.0+unknown"


def _numba_cache_dir() -> str:
    """A numba cache folder keyed on the package's source.

    numba's ``cache=True`` invalidates a cached kernel only when the kernel's *own* file changes;
    a kernel that inlined a function from another module keeps its stale machine code after that
    module changes (it happened here: wrong labels until the cache was deleted). Keying the folder
    on a hash of every layer's sources below cli/ and gui/ (where the kernels live) makes any
    change there, or an upgrade, compile afresh.
    """
    import hashlib
    from pathlib import Path

    from platformdirs import user_cache_path

    root = Path(__file__).resolve().parent
    digest = hashlib.sha256(__version__.encode())
    # Only the layers that hold compiled kernels: a GUI or CLI edit need not recompile them.
    layers = ("core", "physics", "io", "gamut", "job", "proof")
    for path in sorted(p for layer in layers for p in (root / layer).rglob("*.py")):
        digest.update(path.relative_to(root).as_posix().encode())
        digest.update(path.read_bytes())
    return str(user_cache_path("dreamprint") / "numba" / digest.hexdigest()[:16])


def _numba_cpu_features() -> str | None:
    """The CPU features numba compiles for where the CPU has AVX-512: the host's own (what
    numba would use), with LLVM's ``prefer-256-bit`` tuning turned off; else None.

    LLVM keeps to 256-bit vectors on Intel's AVX-512 CPUs unless told otherwise (the tuning of
    Skylake-X and later: 512-bit instructions once slowed the clock), so the kernels written
    for its loop vectoriser ran 8 float32 lanes where the CPU has 16. Turned off, the job's
    labelling takes 512-bit vectors (``benchmarks/bench_label_passes.py``: the demo 21.7 ->
    19.7 ns per foreground voxel, MetaImage 12.7 -> 11.1, ``Cd`` 21.3 -> 18.7). The width
    changes no result: the kernels use no fast-math except InstantNGP's networks, so every
    operation rounds as before (``benchmarks/job_hashes.py --check``: all the same).
    """
    import platform

    if platform.machine().lower() not in ("x86_64", "amd64"):
        return None
    import llvmlite.binding as llvm

    try:
        features = llvm.get_host_cpu_features()
    except RuntimeError:  # LLVM cannot read this CPU's features: leave numba to decide
        return None
    if not features.get("avx512f", False):
        return None
    return features.flatten() + ",-prefer-256-bit"


# Must be set before numba is first imported (it reads its configuration then).
if "NUMBA_CACHE_DIR" not in _os.environ:
    _os.environ["NUMBA_CACHE_DIR"] = _numba_cache_dir()
# A user's own choice of CPU, features or no AVX is kept.
if not {"NUMBA_CPU_NAME", "NUMBA_CPU_FEATURES", "NUMBA_ENABLE_AVX"} & _os.environ.keys():
    _FEATURES = _numba_cpu_features()
    if _FEATURES is not None:
        _os.environ["NUMBA_CPU_FEATURES"] = _FEATURES
        import sys as _sys

        if "numba" in _sys.modules:  # imported first (a script, a notebook): read it again
            from numba.core import config as _numba_config

            _numba_config.reload_config()
