"""InstantNGP snapshots: closed forms, an independent numpy evaluation, bad files, inspect."""

import gzip
import json
import math

import msgpack
import numpy as np
import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes import grid_for_source, open_source
from dreamprint_gui.io.volumes.base import voxel_centres

# ------------------------------------------------------------------ an instant-ngp-like writer


def _next16(v):
    return (v + 15) // 16 * 16


def level_layout(n_levels, base, pls, log2_t, dense=False):
    """(scale, resolution, entries, hashed) per level, from tiny-cuda-nn grid.h's formulas."""
    out = []
    for lvl in range(n_levels):
        s = float(np.float32(np.exp2(np.float32(lvl) * np.float32(np.log2(np.float32(pls))))
                             * np.float32(base) - np.float32(1)))
        r = math.ceil(s) + 1
        n = (r ** 3 + 7) // 8 * 8
        if not dense:
            n = min(n, 2 ** log2_t)
        out.append((s, r, n, (not dense) and n < r ** 3))
    return out


def make_config(n_levels=2, n_feat=2, log2_t=10, base=4, pls=2.0, d_width=16, d_hidden=1,
                r_width=16, r_hidden=2, dense=False, interpolation="Linear"):
    enc = {"otype": "DenseGrid" if dense else "HashGrid", "n_levels": n_levels,
           "n_features_per_level": n_feat, "log2_hashmap_size": log2_t,
           "base_resolution": base, "per_level_scale": pls, "interpolation": interpolation}
    return {
        "encoding": enc,
        "network": {"otype": "FullyFusedMLP", "activation": "ReLU", "output_activation": "None",
                    "n_neurons": d_width, "n_hidden_layers": d_hidden},
        "dir_encoding": {"otype": "Composite", "nested": [
            {"n_dims_to_encode": 3, "otype": "SphericalHarmonics", "degree": 4},
            {"otype": "Identity"}]},
        "rgb_network": {"otype": "FullyFusedMLP", "activation": "ReLU",
                        "output_activation": "None", "n_neurons": r_width,
                        "n_hidden_layers": r_hidden},
    }


def mlp_shapes(n_in, width, hidden, n_out):
    return [(width, n_in)] + [(width, width)] * (hidden - 1) + [(_next16(n_out), width)]


def param_shapes(cfg):
    """Matrices of the density and colour MLPs and the grid's table size, per nerf_network.h."""
    e, d, r = cfg["encoding"], cfg["network"], cfg["rgb_network"]
    levels = level_layout(e["n_levels"], e["base_resolution"], e["per_level_scale"],
                          e["log2_hashmap_size"], e["otype"] == "DenseGrid")
    enc_w = _next16(e["n_levels"] * e["n_features_per_level"])
    dm = mlp_shapes(enc_w, d["n_neurons"], d["n_hidden_layers"], 16)
    rm = mlp_shapes(32, r["n_neurons"], r["n_hidden_layers"], 3)
    return dm, rm, levels


