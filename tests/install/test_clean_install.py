"""A clean install: ``pip install`` of the package into a fresh virtual environment that cannot
see the system's site-packages, then ``dreamprint inspect`` on one file of every volume format
the README lists (one process calling the installed entry point per file), a small ``convert``
and a small ``proof`` (Mitsuba's LLVM variant from pip's libLLVM where the platform has the
wheel, and its scalar variant).

Marked ``clean_install`` (``pytest -m clean_install`` runs only these, ``-m "not
clean_install"`` skips them). The package is installed from a copy of what a source
distribution holds (pyproject, README, the package, resources/), not in editable mode, so a
missing dependency or a file left out of the installed package fails here. pip reuses its
wheel cache; ``--no-compile`` skips byte-compiling what it installs (the commands compile what
they import).
"""

from __future__ import annotations

import importlib.util
import json
import os
import platform
import shutil
import subprocess
import sys
import time
import tomllib
import zipfile
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
TESTS = ROOT / "tests"
pytestmark = pytest.mark.clean_install



def _module(rel: str):
    """A writer module of the volume tests (their generators write the generated rows)."""
    path = TESTS / rel
    spec = importlib.util.spec_from_file_location(f"_clean_install_{path.stem}", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _write_samples(out: Path, shared: Path) -> dict[str, Path]:
    """One file of every format, from ../shared/data or written by the tests' own writers."""
    files = {
        "openvdb": shared / "volumes" / "blender_mantaflow_fluid_data_0190.vdb",
        "nanovdb": TESTS / "data" / "volumes" / "blender_mantaflow_density_zip.nvdb",
        "vti": shared / "volumes" / "hydrogen.vti",
        "legacy_vtk": shared / "volumes" / "ironProt.vtk",
        "metaimage": shared / "volumes" / "HeadMRVolume.mhd",
        "inria_ply": shared / "splats" / "inria3dgs_iter7000_sh3_9080.ply",
        "vox": shared / "voxels" / "magicavoxel_chr_knight.vox",
    }
    rng = np.random.default_rng(0)
    vals = rng.random((6, 7, 8)).astype("<f4")
    head = ("NRRD0005\ntype: float\ndimension: 3\nsizes: 8 7 6\nspacings: 0.5 0.5 1\n"
            "endian: little\nencoding: gzip\n")
    import gzip

    (out / "a.nrrd").write_bytes((head + "\n").encode() + gzip.compress(vals.tobytes()))
    files["nrrd"] = out / "a.nrrd"
    (out / "b.raw").write_bytes(vals.tobytes())
    (out / "b.nhdr").write_text(head.replace("gzip", "raw") + "data file: b.raw\n")
    files["nhdr"] = out / "b.nhdr"

    sigma = np.zeros((6, 7, 8), np.float32)
    sigma[1:5, 2:6, 2:7] = 5.0
    rgb = np.broadcast_to(np.float32([0.8, 0.3, 0.1]), sigma.shape + (3,))
    np.savez_compressed(out / "r.npz", sigma=sigma, rgb=rgb,
                        bounds=np.array([[0.0, 0, 0], [1.0, 1, 1]]))
    files["radiance_npz"] = out / "r.npz"
    rv = _module("io/volumes/test_volumes_radiance_vox.py")
    (out / "exr").mkdir()
    for k in range(4):
        rv._write_exr(out / "exr" / f"slice_{k}.exr", sigma[k], np.asarray(rgb[k]))
    files["radiance_exr"] = out / "exr"

    sf = _module("io/volumes/test_splat_formats.py")
    k = sf._known()
    sf.write_splat(files.setdefault("splat", out / "a.splat"), *k)
    sf.write_ksplat(files.setdefault("ksplat", out / "a.ksplat"), *k, 1)
    sf.write_spz(files.setdefault("spz", out / "a.spz"), 4, *k)
    sog, _ = sf.sog_files(*k)
    with zipfile.ZipFile(files.setdefault("sog", out / "a.sog"), "w") as z:
        for name, data in sog.items():
            z.writestr(name, data)
    sf.write_nerfstudio_ply(files.setdefault("nerfstudio_ply", out / "ns.ply"), *k, 9)
    import gsply

    gsply.plywrite(files.setdefault("compressed_ply", out / "c.compressed.ply"),
                   gsply.plyread(files["inria_ply"]), compressed=True)

    ng = _module("io/volumes/test_volumes_ingp.py")
    cfg = ng.make_config(n_levels=2, n_feat=2, log2_t=10)
    dm, rm, levels = ng.param_shapes(cfg)
    table = np.full((sum(n for *_, n, _h in levels), 2), 0.5, np.float32)
    d0 = np.zeros(dm[0], np.float32)
    d0[0, 0] = 1.0
    d1 = np.zeros(dm[1], np.float32)
    d1[0, 0] = 4.0
    files["ingp_snapshot"] = ng.write_snapshot(out / "s.ingp", cfg, [d0, d1],
                                               [np.zeros(s, np.float32) for s in rm], table)
    ex = _module("io/volumes/test_volumes_ingp_export.py")
    files["ingp_png_slices"] = ex.write_png_sequence(out / "rgba_slices", sigma * 20,
                                                     np.asarray(rgb))
    files["ingp_raw"] = ex.write_raw(out / "volume_raw", sigma, np.asarray(rgb))
    return files


# format: (what `inspect --json` calls it, a substring), a row per format the README lists
ROWS = {
    "openvdb": "OpenVDB", "nanovdb": "NanoVDB", "vti": "VTK", "legacy_vtk": "VTK",
    "metaimage": "MetaImage", "nrrd": "NRRD", "nhdr": "NRRD", "radiance_npz": "radiance",
    "radiance_exr": "EXR", "inria_ply": "splats", "nerfstudio_ply": "splats",
    "compressed_ply": "compressed", "spz": "SPZ", "splat": "splats", "ksplat": "splats",
    "sog": "SOG", "vox": "MagicaVoxel", "ingp_snapshot": "InstantNGP",
    "ingp_png_slices": "InstantNGP RGBA PNG", "ingp_raw": "InstantNGP",
}


def _pip_install(venv: Path, src: Path) -> None:
    py = venv / "bin" / "python"
    cmd = [str(py), "-m", "pip", "install", "--disable-pip-version-check", "--no-compile",
           "--progress-bar", "off", "-q", str(src)]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=1500)
    assert r.returncode == 0, f"pip install failed:\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"


