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


# Must be set before numba is first imported (it reads its configuration then).
if "NUMBA_CACHE_DIR" not in _os.environ:
    _os.environ["NUMBA_CACHE_DIR"] = _numba_cache_dir()
