"""Gaussian splats: readers for each layout, and the density conversion against closed forms."""

import json

import numpy as np
import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes import grid_for_source, open_source
from dreamprint_gui.io.volumes.base import voxel_centres
from dreamprint_gui.io.volumes.splats.cloud import SH_C0, GaussianCloud


def _rot(q):
    w, x, y, z = np.asarray(q, float) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def test_single_isotropic_gaussian_optical_depth():
    a, sig = 0.6, 0.1
    s = GaussianCloud("g", "t", [[0, 0, 0]], [[sig, sig, sig]], [[1, 0, 0, 0]], [a], [[1, 0, 0]],
                      bounds=((-1, -1, -1), (1, 1, 1)))
    # one column of voxels through the centre (odd counts centre a voxel on 0)
    g = grid_for_source(s, (2.0 / 21, 2.0 / 21, 0.002), size_mm=(2, 2, 2))
    assert g.mm_per_unit == pytest.approx(1.0)
    zc = voxel_centres(g, 2)
    _, d = s.sample_slab(g, 0, g.shape_xyz[2])
    col = d[:, 10, 10]
    tau = col.sum() * (g.voxel_mm[2] / g.mm_per_unit) * g.mm_per_unit    # sum sigma[1/mm] dz[mm]
    from math import erf, log, sqrt
    want = -log(1 - a) * erf(3 / sqrt(2))          # kernel cut at 3 sigma
    assert tau == pytest.approx(want, rel=1e-4)
    # pointwise: s exp(-r^2 / 2 sigma^2) with s = -ln(1-a) / (sqrt(2 pi) sigma)
    peak = -log(1 - a) / (sqrt(2 * np.pi) * sig)
    xc, yc = voxel_centres(g, 0)[10], voxel_centres(g, 1)[10]
    r2 = xc ** 2 + yc ** 2 + zc ** 2
    want_pt = np.where(r2 <= 9 * sig ** 2, peak * np.exp(-r2 / (2 * sig ** 2)), 0.0)
    np.testing.assert_allclose(col, want_pt, rtol=2e-5, atol=1e-6)


def test_single_rotated_anisotropic_gaussian_closed_form():
    a = 0.8
    sig = np.array([0.3, 0.1, 0.05])
    q = np.array([0.9, 0.2, -0.3, 0.25])
    mu = np.array([0.1, -0.2, 0.05])
    s = GaussianCloud("g", "t", [mu], [sig], [q], [a], [[0.2, 0.4, 0.6]],
                      bounds=((-1, -1, -1), (1, 1, 1)))
    g = grid_for_source(s, (0.03, 0.05, 0.02), size_mm=(2, 2, 2))
    rgb, d = s.sample_slab(g, 30, 70, density_scale=2.0)
    R = _rot(q)
    inv = R @ np.diag(sig ** -2.0) @ R.T
    zc, yc, xc = np.meshgrid(voxel_centres(g, 2, 30, 70), voxel_centres(g, 1),
                             voxel_centres(g, 0), indexing="ij")
    dx = np.stack([xc, yc, zc], -1) - mu
    m2 = np.einsum("...i,ij,...j->...", dx, inv, dx)
    peak = -np.log(1 - a) / (np.sqrt(2 * np.pi) * np.cbrt(sig.prod()))
    want = np.where(m2 <= 9, peak * np.exp(-m2 / 2), 0.0) * 2.0 / g.mm_per_unit
    np.testing.assert_allclose(d, want, rtol=1e-4, atol=1e-5 * want.max())
    np.testing.assert_allclose(rgb[d > 0], np.broadcast_to([0.2, 0.4, 0.6], rgb[d > 0].shape),
                               atol=1e-6)
    # optical depth through the centre along principal axis k: -ln(1-a) sigma_k / geomean
    from math import erf, sqrt
    for k in range(3):
        t = np.linspace(-3 * sig[k], 3 * sig[k], 20001)
        pts = mu + t[:, None] * R[:, k]
        dd = pts - mu
        vals = peak * np.exp(-0.5 * np.einsum("ni,ij,nj->n", dd, inv, dd))
        tau = np.trapezoid(vals, t)
        assert tau == pytest.approx(-np.log(1 - a) * sig[k] / np.cbrt(sig.prod())
                                    * erf(3 / sqrt(2)), rel=1e-6)


