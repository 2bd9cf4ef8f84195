"""The benchmark's source files, one per source kind: the samples in ``../shared/data`` (or
``DREAMPRINT_SAMPLE_DATA``) and files generated at realistic sizes into ``benchmarks/.data/``
(made once, then reused; delete the folder to remake them).

Kinds (:data:`KINDS`): ``demo``; ``openvdb`` (a generated 320 x 256 x 288 fog-volume cloud,
half floats, ~30 % of its leaves active: a smoke simulation's size), ``openvdb-colour`` (the
same with a scene-linear ``Cd`` colour grid) and ``openvdb-manta``
(Blender's Mantaflow sample, 21 x 21 x 32); ``nanovdb`` (the same cloud, float, through
``nanovdb_convert``); ``vtk`` (hydrogen.vti, ironProt.vtk); ``metaimage`` (HeadMRVolume.mhd);
``nrrd`` (ironProt written as NRRD); ``radiance`` (a generated 160^3 RGBA .npz, sRGB) and
``radiance-linear`` (the same grid marked scene-linear); ``inria`` (a generated 1e6-Gaussian
INRIA PLY, SH degree 0, 68 MB) and ``inria-sample`` (the 9k-Gaussian SH3 sample);
``compressed-ply`` and ``spz`` (the 1e6 scene through gsply); ``vox`` (the knight);
``ingp`` (an InstantNGP snapshot shaped like instant-ngp's NeRF defaults, seeded random weights,
an occupancy ball of ~18 % of the cells: ``bench_ingp.write_realistic``).

    python benchmarks/bench_sources.py            # make the generated files, list every kind
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
DATA = HERE / ".data"


def shared_data() -> Path:
    env = os.environ.get("DREAMPRINT_SAMPLE_DATA")
    return Path(env) if env else HERE.parent.parent / "shared" / "data"


def _cloud_field(shape_zyx=(288, 256, 320), seed: int = 3) -> np.ndarray:
    """A smoke-like density (float32, z y x): a coarse random blob field upsampled 8x and cut
    at a threshold, so that most of the box is exactly 0 (empty VDB leaves)."""
    from scipy.ndimage import gaussian_filter, zoom

    rng = np.random.default_rng(seed)
    coarse = rng.random(tuple(s // 8 for s in shape_zyx)).astype(np.float32)
    coarse = gaussian_filter(coarse, 1.2)
    z, y, x = np.meshgrid(*(np.linspace(-1, 1, s) for s in coarse.shape), indexing="ij")
    coarse *= np.exp(-1.5 * (x * x + y * y + z * z)).astype(np.float32)
    f = zoom(coarse, 8, order=1).astype(np.float32)
    thr = np.quantile(f, 0.8)
    return np.maximum(f - thr, 0).astype(np.float32) * np.float32(40.0)


_WRITE_VDB = textwrap.dedent("""
    import sys
    import numpy as np
    import pyopenvdb as vdb
    a = np.load(sys.argv[1])              # (z, y, x)

    def density(half):
        g = vdb.FloatGrid()
        g.copyFromArray(np.ascontiguousarray(a.transpose(2, 1, 0)), (0, 0, 0), 0.0)
        g.name = "density"
        g.gridClass = vdb.GridClass.FOG_VOLUME
        g.saveFloatAsHalf = half
        g.transform = vdb.createLinearTransform(voxelSize=0.01)
        return g

    for out, half in ((sys.argv[2], True), (sys.argv[3], False)):
        vdb.write(out, [density(half)])
    # a scene-linear colour grid where there is smoke (Cd, as Houdini writes it)
    i, j, k = np.meshgrid(*(np.linspace(0, 1, n, dtype=np.float32) for n in a.shape[::-1]),
                          indexing="ij")
    cd = np.stack([0.1 + 0.8 * i, 0.6 * j * (1 - i), 0.9 - 0.7 * k], -1).astype(np.float32)
    cd[a.transpose(2, 1, 0) <= 0] = 0.0
    c = vdb.Vec3SGrid()
    c.copyFromArray(cd, (0, 0, 0), (0.0, 0.0, 0.0))
    c.name = "Cd"
    c.transform = vdb.createLinearTransform(voxelSize=0.01)
    vdb.write(sys.argv[4], [density(True), c])