@pytest.fixture(scope="session")
def clean_env(tmp_path_factory, shared_data):
    """(dreamprint command, environment, sample files, seconds taken to install)."""
    if sys.platform == "win32":
        pytest.skip("the venv layout below is POSIX's")
    base = tmp_path_factory.mktemp("clean_install")
    src = base / "src"
    src.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, src / name)
    for name in ("dreamprint_gui", "resources"):
        shutil.copytree(ROOT / name, src / name,
                        ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    venv = base / "venv"
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, timeout=300)
    cfg = (venv / "pyvenv.cfg").read_text()
    assert "include-system-site-packages = false" in cfg
    _pip_install(venv, src)
    seconds = time.perf_counter() - t0
    samples = base / "samples"
    samples.mkdir()
    files = _write_samples(samples, shared_data)
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "DRJIT_LIBLLVM_PATH", "VIRTUAL_ENV", "PYTHONHOME")}
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    # numba's cache of this install's kernels, kept with the install: the installed sources'
    # paths are new every session, so nothing in the user's cache would ever serve them again
    # (the package honours a NUMBA_CACHE_DIR it is given, dreamprint_gui/__init__.py)
    env["NUMBA_CACHE_DIR"] = str(base / "numba-cache")
    return venv / "bin" / "dreamprint", env, files, seconds, base


def _run(clean_env, *args, timeout=600):
    exe, env, *_ = clean_env
    return subprocess.run([str(exe), *map(str, args)], capture_output=True, text=True, env=env,
                          cwd=clean_env[4], timeout=timeout)


def test_the_environment_is_isolated(clean_env):
    """The installed package is the copy's, not the checkout's; the system's site-packages and
    the development environment are out of sight."""
    exe, env, _, seconds, base = clean_env
    probe = ("import sys, dreamprint_gui, numpy; print(dreamprint_gui.__file__); "
             "print(numpy.__file__); print(sys.flags.no_site, sys.path)")
    r = subprocess.run([str(exe.parent / "python"), "-c", probe], capture_output=True,
                       text=True, env=env, cwd=base, timeout=300)
    assert r.returncode == 0, r.stderr
    pkg, np_file, _ = r.stdout.splitlines()
    venv = str(exe.parent.parent)
    assert pkg.startswith(venv) and np_file.startswith(venv), r.stdout
    assert "dist-packages" not in r.stdout and str(ROOT) not in r.stdout
    print(f"fresh venv + pip install: {seconds:.0f} s")