def write_snapshot(path, cfg, dmats, rmats, table, *, density_grid=None, aabb_scale=1,
                   dataset=None, compress=True, extra=None):
    params = np.concatenate([m.reshape(-1) for m in dmats] + [m.reshape(-1) for m in rmats]
                            + [table.reshape(-1)]).astype(np.float16)
    snap = {"version": 1, "mode": "nerf", "n_params": int(params.size), "params_type": "__half",
            "params_binary": params.tobytes(), "density_grid_size": 128,
            "nerf": {"aabb_scale": aabb_scale,
                     "dataset": dataset or {"scale": 1.0, "offset": [0.0, 0.0, 0.0],
                                            "aabb_scale": aabb_scale, "is_hdr": False,
                                            "from_mitsuba": False}},
            "aabb": {"min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 1.0]},
            "render_aabb": {"min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 1.0]},
            "render_aabb_to_local": [[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]],
            "training_step": 1000}
    if density_grid is not None:
        snap["density_grid_binary"] = np.asarray(density_grid, np.float16).tobytes()
    if extra:
        snap.update(extra)
    tree = dict(cfg)
    tree["snapshot"] = snap
    raw = msgpack.packb(tree, use_bin_type=True)
    path.write_bytes(gzip.compress(raw) if compress else raw)
    return path


def f16(a):
    return np.asarray(a, np.float16).astype(np.float32)


# ------------------------------------------------------------ independent numpy evaluation

SH_C = [0.28209479177387814, 0.48860251190291987, 1.0925484305920792, 0.31539156525251999,
        0.54627421529603959, 0.59004358992664352, 2.8906114426405538, 0.45704579946446572,
        0.3731763325901154, 1.4453057213202769]


def sh4(d):
    x, y, z = d
    c = SH_C
    return np.array([c[0], -c[1] * y, c[1] * z, -c[1] * x, c[2] * x * y, -c[2] * y * z,
                     3 * c[3] * z * z - c[3], -c[2] * x * z, c[4] * (x * x - y * y),
                     c[5] * y * (y * y - 3 * x * x), c[6] * x * y * z,
                     c[7] * y * (1 - 5 * z * z), c[8] * z * (5 * z * z - 3),
                     c[7] * x * (1 - 5 * z * z), c[9] * z * (x * x - y * y),
                     c[5] * x * (3 * y * y - x * x)])


def ref_encode(u, table, levels, n_feat):
    """u (N, 3) in [0, 1]; trilinear blend of the 8 corners per level (plain numpy, uint64)."""
    feats = []
    off = 0
    for s, r, n, hashed in levels:
        pos = s * u.astype(np.float64) + 0.5
        g = np.floor(pos).astype(np.int64)
        w = pos - g
        acc = np.zeros((len(u), n_feat))
        for corner in np.ndindex(2, 2, 2):
            c = g + np.array(corner)
            wt = np.prod(np.where(np.array(corner) == 1, w, 1 - w), axis=1)
            c64 = c.astype(np.uint64)
            if hashed:
                h = (c64[:, 0] ^ ((c64[:, 1] * np.uint64(2654435761)) & np.uint64(0xFFFFFFFF))
                     ^ ((c64[:, 2] * np.uint64(805459861)) & np.uint64(0xFFFFFFFF)))
            else:
                h = c64[:, 0] + c64[:, 1] * np.uint64(r) + c64[:, 2] * np.uint64(r * r)
            idx = (h % np.uint64(n)).astype(np.int64) + off
            acc += wt[:, None] * table[idx]
        feats.append(acc)
        off += n
    return np.concatenate(feats, axis=1)


def ref_mlp(x, mats, n_use=None):
    h = x
    for k, m in enumerate(mats):
        h = h @ m.T.astype(np.float64)
        if k < len(mats) - 1:
            h = np.maximum(h, 0)
    return h if n_use is None else h[:, :n_use]


def ref_field(q, dmats, rmats, table, levels, n_feat, dirs):
    """(sigma, rgb) of instant-ngp points q (N, 3) in the unit aabb, colour the mean of the
    sigmoid outputs over unit directions ``dirs`` (instant-ngp frame)."""
    e = ref_encode(q, table, levels, n_feat)
    e = np.concatenate([e, np.zeros((len(q), _next16(e.shape[1]) - e.shape[1]))], axis=1)
    d = ref_mlp(e, dmats)
    sigma = np.exp(d[:, 0])
    rgb = np.zeros((len(q), 3))
    for dirn in dirs:
        inp = np.concatenate([d, np.broadcast_to(sh4(dirn), (len(q), 16))], axis=1)
        rgb += 1 / (1 + np.exp(-ref_mlp(inp, rmats, 3)))
    return sigma, rgb / len(dirs)


# ---------------------------------------------------------------------------- closed forms


def test_constant_field_closed_form(tmp_path):
    """All table entries 0.5 -> every level encodes 0.5 -> density exp(a * sum) everywhere,
    colour sigmoid(k) from the constant SH term; density grid absent -> whole aabb."""
    cfg = make_config(n_levels=2, n_feat=2, log2_t=10)
    dm, rm, levels = param_shapes(cfg)
    table = np.zeros((sum(n for *_, n, _h in levels), 2), np.float32)
    table[:, 0] = 0.5
    d0 = np.zeros(dm[0], np.float32)
    d0[0, 0] = d0[0, 2] = 1.0                     # h0 = feature 0 of both levels = 1.0
    d1 = np.zeros(dm[1], np.float32)
    d1[0, 0] = 1.5                                # o0 = 1.5 -> sigma = exp(1.5)
    r0 = np.zeros(rm[0], np.float32)
    r0[:3, 16] = 1.0                              # SH Y00 column (after 16 density outputs)
    r1 = np.eye(*rm[1], dtype=np.float32)
    r2 = np.zeros(rm[2], np.float32)
    k = np.array([-1.0, 0.0, 2.0])
    r2[:3, :3] = np.diag(k / SH_C[0])
    p = write_snapshot(tmp_path / "c.ingp", cfg, [d0, d1], [r0, r1, r2], table,
                       dataset={"scale": 0.5, "offset": [0.1, 0.2, 0.3], "aabb_scale": 1})
    s = open_source(p)
    # source p = ((q_z, q_x, q_y) - offset) / scale (instant-ngp's ngp_position_to_nerf)
    np.testing.assert_allclose(s.bounds[0], [(0 - 0.1) / 0.5, (0 - 0.2) / 0.5, (0 - 0.3) / 0.5])
    np.testing.assert_allclose(s.bounds[1], [(1 - 0.1) / 0.5, (1 - 0.2) / 0.5, (1 - 0.3) / 0.5])
    g = grid_for_source(s, (0.5, 0.5, 0.5), height_mm=10)
    rgb, d = s.sample_slab(g, 0, g.shape_xyz[2], density_scale=2.0)
    sig_ngp = math.exp(float(f16(1.5) * f16(1.0) * 2 * f16(0.5)))
    inside = np.ones(d.shape, bool)
    for a, ax in ((0, 2), (1, 1), (2, 0)):
        c = voxel_centres(g, a)
        m = (c >= s.bounds[0][a]) & (c <= s.bounds[1][a])
        shape = [1, 1, 1]
        shape[ax] = -1
        inside &= m.reshape(shape)
    want = sig_ngp * 0.5 * 2.0 / g.mm_per_unit
    np.testing.assert_allclose(d[inside], want, rtol=2e-3)
    assert np.all(d[~inside] == 0)
    sg = 1 / (1 + np.exp(-f16(k / SH_C[0]) * np.float32(SH_C[0])))
    np.testing.assert_allclose(rgb[inside], np.broadcast_to(sg, rgb[inside].shape), atol=2e-3)


def test_linear_dense_level_and_view_dependence(tmp_path):
    """One dense level whose entries are the vertex's x index: the encoding is s*u + 0.5
    exactly (trilinear of a linear function); colour from the SH x term depends on the view."""
    cfg = make_config(n_levels=1, n_feat=2, base=8, pls=2.0, dense=True, log2_t=19)
    dm, rm, levels = param_shapes(cfg)
    (s_l, r, n, hashed), = levels
    assert not hashed and r == 8
    ent = np.arange(n)
    table = np.zeros((n, 2), np.float32)
    table[:, 0] = ent % r                          # x index of entry x + y r + z r^2
    d0 = np.zeros(dm[0], np.float32)
    d0[0, 0] = 1.0
    d1 = np.zeros(dm[1], np.float32)
    d1[0, 0] = 0.25                                # sigma = exp(0.25 (s u_x + 0.5))
    r0 = np.zeros(rm[0], np.float32)
    r0[0, 16 + 3] = -1.0 / SH_C[1]                 # h0 = relu(x_dir): SH[3] = -c1 x
    r0[1, 16 + 3] = 1.0 / SH_C[1]                  # h1 = relu(-x_dir)
    r1 = np.eye(*rm[1], dtype=np.float32)
    r2 = np.zeros(rm[2], np.float32)
    r2[0, 0] = 2.0
    r2[1, 1] = 3.0
    p = write_snapshot(tmp_path / "lin.msgpack", cfg, [d0, d1], [r0, r1, r2], table,
                       compress=False)
    # source frame with scale 1, offset 0: ngp (x, y, z) = source (y, z, x)
    src = open_source(p, view="0,1,0")             # source +y = ngp +x
    ys = np.array([0.05, 0.3, 0.6, 0.8])           # ngp x = source y; s*u+0.5 < r-1 here
    rgb, sig = src.evaluate(np.array([0.5]), ys, np.array([0.5]))
    u = ys
    np.testing.assert_allclose(sig[0, :, 0], np.exp(0.25 * (s_l * u + 0.5)), rtol=2e-3)
    np.testing.assert_allclose(rgb[0, :, 0], np.broadcast_to([1 / (1 + np.exp(-2.0)), 0.5, 0.5],
                                                             (4, 3)), atol=2e-3)
    mean = open_source(p, view="mean")
    rgb_m, _ = mean.evaluate(np.array([0.5]), ys, np.array([0.5]))
    # six directions: +x gives channel 0 sigmoid(2), -x gives channel 1 sigmoid(3)
    want0 = (1 / (1 + np.exp(-2.0)) + 5 * 0.5) / 6
    want1 = (1 / (1 + np.exp(-3.0)) + 5 * 0.5) / 6
    np.testing.assert_allclose(rgb_m[0, :, 0, 0], want0, atol=2e-3)
    np.testing.assert_allclose(rgb_m[0, :, 0, 1], want1, atol=2e-3)
    np.testing.assert_allclose(rgb_m[0, :, 0, 2], 0.5, atol=2e-3)
    assert "mean over the 6 view directions" in mean.info()["colour"]


def test_occupancy_grid_skips_empty_cells(tmp_path):
    cfg = make_config(n_levels=1, n_feat=2, log2_t=10)
    dm, rm, levels = param_shapes(cfg)
    table = np.full((levels[0][2], 2), 0.5, np.float32)
    d0 = np.zeros(dm[0], np.float32)
    d0[0, 0] = 1.0
    d1 = np.zeros(dm[1], np.float32)
    d1[0, 0] = 1.0
    rmats = [np.zeros(sh, np.float32) for sh in rm]
    # occupied: ngp x < 0.5 only (Morton order: x is bit 0 of each triple)
    grid = np.zeros(128 ** 3, np.float32)
    idx = np.arange(128 ** 3)
    x = np.zeros_like(idx)
    for b in range(7):
        x |= ((idx >> (3 * b)) & 1) << b
    grid[x < 64] = 1.0
    p = write_snapshot(tmp_path / "o.ingp", cfg, [d0, d1], rmats, table, density_grid=grid)
    s = open_source(p)
    ys = np.array([0.2, 0.4, 0.6, 0.8])             # source y = ngp x
    _, sig = s.evaluate(np.array([0.5]), ys, np.array([0.5]))
    assert np.all(sig[0, :2, 0] > 0) and np.all(sig[0, 2:, 0] == 0)
    info = s.info()
    assert info["occupancy_grid"]["occupied_fraction"] == [0.5]
    _, sig_all = open_source(p, occupancy=False).evaluate(np.array([0.5]), ys, np.array([0.5]))
    assert np.all(sig_all > 0)


# ------------------------------------------------------------ numba vs numpy, random weights


@pytest.mark.parametrize("compress", [True, False])
def test_random_weights_match_numpy_reference(tmp_path, compress):
    rng = np.random.default_rng(3)
    cfg = make_config(n_levels=6, n_feat=2, log2_t=12, base=4, pls=1.9, d_width=32,
                      d_hidden=2, r_width=32, r_hidden=2)
    dm, rm, levels = param_shapes(cfg)
    assert any(h for *_, h in levels) and not all(h for *_, h in levels)
    table = f16(rng.uniform(-1, 1, (sum(n for _s, _r, n, _h in levels), 2)))
    dmats = [f16(rng.normal(0, 0.5, sh)) for sh in dm]
    rmats = [f16(rng.normal(0, 0.5, sh)) for sh in rm]
    ds = {"scale": 0.8, "offset": [0.5, 0.4, 0.3], "aabb_scale": 1}
    p = write_snapshot(tmp_path / ("r.ingp" if compress else "r.msgpack"), cfg, dmats, rmats,
                       table, dataset=ds, compress=compress)
    src = open_source(p, view="mean", threads=2)
    pts = rng.uniform(0.02, 0.98, (3, 7))          # ngp coordinates in the unit aabb
    # source = (C^T q - offset) / scale, C^T q = (q_z, q_x, q_y)
    xs = (pts[2] - 0.5) / 0.8
    ys = (pts[0] - 0.4) / 0.8
    zs = (pts[1] - 0.3) / 0.8
    rgb, sig = src.evaluate(xs, ys, zs)
    Z, Y, X = np.meshgrid(zs, ys, xs, indexing="ij")
    q = np.stack([Y * 0.8 + 0.4, Z * 0.8 + 0.3, X * 0.8 + 0.5], -1).reshape(-1, 3)
    dirs = [np.array(v, float) for v in ([0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1],
                                         [1, 0, 0], [-1, 0, 0])]
    want_s, want_c = ref_field(q, dmats, rmats, table, levels, 2, dirs)
    np.testing.assert_allclose(sig.reshape(-1), want_s, rtol=1e-4)
    np.testing.assert_allclose(rgb.reshape(-1, 3), want_c, atol=1e-4)  # float32 vs 64
    # single thread, one direction: same kernel path, other chunking
    one = open_source(p, view="down", threads=1)
    rgb1, sig1 = one.evaluate(xs, ys, zs)
    np.testing.assert_allclose(sig1, sig, rtol=1e-6)
    _, want_c1 = ref_field(q, dmats, rmats, table, levels, 2, [np.array([0, -1.0, 0])])
    np.testing.assert_allclose(rgb1.reshape(-1, 3), want_c1, atol=1e-4)


# ------------------------------------------------------------------- bad files and the CLI


def _good(tmp_path, **kw):
    cfg = make_config(n_levels=1, log2_t=10)
    dm, rm, levels = param_shapes(cfg)
    return cfg, [np.zeros(s, np.float32) for s in dm], [np.zeros(s, np.float32) for s in rm], \
        np.zeros((levels[0][2], 2), np.float32)


def test_bad_snapshots_one_line_errors(tmp_path, capsys):
    cfg, dm, rm, table = _good(tmp_path)
    p = write_snapshot(tmp_path / "ok.ingp", cfg, dm, rm, table)
    data = p.read_bytes()
    cases = {}
    (tmp_path / "trunc.ingp").write_bytes(data[: len(data) // 2])
    cases["trunc.ingp"] = "damaged compressed snapshot"
    (tmp_path / "junk.msgpack").write_bytes(b"\x93\x01\x02")
    cases["junk.msgpack"] = "not an InstantNGP snapshot"
    bad = dict(cfg, encoding={"otype": "Frequency", "n_frequencies": 12})
    write_snapshot(tmp_path / "freq.ingp", bad, dm, rm, table)
    cases["freq.ingp"] = "position encoding 'Frequency' is not supported"
    bad = dict(cfg, network=dict(cfg["network"], otype="SIREN"))
    write_snapshot(tmp_path / "siren.ingp", bad, dm, rm, table)
    cases["siren.ingp"] = "density network type 'SIREN' is not supported"
    write_snapshot(tmp_path / "short.ingp", cfg, dm, rm[:-1], table)
    cases["short.ingp"] = "configuration needs"
    write_snapshot(tmp_path / "sdf.ingp", cfg, dm, rm, table, extra={"mode": "sdf"})
    cases["sdf.ingp"] = "'sdf' snapshot is not a radiance field"
    write_snapshot(tmp_path / "grid.ingp", cfg, dm, rm, table, density_grid=np.ones(1000))
    cases["grid.ingp"] = "density grid"
    for name, msg in cases.items():
        with pytest.raises(DreamPrintError, match=msg):
            open_source(tmp_path / name)
        assert main(["inspect", str(tmp_path / name)]) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith("dreamprint: error:") and "\n" not in err and msg in err


def test_inspect_names_kind_network_and_occupancy(tmp_path, capsys):
    cfg, dm, rm, table = _good(tmp_path)
    p = write_snapshot(tmp_path / "ok.ingp", cfg, dm, rm, table,
                       density_grid=np.r_[np.ones(128 ** 3 // 4), np.zeros(3 * 128 ** 3 // 4)])
    assert main(["inspect", "--json", str(p)]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["format"] == "InstantNGP snapshot"
    assert info["encoding"]["type"] == "hash" and info["encoding"]["levels"] == 1
    assert info["density_network"]["type"] == "FullyFusedMLP"
    assert info["occupancy_grid"]["occupied_fraction"] == [0.25]
    assert "looking down" in info["colour"]
    assert main(["inspect", str(p)]) == 0
    text = capsys.readouterr().out
    assert "InstantNGP snapshot" in text and "FullyFusedMLP" in text and "occupied" in text


def test_occupancy_cascades_follow_mip_from_pos():
    """The cascade picked for a point is instant-ngp's mip_from_pos: frexp of max|q - 0.5|."""
    from dreamprint_gui.io.volumes.ingp.kernels import _occupied

    rng = np.random.default_rng(5)
    occ = (rng.random((3, 8, 8, 8)) < 0.5).astype(np.uint8)
    for q in rng.uniform(-1.6, 2.6, (2000, 3)):
        e = math.frexp(float(np.max(np.abs(q - 0.5))))[1]
        mip = min(max(e + 1, 0), 2)
        c = ((q - 0.5) * 2.0 ** -mip + 0.5) * 8
        i = c.astype(int)                                   # C++ float -> int truncation
        want = bool(np.all((i >= 0) & (i < 8)) and occ[mip, i[2], i[1], i[0]])
        assert _occupied(q, occ, 2) == want


def test_convert_a_snapshot(tmp_path):
    """``dreamprint convert`` runs on a snapshot (two worker threads, one slab each)."""
    cfg = make_config(n_levels=2, n_feat=2, log2_t=10)
    dm, rm, levels = param_shapes(cfg)
    table = np.full((sum(n for *_, n, _h in levels), 2), 0.5, np.float32)
    d0 = np.zeros(dm[0], np.float32)
    d0[0, 0] = 1.0
    d1 = np.zeros(dm[1], np.float32)
    d1[0, 0] = 4.0                                  # sigma = e^2 per unit: visibly dense
    rmats = [np.zeros(sh, np.float32) for sh in rm]
    grid = np.zeros(128 ** 3, np.float32)
    grid[: 128 ** 3 // 8] = 1.0                     # Morton: the first octant (x, y, z < 0.5)
    p = write_snapshot(tmp_path / "s.ingp", cfg, [d0, d1], rmats, table, density_grid=grid)
    out = tmp_path / "JOB"  # over the whole box (--fit box): the occupied octant is 1/8 of it
    rc = main(["convert", str(p), "-o", str(out), "--height-mm", "0.5", "--table-size", "17",
               "--workers", "2", "--slab-layers", "4", "--option", "view=mean", "--fit", "box"])
    assert rc == 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["source"]["options"] == {"view": "mean"}
    counts = manifest["voxel_counts"]
    inked = sum(v for k, v in counts.items() if k not in ("Cl", "empty"))
    assert 0.09 < inked / manifest["total_voxels"] < 0.16      # the occupied octant: 1/8


def test_hdr_colour_and_render_box_crop(tmp_path):
    """HDR snapshots: colour exp(clamp(out, -10, 10)), linear, encoded to sRGB; a render box
    (turned 90 degrees about instant-ngp's y) crops the print to that box."""
    from dreamprint_gui.io.volumes.base import linear_to_srgb

    cfg = make_config(n_levels=1, n_feat=2, log2_t=10)
    dm, rm, levels = param_shapes(cfg)
    table = np.full((levels[0][2], 2), 0.5, np.float32)
    d0 = np.zeros(dm[0], np.float32)
    d0[0, 0] = 2.0
    d1 = np.zeros(dm[1], np.float32)
    d1[0, 0] = 1.0                                  # sigma = e
    r0 = np.zeros(rm[0], np.float32)
    r0[:3, 16] = 1.0
    r1 = np.eye(*rm[1], dtype=np.float32)
    r2 = np.zeros(rm[2], np.float32)
    k = np.array([-1.0, -2.0, 0.5])
    r2[:3, :3] = np.diag(k / SH_C[0])
    # local = R q with R a quarter turn about y: (x, y, z) -> (z, y, -x); the local box
    # x in [0.2, 0.6], y in [0, 1], z in [-0.9, -0.5] is q in x [0.5, 0.9], z [0.2, 0.6]
    R = [[0.0, 0, 1], [0, 1, 0], [-1, 0, 0]]
    extra = {"render_aabb": {"min": [0.2, 0.0, -0.9], "max": [0.6, 1.0, -0.5]},
             "render_aabb_to_local": R}
    ds = {"scale": 1.0, "offset": [0.0, 0.0, 0.0], "aabb_scale": 1, "is_hdr": True}
    p = write_snapshot(tmp_path / "h.ingp", cfg, [d0, d1], [r0, r1, r2], table, dataset=ds,
                       extra=extra)
    s = open_source(p)
    assert s.colour_encoding == "linear"
    # source p = (q_z, q_x, q_y): x in [0.2, 0.6], y in [0.5, 0.9], z in [0, 1]
    np.testing.assert_allclose(s.bounds, ((0.2, 0.5, 0.0), (0.6, 0.9, 1.0)), atol=1e-12)
    g = grid_for_source(s, (0.1, 0.1, 0.1), size_mm=(4, 4, 10))
    rgb, d = s.sample_slab(g, 0, g.shape_xyz[2])
    assert np.all(d > 0)                            # the grid covers just the box
    np.testing.assert_allclose(d * g.mm_per_unit, math.e, rtol=2e-3)
    want = linear_to_srgb(np.exp(f16(k / SH_C[0]) * np.float32(SH_C[0])))
    np.testing.assert_allclose(rgb.reshape(-1, 3), np.broadcast_to(want, (d.size, 3)),
                               atol=2e-3)
    _, outside = s.evaluate(np.array([0.1, 0.4, 0.7]), np.array([0.7]), np.array([0.5]))
    assert outside[0, 0, 0] == 0 and outside[0, 0, 1] > 0 and outside[0, 0, 2] == 0


def test_aabb_scale_2_uses_two_cascades_and_derived_level_scale(tmp_path):
    """aabb_scale 2: aabb 0.5 -+ 1 (load_nerf_post), two occupancy cascades, and without a
    per_level_scale the level scale exp(ln(2048 * 2 / N_min) / (L - 1)) (reset_network)."""
    cfg = make_config(n_levels=2, n_feat=2, log2_t=10, base=4)
    del cfg["encoding"]["per_level_scale"]
    pls = float(np.exp(np.float32(np.log(np.float32(4096.0) / np.float32(4)))))
    cfg_w = make_config(n_levels=2, n_feat=2, log2_t=10, base=4, pls=pls)
    dm, rm, levels = param_shapes(cfg_w)
    rng = np.random.default_rng(2)
    table = f16(rng.uniform(-1, 1, (sum(n for _s, _r, n, _h in levels), 2)))
    dmats = [f16(rng.normal(0, 0.5, sh)) for sh in dm]
    rmats = [f16(rng.normal(0, 0.5, sh)) for sh in rm]
    grid = np.zeros(2 * 128 ** 3, np.float32)
    grid[128 ** 3:] = 1.0                           # cascade 1 all occupied, cascade 0 empty
    p = write_snapshot(tmp_path / "a2.ingp", cfg, dmats, rmats, table, aabb_scale=2,
                       density_grid=grid)
    tree = msgpack.unpackb(gzip.decompress(p.read_bytes()), raw=False)
    del tree["snapshot"]["aabb"], tree["snapshot"]["render_aabb"]   # the reader derives them
    p.write_bytes(gzip.compress(msgpack.packb(tree, use_bin_type=True)))
    s = open_source(p)
    assert s.bounds == ((-0.5, -0.5, -0.5), (1.5, 1.5, 1.5))
    assert s.info()["occupancy_grid"]["occupied_fraction"] == [0.0, 1.0]
    # source (x, y, z) = ngp (z, x, y): inside the unit cube -> cascade 0 (empty)
    _, sig = s.evaluate(np.array([0.4, 1.3]), np.array([0.5]), np.array([0.5]))
    assert sig[0, 0, 0] == 0 and sig[0, 0, 1] > 0
    q = np.array([[0.5, 0.5, 1.3]])                 # ngp of source (1.3, 0.5, 0.5)
    want, _ = ref_field((q + 0.5) / 2.0, dmats, rmats, table, levels, 2, [np.array([0, -1.0, 0])])
    np.testing.assert_allclose(sig[0, 0, 1], want[0], rtol=1e-4)