""")


def _openvdb_python() -> str:
    """An interpreter with pyopenvdb to write the benchmark's .vdb files (Debian's
    python3-openvdb; DREAMPRINT_TEST_OPENVDB_PYTHON to choose another). The product reads
    them without it."""
    return os.environ.get("DREAMPRINT_TEST_OPENVDB_PYTHON", "/usr/bin/python3")


def _make_vdb() -> tuple[Path, Path, Path]:
    half, full = DATA / "cloud_320x256x288_half.vdb", DATA / "cloud_320x256x288.vdb"
    colour = DATA / "cloud_320x256x288_cd.vdb"
    if not (half.exists() and full.exists() and colour.exists()):
        npy = DATA / "cloud.npy"
        np.save(npy, _cloud_field())
        script = DATA / "write_vdb.py"
        script.write_text(_WRITE_VDB)
        subprocess.run([_openvdb_python(), "-I", str(script), str(npy), str(half), str(full),
                        str(colour)], check=True)
        npy.unlink()
    return half, full, colour


def _make_nvdb() -> Path:
    out = DATA / "cloud_320x256x288.nvdb"
    if not out.exists():
        _, full, _ = _make_vdb()
        conv = shutil.which("nanovdb_convert")
        if conv is None:
            raise SystemExit("nanovdb_convert missing (apt-get install libnanovdb-tools)")
        subprocess.run([conv, "-f", str(full), str(out)], check=True, capture_output=True)
    return out


def _make_radiance(linear: bool) -> Path:
    out = DATA / ("radiance_160_linear.npz" if linear else "radiance_160.npz")
    if not out.exists():
        n = 160
        f = _cloud_field((n, n, n), seed=5)
        z, y, x = np.meshgrid(*(np.linspace(0, 1, n, dtype=np.float32),) * 3, indexing="ij")
        rgb = np.stack([0.2 + 0.8 * x, 0.3 + 0.6 * y * (1 - x), 1.0 - 0.8 * z], -1)
        np.savez(out, sigma=f / 4, rgb=rgb.astype(np.float32),
                 bounds=np.array([[0, 0, 0], [1, 1, 1]], float),
                 colour_encoding=np.array("linear" if linear else "srgb"))
    return out


def _gaussians(n: int, seed: int = 11):
    """A scene of ``n`` Gaussians clustered on a few surfaces, 3DGS-like scales."""
    rng = np.random.default_rng(seed)
    centres = rng.normal(size=(64, 3)) * 0.6
    k = rng.integers(0, 64, n)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    means = centres[k] + d * rng.uniform(0.15, 0.35, 64)[k][:, None]
    scales = np.log(rng.lognormal(np.log(0.006), 0.5, (n, 3)))
    quats = rng.normal(size=(n, 4))
    opac = rng.uniform(-2.0, 4.0, n)                     # pre-sigmoid
    f_dc = (rng.uniform(0.05, 0.95, (n, 3)) - 0.5) / 0.28209479177387814
    return means, scales, quats, opac, f_dc


def _make_inria() -> Path:
    out = DATA / "splats_1e6.ply"
    if not out.exists():
        from plyfile import PlyData, PlyElement

        means, scales, quats, opac, f_dc = _gaussians(1_000_000)
        names = (["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2", "opacity",
                  "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"])
        arr = np.zeros(len(means), [(k, "f4") for k in names])
        for i, k in enumerate("xyz"):
            arr[k] = means[:, i]
        for i in range(3):
            arr[f"f_dc_{i}"] = f_dc[:, i]
            arr[f"scale_{i}"] = scales[:, i]
        for i in range(4):
            arr[f"rot_{i}"] = quats[:, i]
        arr["opacity"] = opac
        PlyData([PlyElement.describe(arr, "vertex")]).write(str(out))
    return out


def _make_gsply(kind: str) -> Path:
    out = DATA / ("splats_1e6.compressed.ply" if kind == "compressed-ply" else "splats_1e6.spz")
    if not out.exists():
        import gsply

        data = gsply.plyread(_make_inria())
        if kind == "compressed-ply":
            gsply.plywrite(out, data, compressed=True)
        else:
            gsply.write_spz(out, data)
    return out


def _make_nrrd() -> Path:
    out = DATA / "ironProt.nrrd"
    if not out.exists():
        import pyvista as pv

        img = pv.read(shared_data() / "volumes" / "ironProt.vtk")
        a = np.asarray(img.point_data[img.active_scalars_name]).reshape(img.dimensions[::-1])
        nx, ny, nz = img.dimensions
        sp = img.spacing
        head = (f"NRRD0004\ntype: uint8\ndimension: 3\nsizes: {nx} {ny} {nz}\n"
                f"spacings: {sp[0]} {sp[1]} {sp[2]}\nencoding: raw\n\n")
        out.write_bytes(head.encode() + np.ascontiguousarray(a, np.uint8).tobytes())
    return out


def _make_ingp() -> Path:
    out = DATA / "ingp_nerf_defaults.ingp"
    if not out.exists():
        sys.path.insert(0, str(HERE))
        from bench_ingp import write_realistic

        tmp = out.with_suffix(".tmp")
        write_realistic(tmp)
        tmp.replace(out)
    return out


def source_path(kind: str) -> str:
    """The source (a path, or ``demo``) the benchmark converts for ``kind``."""
    DATA.mkdir(exist_ok=True)
    sd = shared_data()
    fixed = {"demo": "demo",
             "openvdb-manta": sd / "volumes" / "blender_mantaflow_fluid_data_0190.vdb",
             "vtk": sd / "volumes" / "hydrogen.vti",
             "vtk-legacy": sd / "volumes" / "ironProt.vtk",
             "metaimage": sd / "volumes" / "HeadMRVolume.mhd",
             "inria-sample": sd / "splats" / "inria3dgs_iter7000_sh3_9080.ply",
             "vox": sd / "voxels" / "magicavoxel_chr_knight.vox"}
    if kind in fixed:
        return str(fixed[kind])
    made = {"openvdb": lambda: _make_vdb()[0], "openvdb-colour": lambda: _make_vdb()[2],
            "nanovdb": _make_nvdb,
            "radiance": lambda: _make_radiance(False),
            "radiance-linear": lambda: _make_radiance(True), "inria": _make_inria,
            "compressed-ply": lambda: _make_gsply("compressed-ply"),
            "spz": lambda: _make_gsply("spz"), "nrrd": _make_nrrd, "ingp": _make_ingp}
    if kind not in made:
        raise SystemExit(f"unknown source kind {kind!r} (one of {', '.join(KINDS)})")
    return str(made[kind]())


KINDS = ("demo", "openvdb", "openvdb-colour", "openvdb-manta", "nanovdb", "vtk", "vtk-legacy",
         "metaimage", "nrrd",
         "radiance", "radiance-linear", "inria", "inria-sample", "compressed-ply", "spz", "vox",
         "ingp")


if __name__ == "__main__":
    for k in (sys.argv[1:] or KINDS):
        p = source_path(k)
        size = os.path.getsize(p) / 1e6 if os.path.isfile(p) else 0.0
        print(f"{k:>16} {size:8.1f} MB  {p}")