# One process inspects every format: the installed ``dreamprint`` entry point (found through
# the distribution's metadata, as the console script finds it) called once per file, each
# call's output and errors kept apart. A process per file paid Python's start, the package's
# imports and numba's cache loads twenty times over.
_INSPECT_ALL = """
import contextlib, io, json, sys, traceback
from importlib.metadata import entry_points

(main,) = [e.load() for e in entry_points(group="console_scripts", name="dreamprint")]
results = {}
for fmt, path in json.loads(sys.argv[1]).items():
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(["inspect", "--json", path])
        except BaseException:  # noqa: BLE001 - reported per format
            code = -1
            traceback.print_exc()
    results[fmt] = {"returncode": code, "stdout": out.getvalue(), "stderr": err.getvalue()}
with open(sys.argv[2], "w") as f:
    json.dump(results, f)
"""


@pytest.fixture(scope="module")
def inspected(clean_env) -> dict[str, dict]:
    """Per format, what ``dreamprint inspect --json FILE`` returned, printed and said."""
    exe, env, files, _, base = clean_env
    arg = json.dumps({fmt: str(files[fmt]) for fmt in ROWS})
    report = base / "inspected.json"
    r = subprocess.run([str(exe.parent / "python"), "-c", _INSPECT_ALL, arg, str(report)],
                       capture_output=True, text=True, env=env, cwd=base, timeout=1200)
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(report.read_text())


@pytest.mark.parametrize("fmt", ROWS)
def test_inspect_every_format(inspected, fmt):
    r = inspected[fmt]
    assert r["returncode"] == 0, r["stderr"]
    assert r["stderr"] == "" or "Traceback" not in r["stderr"]
    info = json.loads(r["stdout"])
    assert ROWS[fmt].lower() in info["format"].lower(), info["format"]
    # what the file holds: grids, Gaussians, or (a NeRF snapshot) its networks
    assert info.get("grids") or info.get("gaussians") or info.get("density_network"), info


def _convert(clean_env, src, tmp_path):
    job = tmp_path / "job"
    r = _run(clean_env, "convert", src, "-o", job, "--height-mm", "2", "--table-size", "17",
             "--seed", "1", "--quiet", "--json")
    assert r.returncode == 0, r.stderr
    m = json.loads((job / "manifest.json").read_text())
    nx, ny, nz = m["grid_dimensions"]
    assert sum(m["voxel_counts"].values()) == nx * ny * nz and nz > 0
    assert len(list((job / "slices").glob("*.png"))) == nz
    inked = sum(v for k, v in m["voxel_counts"].items() if k not in ("Cl", "empty"))
    assert inked > 0
    return m


def test_convert_a_voxel_model(clean_env, tmp_path):
    _convert(clean_env, clean_env[2]["vox"], tmp_path)


def test_convert_the_openvdb_sample(clean_env, tmp_path):
    _convert(clean_env, clean_env[2]["openvdb"], tmp_path)


@pytest.mark.parametrize("variant", ["", "scalar"])
def test_proof_renders_from_pip_alone(clean_env, tmp_path, variant):
    """The print proof renders; by default, where pip provides a libLLVM (Linux x86_64), with
    Mitsuba's LLVM variant on it; asked for (DREAMPRINT_MITSUBA=scalar), with the scalar
    one."""
    exe, env, *_ = clean_env
    env = {**env, "DREAMPRINT_MITSUBA": variant}       # "": the default
    r = subprocess.run([str(exe), "proof", str(clean_env[2]["vox"]), "-o", str(tmp_path / "p"),
                        "--height-mm", "3", "--views", "1", "--resolution", "24", "--spp", "2",
                        "--json"], capture_output=True, text=True, env=env, cwd=clean_env[4],
                       timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    proof = json.loads((tmp_path / "p" / "proof.json").read_text())
    renderer = proof["renderer"]
    if variant == "scalar":
        assert renderer["variant"] == "scalar_rgb" and not renderer["fallback"], renderer
    elif sys.platform.startswith("linux") and platform.machine() == "x86_64":
        assert renderer["variant"] == "llvm_ad_rgb", renderer
        assert "karellen-llvm-core wheel" in renderer["note"], renderer


def test_data_files_list_every_resource_folder():
    """The installed package finds resources/ under <prefix>/share/dreamprint/resources: every
    folder of resources/ that holds files is listed in pyproject's data-files."""
    listed = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"][
        "data-files"]
    folders = {p.parent.relative_to(ROOT).as_posix() for p in (ROOT / "resources").rglob("*")
               if p.is_file()}
    assert {f"share/dreamprint/{f}" for f in folders} == set(listed)
    for dest, globs in listed.items():
        assert globs == [dest.removeprefix("share/dreamprint/") + "/*"], dest
