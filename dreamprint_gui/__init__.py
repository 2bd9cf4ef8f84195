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


# CPU names numba runs without AVX (numba.core.config's ``avx_default``: AVX slow there, or a
# virtual machine's baseline name next to AVX-512 flags it cannot honour): left to numba.
_NUMBA_NO_AVX = frozenset({"corei7-avx", "core-avx-i", "sandybridge", "ivybridge", "nocona"})


def _numba_cpu_features() -> str | None:
    """The CPU features numba compiles for where the CPU has AVX-512: the host's own, as numba
    reads them, with LLVM's ``prefer-256-bit`` tuning turned off; else None (numba decides).

    LLVM keeps to 256-bit vectors on AVX-512 CPUs whose tuning says so (Intel's from Skylake-X
    on: 512-bit instructions once slowed the clock; this project's VM reports ``rocketlake``),
    so the kernels written for its loop vectoriser ran 8 float32 lanes where the CPU has 16.
    Turned off, the job's labelling takes 512-bit vectors (``benchmarks/bench_label_passes.py``:
    the demo 21.7 -> 19.7 ns per foreground voxel, MetaImage 12.7 -> 11.1, ``Cd`` 21.3 -> 18.7;
    InstantNGP's networks got 3-12 % slower). The width changes no result: the kernels use no
    fast-math except InstantNGP's networks, so every operation rounds as before
    (``benchmarks/job_hashes.py --check``: all the same). Not done where numba runs without
    AVX (:data:`_NUMBA_NO_AVX`) or a ``.numba_config.yaml`` in the working folder configures it.
    """
    import platform
    from pathlib import Path

    if platform.machine().lower() not in ("x86_64", "amd64") or Path(".numba_config.yaml").exists():
        return None
    import llvmlite.binding as llvm

    try:
        if llvm.get_host_cpu_name() in _NUMBA_NO_AVX:
            return None
        features = llvm.get_host_cpu_features()
    except RuntimeError:  # LLVM cannot read this CPU's features: leave numba to decide
        return None
    if not features.get("avx512f", False):
        return None
    return features.flatten() + ",-prefer-256-bit"


def _configure_numba() -> None:
    """numba's cache folder and CPU features, set before numba is first imported (it reads its
    configuration then). A user's own cache folder, choice of CPU, features or no AVX is kept.
    If numba was imported first (a script, a notebook), it reads its configuration again; a
    compiled function defined before this package is imported keeps numba on the settings it
    had (its code generator is made then)."""
    env = _os.environ
    changed = False
    if "NUMBA_CACHE_DIR" not in env:
        env["NUMBA_CACHE_DIR"] = _numba_cache_dir()
        changed = True
    if not {"NUMBA_CPU_NAME", "NUMBA_CPU_FEATURES", "NUMBA_ENABLE_AVX"} & env.keys():
        features = _numba_cpu_features()
        if features is not None:
            env["NUMBA_CPU_FEATURES"] = features
            changed = True
    import sys

    if changed and "numba" in sys.modules:
        from numba.core import config

        config.reload_config()


_configure_numba()
