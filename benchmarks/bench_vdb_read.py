"""Reading and densifying a .vdb: the in-process reader (io/volumes/vdb/vdb_file.py) against the
former Debian helper process (python3-openvdb under /usr/bin/python3), whole process and in
process.

For each file, each code version runs in a fresh interpreter ``open_source(FILE)`` then the
density grid's dense copy (``LeafGridPlan.dense``, what a print job makes first); printed:
the wall time of the whole process (interpreter start, imports, read, densify), the time of
read + densify measured inside it and its two parts (``open_source``: for the old code the
helper process; the dense copy: numba's cached kernels loaded, then run), and the imports;
each the least of ``--repeat`` runs after one warm-up run (numba's cache filled): on a
shared, loaded machine the least is the figure least disturbed by the other processes.
The old code is the package at ``--old-rev`` (default: the last
commit that had the helper), extracted with ``git archive``: once with its transfer cache
off (``DREAMPRINT_VDB_CACHE=0``: every run starts the helper, as a first opening does) and once
with the cache filled by the warm-up run (a second opening of the same file).

Files: the Blender sample (``--files`` to choose), the benchmark cloud (320 x 256 x 288, half
floats, :mod:`bench_sources`) and a 200^3 smoke-like fog volume (blosc, float) written here
with pyopenvdb.

    python benchmarks/bench_vdb_read.py --repeat 3
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tarfile
import tempfile
import textwrap
import time
from io import BytesIO
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_sources import DATA, shared_data, source_path  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
HELPER = "dreamprint_gui/io/volumes/_vdb_helper.py"

RUN = textwrap.dedent("""
    import sys, time
    t0 = time.perf_counter()
    from dreamprint_gui.io.volumes import open_source
    t1 = time.perf_counter()
    s = open_source(sys.argv[1])
    t2 = time.perf_counter()
    d = s._leaf_plan.dense()
    t3 = time.perf_counter()
    print(t1 - t0, t2 - t1, t3 - t2, 0 if d is None else d[0].size)
""")

WRITE_SMOKE = textwrap.dedent("""
    import sys
    import numpy as np
    import pyopenvdb as vdb
    n = 200
    z, y, x = np.meshgrid(*(np.linspace(-1, 1, n, dtype=np.float32),) * 3, indexing="ij")
    rng = np.random.default_rng(1)
    plume = np.exp(-((x / 0.35) ** 2 + (y / 0.35) ** 2)) * (0.5 + 0.5 * z)
    noise = rng.random((n // 8,) * 3).astype(np.float32).repeat(8, 0).repeat(8, 1).repeat(8, 2)
    a = np.maximum(plume * (0.6 + 0.4 * noise) - 0.05, 0).astype(np.float32)
    g = vdb.FloatGrid()
    g.copyFromArray(np.ascontiguousarray(a.transpose(2, 1, 0)), (0, 0, 0), 0.0)
    g.name = "density"
    g.gridClass = vdb.GridClass.FOG_VOLUME
    g.transform = vdb.createLinearTransform(voxelSize=0.01)
    vdb.write(sys.argv[1], [g])
""")


def _smoke() -> Path:
    out = DATA / "smoke_200.vdb"
    if not out.exists():
        DATA.mkdir(exist_ok=True)
        script = DATA / "write_smoke.py"
        script.write_text(WRITE_SMOKE)
        py = os.environ.get("DREAMPRINT_TEST_OPENVDB_PYTHON", "/usr/bin/python3")
        subprocess.run([py, "-I", str(script), str(out)], check=True)
    return out


def _old_tree(rev: str | None) -> Path:
    if rev is None:
        gone = subprocess.run(["git", "-C", str(ROOT), "rev-list", "-n", "1", "HEAD", "--",
                               HELPER], capture_output=True, text=True, check=True).stdout
        rev = gone.strip() + "^"
    data = subprocess.run(["git", "-C", str(ROOT), "archive", rev, "dreamprint_gui"],
                          capture_output=True, check=True).stdout
    out = Path(tempfile.mkdtemp(prefix="dp-old-"))
    with tarfile.open(fileobj=BytesIO(data)) as t:
        t.extractall(out, filter="data")
    return out


def _run(tree: Path, f: str, cache: str = "0") -> tuple[float, float, float, float, int]:
    env = dict(os.environ, PYTHONPATH=str(tree), DREAMPRINT_VDB_CACHE=cache)
    t = time.perf_counter()
    # cwd=tree: ``python -c`` puts the working folder first on sys.path
    r = subprocess.run([sys.executable, "-c", RUN, f], env=env, capture_output=True,
                       text=True, check=False, cwd=str(tree))
    wall = time.perf_counter() - t
    if r.returncode:
        raise SystemExit(f"{tree}: {f}: {r.stderr.strip()[-2000:]}")
    imp, read, dense, n = r.stdout.split()
    return wall, float(imp), float(read), float(dense), int(n)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--old-rev", default=None)
    ap.add_argument("--files", default=None, help="comma-separated .vdb files")
    a = ap.parse_args()
    files = a.files.split(",") if a.files else [
        str(shared_data() / "volumes" / "blender_mantaflow_fluid_data_0190.vdb"),
        source_path("openvdb"), str(_smoke())]
    old = _old_tree(a.old_rev)
    print(f"load {open('/proc/loadavg').read().split()[:3]}")
    print(f"{'file':>36} {'code':>21} {'whole process s':>16} {'read+densify s':>15} "
          f"{'read s':>7} {'densify s':>10} {'imports s':>10} {'dense values':>13}")
    for f in files:
        cache = tempfile.mkdtemp(prefix="dp-vdbcache-")
        for label, tree, c in (("old", old, "0"), ("old, transfer cached", old, cache),
                               ("new", ROOT, "0")):
            _run(tree, f, c)                                # warm-up (numba cache)
            runs = [_run(tree, f, c) for _ in range(a.repeat)]
            best = [min(r[k] for r in runs) for k in range(4)]
            both = min(r[2] + r[3] for r in runs)
            print(f"{Path(f).name[-36:]:>36} {label:>21} {best[0]:16.2f} {both:15.3f} "
                  f"{best[2]:7.3f} {best[3]:10.3f} {best[1]:10.2f} {runs[0][4]:13,}",
                  flush=True)


if __name__ == "__main__":
    main()