def test_colour_is_density_weighted_between_two_gaussians():
    s = GaussianCloud("g", "t", [[-0.1, 0, 0], [0.1, 0, 0]], [[0.1] * 3, [0.1] * 3],
                      [[1, 0, 0, 0]] * 2, [0.5, 0.5], [[1, 0, 0], [0, 0, 1]],
                      bounds=((-1, -1, -1), (1, 1, 1)))
    g = grid_for_source(s, (2 / 21, 2 / 21, 2 / 21), size_mm=(2, 2, 2))
    rgb, d = s.sample_slab(g, 10, 11)
    c = rgb[0, 10, 10]                              # exactly between: equal weights
    np.testing.assert_allclose(c, [0.5, 0, 0.5], atol=1e-6)


def _write_inria_ply(path, means, sigmas, quats, opac, rgb, n_rest=0, double=False):
    from plyfile import PlyData, PlyElement

    t = "f8" if double else "f4"
    names = (["x", "y", "z", "nx", "ny", "nz"] + [f"f_dc_{i}" for i in range(3)]
             + [f"f_rest_{i}" for i in range(n_rest)] + ["opacity"]
             + [f"scale_{i}" for i in range(3)] + [f"rot_{i}" for i in range(4)])
    n = len(means)
    arr = np.zeros(n, [(k, t) for k in names])
    for i, k in enumerate("xyz"):
        arr[k] = means[:, i]
    for i in range(3):
        arr[f"f_dc_{i}"] = (rgb[:, i] - 0.5) / SH_C0
        arr[f"scale_{i}"] = np.log(sigmas[:, i])
    for i in range(4):
        arr[f"rot_{i}"] = quats[:, i]
    arr["opacity"] = np.log(opac / (1 - opac))
    PlyData([PlyElement.describe(arr, "vertex")]).write(str(path))


def _cloud(n=50, seed=0):
    rng = np.random.default_rng(seed)
    return (rng.normal(size=(n, 3)), rng.uniform(0.05, 0.2, (n, 3)), rng.normal(size=(n, 4)),
            rng.uniform(0.1, 0.9, n), rng.uniform(0.1, 0.9, (n, 3)))


def test_inria_sample_file(shared_data, capsys):
    f = shared_data / "splats" / "inria3dgs_iter7000_sh3_9080.ply"
    s = open_source(f)
    info = s.info()
    assert info["gaussians"] == 9080 and info["sh_degree"] == 3
    assert main(["inspect", "--json", str(f)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out) == {"format", "gaussians", "skipped", "sh_degree", "bounds", "content",
                        "placement"}
    assert out["placement"]["orientation"]["up"] == "-y"  # 3DGS: y down, stood up
    assert out["content"] == {"mode": "fog", "reason": "Gaussian splats"}


@pytest.mark.parametrize("n_rest, degree, double", [(0, 0, False), (9, 1, True), (45, 3, False)])
def test_inria_layouts_roundtrip(tmp_path, n_rest, degree, double):
    means, sig, q, a, rgb = _cloud()
    p = tmp_path / "c.ply"
    _write_inria_ply(p, means, sig, q, a, rgb, n_rest, double)
    s = open_source(p)
    assert s.info()["sh_degree"] == degree and s.info()["gaussians"] == 50
    ref = GaussianCloud("r", "t", means, sig, q, a, rgb)
    np.testing.assert_allclose(s.peak, ref.peak, rtol=1e-5)
    np.testing.assert_allclose(s.rgb, ref.rgb, atol=1e-6)
    np.testing.assert_allclose(s.inv_cov, ref.inv_cov, rtol=1e-4)


def test_compressed_ply_and_spz_match_plain(tmp_path):
    import gsply

    means, sig, q, a, rgb = _cloud(300, 1)
    p = tmp_path / "c.ply"
    _write_inria_ply(p, means, sig, q, a, rgb)
    plain = open_source(p)
    data = gsply.plyread(p)
    gsply.plywrite(tmp_path / "c.compressed.ply", data, compressed=True)
    gsply.write_spz(tmp_path / "c.spz", data)
    for f, tol in ((tmp_path / "c.compressed.ply", 0.05), (tmp_path / "c.spz", 0.05)):
        s = open_source(f)
        assert s.info()["gaussians"] == 300
        assert "compressed" in s.format or "SPZ" in s.format
        # quantised layouts: same cloud within quantisation error
        np.testing.assert_allclose(s.mean, plain.mean, atol=0.01)
        np.testing.assert_allclose(s.rgb, plain.rgb, atol=tol)
        np.testing.assert_allclose(np.log(s.peak), np.log(plain.peak), atol=0.1)


def test_bad_splat_files(tmp_path):
    means, sig, q, a, rgb = _cloud()
    p = tmp_path / "c.ply"
    _write_inria_ply(p, means, sig, q, a, rgb)
    data = p.read_bytes()
    t = tmp_path / "t.ply"
    t.write_bytes(data[: len(data) - 100])
    with pytest.raises(DreamPrintError, match="truncated"):
        open_source(t)
    h = tmp_path / "h.ply"
    h.write_bytes(data.replace(b"element vertex 50", b"element vertex 99999999999"))
    with pytest.raises(DreamPrintError, match="truncated"):
        open_source(h)
    from plyfile import PlyData, PlyElement
    m = tmp_path / "mesh.ply"
    PlyData([PlyElement.describe(np.zeros(3, [("x", "f4"), ("y", "f4"), ("z", "f4")]),
                                 "vertex")]).write(str(m))
    with pytest.raises(DreamPrintError, match="not a Gaussian-splat PLY"):
        open_source(m)
    z = tmp_path / "z.spz"
    z.write_bytes(b"\x1f\x8b" + b"\0" * 50)
    with pytest.raises(DreamPrintError, match="SPZ"):
        open_source(z)


def test_frames_kernel_equals_the_numpy_formulas():
    """The compiled per-Gaussian frames (inverse covariance, 3-sigma half-extents) give the bits
    of R from the normalised quaternion and ``einsum("nij,nj,nkj->nik")`` in numpy, including
    zero and huge quaternions."""
    from dreamprint_gui.io.volumes.splats.cloud import _frames, _quat_to_rot

    rng = np.random.default_rng(4)
    n = 20_000
    q = rng.normal(size=(n, 4))
    q[:3] = 0.0
    q[3] *= 1e-160
    sig = rng.lognormal(-4, 2, (n, 3))
    rot = _quat_to_rot(q)
    inv = np.einsum("nij,nj,nkj->nik", rot, sig ** -2.0, rot)
    cov = np.einsum("nij,nj,nkj->nik", rot, sig ** 2, rot)
    want_inv = np.stack([inv[:, 0, 0], inv[:, 1, 1], inv[:, 2, 2], inv[:, 0, 1], inv[:, 0, 2],
                         inv[:, 1, 2]], axis=1)
    want_half = 3.0 * np.sqrt(np.einsum("nii->ni", cov))
    got_inv, got_half = np.empty((n, 6)), np.empty((n, 3))
    _frames(q, sig ** 2, sig ** -2.0, got_inv, got_half)
    np.testing.assert_array_equal(got_inv.view(np.uint64), want_inv.view(np.uint64))
    np.testing.assert_array_equal(got_half.view(np.uint64), want_half.view(np.uint64))
