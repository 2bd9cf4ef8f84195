"""Splat exchange formats: files written here to each published layout (antimatter15 .splat,
GaussianSplats3D .ksplat levels 0-2, Niantic SPZ v1-v4, PlayCanvas SOG, nerfstudio's PLY
export) from known Gaussians, read back and compared within each layout's quantisation."""

import gzip
import io
import json
import struct
import zipfile

import numpy as np
import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes import open_source
from dreamprint_gui.io.volumes.splats.cloud import SH_C0, GaussianCloud
from dreamprint_gui.io.volumes.splats.formats import (
    decode_ksplat,
    decode_sog,
    decode_splat,
    decode_spz,
)

N = 37


def _known(n=N, seed=3):
    rng = np.random.default_rng(seed)
    means = rng.uniform(-2, 2, (n, 3))
    sig = np.exp(rng.uniform(-4, -1.5, (n, 3)))
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    a = rng.uniform(0.05, 0.95, n)
    rgb = rng.uniform(0.05, 0.95, (n, 3))
    return means, sig, q, a, rgb


def _same_rotation(got, want, atol):
    got = got / np.linalg.norm(got, axis=1, keepdims=True)
    dots = np.abs(np.sum(got * want, axis=1))          # q and -q are one rotation
    np.testing.assert_allclose(dots, 1.0, atol=atol)


def _check(g, means, sig, q, a, rgb, *, pos, log_sig, rot, colour, alpha):
    np.testing.assert_allclose(g.means, means, atol=pos)
    np.testing.assert_allclose(np.log(g.sigmas), np.log(sig), atol=log_sig)
    _same_rotation(g.quats, q, rot)
    np.testing.assert_allclose(g.rgb, rgb, atol=colour)
    np.testing.assert_allclose(g.opacity, a, atol=alpha)


def _u8(x):
    return np.clip(np.round(x), 0, 255).astype(np.uint8)


# ------------------------------------------------------------------------------ .splat

def write_splat(path, means, sig, q, a, rgb):
    rec = np.zeros(len(means), [("pos", "<f4", 3), ("scale", "<f4", 3), ("rgba", "u1", 4),
                                ("rot", "u1", 4)])
    rec["pos"], rec["scale"] = means, sig
    rec["rgba"] = _u8(np.column_stack([rgb, a]) * 255)
    rec["rot"] = _u8(q / np.linalg.norm(q, axis=1, keepdims=True) * 128 + 128)
    rec.tofile(path)


def test_splat_round_trip(tmp_path):
    k = _known()
    p = tmp_path / "c.splat"
    write_splat(p, *k)
    g = decode_splat(p)
    _check(g, *k, pos=1e-6, log_sig=1e-6, rot=3e-4, colour=0.5 / 255 + 1e-9,
           alpha=0.5 / 255 + 1e-9)
    assert p.stat().st_size == 32 * N


# ------------------------------------------------------------------------------ .ksplat

def _half(x):
    return np.asarray(x, "<f2")


def write_ksplat(path, means, sig, q, a, rgb, level, *, split=(N,), degree=0, bucket=8,
                 partial_sizes=(5, 8), spare=0):
    """GaussianSplats3D SplatBuffer layout (format 0.1): header, section headers, sections."""
    rgba = _u8(np.column_stack([rgb, a]) * 255)
    qn = q / np.linalg.norm(q, axis=1, keepdims=True)
    n_sh = {0: 0, 1: 9, 2: 24}[degree]
    sections, headers = [], []
    start = 0
    for count in split:
        idx = slice(start, start + count)
        start += count
        m, s, r, c = means[idx], sig[idx], qn[idx], rgba[idx]
        sh = np.linspace(-1, 1, count * n_sh).reshape(count, n_sh)
        out = io.BytesIO()
        h = np.zeros(256, "<u4").view(np.uint8)
        h16, h32, hf = h.view("<u2"), h.view("<u4"), h.view("<f4")
        h32[0], h32[1] = count, count + spare
        if level == 0:
            for i in range(count):
                out.write(np.asarray(m[i], "<f4").tobytes() + np.asarray(s[i], "<f4").tobytes()
                          + np.asarray(r[i], "<f4").tobytes() + c[i].tobytes()
                          + np.asarray(sh[i], "<f4").tobytes())
            per = 44 + 4 * n_sh
        else:
            full = (count - sum(partial_sizes)) // bucket
            assert full * bucket + sum(partial_sizes) == count
            groups = [range(b * bucket, (b + 1) * bucket) for b in range(full)]
            at = full * bucket
            for ps in partial_sizes:
                groups.append(range(at, at + ps))
                at += ps
            centres = np.array([m[list(gr)].mean(0) for gr in groups])
            block = 2.02 * max(np.abs(m[list(gr)] - centres[b]).max()
                               for b, gr in enumerate(groups))
            rng_q = 32767
            out.write(np.asarray(partial_sizes, "<u4").tobytes())
            out.write(np.asarray(centres, "<f4").tobytes())
            for b, gr in enumerate(groups):
                for i in gr:
                    d = np.round((m[i] - centres[b]) * rng_q / (block / 2)) + rng_q
                    shb = (_half(sh[i]).tobytes() if level == 1 else
                           _u8((sh[i] + 1.5) / 3.0 * 255).tobytes())
                    out.write(np.asarray(d, "<u2").tobytes() + _half(s[i]).tobytes()
                              + _half(r[i]).tobytes() + c[i].tobytes() + shb)
            per = 24 + (2 if level == 1 else 1) * n_sh
            h32[2], h32[3] = bucket, len(groups)
            hf[4] = block
            h16[10] = 12
            h32[6] = rng_q
            h32[8], h32[9] = full, len(partial_sizes)
        out.write(b"\0" * per * spare)
        h32[7] = len(out.getvalue())
        h16[20] = degree
        sections.append(out.getvalue())
        headers.append(h.tobytes())
    head = np.zeros(1024, "<u4").view(np.uint8)
    head[0], head[1] = 0, 1
    h32, hf = head.view("<u4"), head.view("<f4")
    h32[1], h32[2], h32[3], h32[4] = len(split), len(split), N + spare, N
    head.view("<u2")[10] = level
    hf[9], hf[10] = -1.5, 1.5
    path.write_bytes(head.tobytes() + b"".join(headers) + b"".join(sections))


@pytest.mark.parametrize("level, kw", [
    (0, {}), (0, {"split": (20, 17), "degree": 2, "spare": 3}),
    (1, {"degree": 1}), (1, {"partial_sizes": (5,), "spare": 2}), (2, {"degree": 1}),
])
def test_ksplat_round_trip(tmp_path, level, kw):
    k = _known()
    if level and kw.get("partial_sizes") == (5,):
        kw["partial_sizes"] = (5,)                           # 4 full buckets of 8, then 5
    p = tmp_path / "c.ksplat"
    write_ksplat(p, *k, level, **kw)
    g = decode_ksplat(p)
    assert g.sh_degree == kw.get("degree", 0)
    extent = 4.0
    _check(g, *k, pos=1e-6 if level == 0 else extent / 32767,
           log_sig=1e-6 if level == 0 else 1e-3, rot=1e-6 if level == 0 else 2e-3,
           colour=0.5 / 255 + 1e-9, alpha=0.5 / 255 + 1e-9)
    s = open_source(p)
    assert s.info()["gaussians"] == N and f"compression level {level}" in s.format


# ------------------------------------------------------------------------------ SPZ

def _spz_sections(version, means, sig, q, a, rgb, fb=12):
    n = len(means)
    if version == 1:
        pos = np.asarray(means, "<f2").tobytes()
    else:
        fixed = np.round(means * (1 << fb)).astype(np.int64).reshape(-1) & 0xFFFFFF
        pos = np.stack([fixed & 255, (fixed >> 8) & 255, fixed >> 16], 1).astype(np.uint8)
        pos = pos.tobytes()
    alphas = _u8(a * 255).tobytes()
    f_dc = (rgb - 0.5) / SH_C0
    colours = _u8(f_dc * 0.15 * 255 + 127.5).tobytes()
    scales = _u8((np.log(sig) + 10) * 16).tobytes()
    xyzw = (q / np.linalg.norm(q, axis=1, keepdims=True))[:, [1, 2, 3, 0]]
    if version < 3:
        xyzw = xyzw * np.where(xyzw[:, 3:] < 0, -1, 1)
        rot = _u8(xyzw[:, :3] * 127.5 + 127.5).tobytes()
    else:
        largest = np.argmax(np.abs(xyzw), axis=1)
        neg = xyzw[np.arange(n), largest] < 0
        comp = largest.astype(np.uint32)
        for i in range(4):
            keep = largest != i
            v = xyzw[:, i]
            mag = np.round(511 * np.abs(v) / np.sqrt(0.5)).astype(np.uint32)
            negbit = ((v < 0) ^ neg).astype(np.uint32)
            comp = np.where(keep, (comp << 10) | (negbit << 9) | mag, comp)
        rot = comp.astype("<u4").tobytes()
    return [pos, alphas, colours, scales, rot]


def write_spz(path, version, means, sig, q, a, rgb, fb=12, degree=0, extension=b""):
    """SPZ as load-spz.cc reads it; ``extension`` bytes go where the format puts extensions
    (after the sections in v1-v3, between header and table in v4) with flag 0x2 set."""
    secs = _spz_sections(version, means, sig, q, a, rgb, fb)
    n = len(means)
    if degree:
        dim = {1: 3, 2: 8, 3: 15}[degree]
        secs.append(_u8(np.linspace(0, 255, n * dim * 3)).tobytes())   # SH, not sampled
    flags = 2 if extension else 0
    if version < 4:
        header = struct.pack("<IIIBBBB", 0x5053474E, version, n, degree,
                             fb if version > 1 else 0, flags, 0)
        path.write_bytes(gzip.compress(header + b"".join(secs) + extension))
        return
    import zstandard

    comp = [zstandard.ZstdCompressor(level=3).compress(s) for s in secs]
    toc = b"".join(struct.pack("<QQ", len(c), len(s)) for c, s in zip(comp, secs, strict=True))
    header = struct.pack("<IIIBBBBI12x", 0x5053474E, 4, n, degree, fb, flags, len(secs),
                         32 + len(extension))
    path.write_bytes(header + extension + toc + b"".join(comp))


@pytest.mark.parametrize("version, extra", [
    (1, {}), (2, {}), (3, {}), (4, {}), (2, {"degree": 1, "extension": b"\x01\x00\x00\x00ext"}),
    (3, {"degree": 3, "fb": 10}), (4, {"degree": 2, "extension": b"\x07" * 12}),
])
def test_spz_round_trip(tmp_path, version, extra):
    k = _known()
    p = tmp_path / f"c{version}.spz"
    write_spz(p, version, *k, **extra)
    g = decode_spz(p)
    assert g.sh_degree == extra.get("degree", 0)
    assert g.format == f"splats (SPZ v{version})"
    pos = 2e-3 if version == 1 else 0.5 / 2 ** extra.get("fb", 12) + 1e-9  # float16 at |x|<=2
    rot = 2e-4 if version >= 3 else 1e-2
    colour = SH_C0 * 0.5 / (0.15 * 255) + 1e-9
    _check(g, *k, pos=pos, log_sig=0.5 / 16 + 1e-9, rot=rot, colour=colour,
           alpha=0.5 / 255 + 1e-9)
    assert open_source(p).info()["gaussians"] == N


# ------------------------------------------------------------------------------ SOG

def _webp(rgba, w, h):
    from PIL import Image

    img = np.zeros((h * w, 4), np.uint8)
    img[: len(rgba)] = rgba
    buf = io.BytesIO()
    Image.fromarray(img.reshape(h, w, 4), "RGBA").save(buf, "WEBP", lossless=True, quality=100,
                                                       exact=True)
    return buf.getvalue()


def sog_files(means, sig, q, a, rgb):
    """PlayCanvas SOG v2 (splat-transform write-sog / read-sog): meta.json + WebP textures."""
    n = len(means)
    w = int(np.ceil(np.sqrt(n)))
    h = int(np.ceil(n / w))
    lt = np.sign(means) * np.log(np.abs(means) + 1)
    mins, maxs = lt.min(0), lt.max(0)
    v = np.round((lt - mins) / (maxs - mins) * 65535).astype(np.uint32)
    full = np.full((n, 1), 255, np.uint8)
    lo = np.column_stack([(v & 255).astype(np.uint8), full])
    hi = np.column_stack([(v >> 8).astype(np.uint8), full])
    ls = np.log(sig)
    s_code = np.linspace(ls.min(), ls.max(), 256)
    s_lab = np.abs(ls[..., None] - s_code).argmin(-1).astype(np.uint8)
    f_dc = (rgb - 0.5) / SH_C0
    c_code = np.linspace(f_dc.min(), f_dc.max(), 256)
    c_lab = np.abs(f_dc[..., None] - c_code).argmin(-1).astype(np.uint8)
    sh0 = np.column_stack([c_lab, _u8(a * 255)])
    qn = q / np.linalg.norm(q, axis=1, keepdims=True)
    largest = np.argmax(np.abs(qn), axis=1)
    qn = qn * np.where(qn[np.arange(n), largest] < 0, -1, 1)[:, None]
    others = np.array([[j for j in range(4) if j != m] for m in largest])
    three = np.take_along_axis(qn, others, 1)
    quats = np.column_stack([_u8((three * np.sqrt(2) * 0.5 + 0.5) * 255),
                             (252 + largest).astype(np.uint8)])
    meta = {"version": 2, "count": n,
            "means": {"mins": mins.tolist(), "maxs": maxs.tolist(),
                      "files": ["means_l.webp", "means_u.webp"]},
            "scales": {"codebook": s_code.tolist(), "files": ["scales.webp"]},
            "quats": {"files": ["quats.webp"]},
            "sh0": {"codebook": c_code.tolist(), "files": ["sh0.webp"]}}
    files = {"meta.json": json.dumps(meta).encode(), "means_l.webp": _webp(lo, w, h),
             "means_u.webp": _webp(hi, w, h),
             "scales.webp": _webp(np.column_stack([s_lab, full]), w, h),
             "quats.webp": _webp(quats, w, h), "sh0.webp": _webp(sh0, w, h)}
    steps = (np.ptp(ls) / 255, np.ptp(f_dc) * SH_C0 / 255)
    return files, steps


def test_sog_bundle_folder_and_meta(tmp_path):
    k = _known()
    files, (s_step, c_step) = sog_files(*k)
    bundle = tmp_path / "scene.sog"
    with zipfile.ZipFile(bundle, "w") as z:
        for name, data in files.items():
            z.writestr(name, data)
    folder = tmp_path / "scene"
    folder.mkdir()
    for name, data in files.items():
        (folder / name).write_bytes(data)
    for target in (bundle, folder, folder / "meta.json"):
        g = decode_sog(target)
        _check(g, *k, pos=5e-4, log_sig=s_step / 2 + 1e-6, rot=2e-3, colour=c_step / 2 + 1e-6,
               alpha=0.5 / 255 + 1e-6)
        assert open_source(target).info()["gaussians"] == N


# ------------------------------------------------------------------------------ nerfstudio

def write_nerfstudio_ply(path, means, sig, q, a, rgb, n_rest):
    """``ns-export gaussian-splat`` (nerfstudio/scripts/exporter.py ExportGaussianSplat):
    binary little-endian, every property float, in the order x y z nx ny nz f_dc_* f_rest_*
    opacity scale_* rot_* (log scales, logit opacity, w-x-y-z quaternion, zero normals)."""
    n = len(means)
    f_dc = (rgb - 0.5) / SH_C0
    cols = ([means[:, i] for i in range(3)] + [np.zeros(n)] * 3 + [f_dc[:, i] for i in range(3)]
            + [np.full(n, 0.01 * j) for j in range(n_rest)] + [np.log(a / (1 - a))]
            + [np.log(sig[:, i]) for i in range(3)] + [q[:, i] * 1.7 for i in range(4)])
    names = (["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"]
             + [f"f_rest_{j}" for j in range(n_rest)]
             + ["opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"])
    head = ("ply\nformat binary_little_endian 1.0\n" + f"element vertex {n}\n"
            + "".join(f"property float {k}\n" for k in names) + "end_header\n")
    path.write_bytes(head.encode() + np.column_stack(cols).astype("<f4").tobytes())


@pytest.mark.parametrize("n_rest, degree", [(45, 3), (9, 1), (24, 2)])
def test_nerfstudio_gaussian_splat_export(tmp_path, n_rest, degree):
    k = _known()
    p = tmp_path / "splat.ply"
    write_nerfstudio_ply(p, *k, n_rest)
    s = open_source(p)
    assert s.info()["gaussians"] == N and s.info()["sh_degree"] == degree
    ref = GaussianCloud("r", "t", *k)
    np.testing.assert_allclose(s.mean, ref.mean, atol=1e-6)
    np.testing.assert_allclose(s.rgb, ref.rgb, atol=1e-6)
    np.testing.assert_allclose(s.peak, ref.peak, rtol=1e-4)
    np.testing.assert_allclose(s.inv_cov, ref.inv_cov, rtol=1e-3, atol=1e-3)


def test_nerfstudio_open3d_export_at_sh_degree_0(tmp_path):
    """The open3d-written export of splatfacto at SH degree 0: activated colour as uchar
    red/green/blue (``map_to_tensors["colors"] = (colors * 255).astype(np.uint8)``)."""
    from plyfile import PlyData, PlyElement

    means, sig, q, a, rgb = _known()
    names = [("x", "f4"), ("y", "f4"), ("z", "f4"), ("nx", "f4"), ("ny", "f4"), ("nz", "f4"),
             ("red", "u1"), ("green", "u1"), ("blue", "u1"), ("opacity", "f4"),
             ("scale_0", "f4"), ("scale_1", "f4"), ("scale_2", "f4"), ("rot_0", "f4"),
             ("rot_1", "f4"), ("rot_2", "f4"), ("rot_3", "f4")]
    v = np.zeros(N, names)
    for i, k in enumerate("xyz"):
        v[k] = means[:, i]
        v[f"scale_{i}"] = np.log(sig[:, i])
    for i, k in enumerate(("red", "green", "blue")):
        v[k] = _u8(rgb[:, i] * 255)
    v["opacity"] = np.log(a / (1 - a))
    for i in range(4):
        v[f"rot_{i}"] = q[:, i]
    p = tmp_path / "splat.ply"
    PlyData([PlyElement.describe(v, "vertex")]).write(str(p))
    s = open_source(p)
    ref = GaussianCloud("r", "t", means, sig, q, a, rgb)
    np.testing.assert_allclose(s.rgb, ref.rgb, atol=0.5 / 255 + 1e-6)
    np.testing.assert_allclose(s.peak, ref.peak, rtol=1e-4)


# ------------------------------------------------------------------------------ CLI, damage

def _all_formats(tmp_path):
    k = _known()
    out = {}
    write_splat(out.setdefault("splat", tmp_path / "a.splat"), *k)
    write_ksplat(out.setdefault("ksplat", tmp_path / "a.ksplat"), *k, 1)
    write_spz(out.setdefault("spz3", tmp_path / "a3.spz"), 3, *k)
    write_spz(out.setdefault("spz4", tmp_path / "a4.spz"), 4, *k)
    files, _ = sog_files(*k)
    with zipfile.ZipFile(out.setdefault("sog", tmp_path / "a.sog"), "w") as z:
        for name, data in files.items():
            z.writestr(name, data)
    return out


def test_inspect_and_convert_each_format(tmp_path, capsys):
    for kind, p in _all_formats(tmp_path).items():
        assert main(["inspect", "--json", str(p)]) == 0, kind
        info = json.loads(capsys.readouterr().out)
        assert info["gaussians"] == N and info["format"].startswith("splats"), kind
        job = tmp_path / f"job-{kind}"
        assert main(["convert", str(p), "-o", str(job), "--height-mm", "0.3", "--table-size",
                     "17", "--seed", "1"]) == 0, kind
        capsys.readouterr()
        m = json.loads((job / "manifest.json").read_text())
        nx, ny, nz = m["grid_dimensions"]
        assert sum(m["voxel_counts"].values()) == nx * ny * nz and nz > 0


@pytest.mark.parametrize("kind, cut, match", [
    ("splat", 5, r"not a .splat file: .* whole 32-byte records and 27 byte"),
    ("ksplat", 40, r"truncated: the header announces [\d,]+ bytes \(37 splats in 1 section"),
    ("spz4", 9, r"truncated: the header announces 37 Gaussians in [\d,]+ bytes, the file has"),
    ("sog", 300, r"not a SOG bundle|damaged SOG"),
])
def test_damaged_files_one_line(tmp_path, capsys, kind, cut, match):
    p = _all_formats(tmp_path)[kind]
    data = p.read_bytes()
    p.write_bytes(data[:-cut])
    with pytest.raises(DreamPrintError, match=match) as exc:
        open_source(p)
    assert exc.value.path == str(p) or str(exc.value.path) == str(p)
    assert main(["inspect", str(p)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(p) in err


def test_damaged_spz_gzip_payload(tmp_path):
    k = _known()
    p = tmp_path / "t.spz"
    write_spz(p, 3, *k)
    payload = gzip.decompress(p.read_bytes())
    p.write_bytes(gzip.compress(payload[:-20]))
    with pytest.raises(DreamPrintError, match=r"truncated: the header announces 37 Gaussians "
                                              r"\(\d+ bytes unpacked\), the file has \d+"):
        open_source(p)
    p.write_bytes(gzip.compress(payload)[:-30])
    with pytest.raises(DreamPrintError, match="gzip stream itself is cut short"):
        open_source(p)


@pytest.mark.parametrize("version", [3, 4])
def test_spz_from_gsply_writer_agrees_with_gsply_reader(tmp_path, version):
    """An independent writer and reader (gsply) against this decoder."""
    import gsply
    from gsply.gsdata import GSData

    means, sig, q, a, rgb = _known(200, 5)
    data = GSData(means=means.astype(np.float32), scales=np.log(sig).astype(np.float32),
                  quats=q.astype(np.float32), opacities=np.log(a / (1 - a)).astype(np.float32),
                  sh0=((rgb - 0.5) / SH_C0).astype(np.float32), shN=None)
    p = tmp_path / "g.spz"
    gsply.write_spz(p, data, version=version)
    g, ref = decode_spz(p), gsply.read_spz(p)
    np.testing.assert_allclose(g.means, ref.means, atol=1e-6)
    np.testing.assert_allclose(np.log(g.sigmas), ref.scales, atol=1e-5)
    _same_rotation(g.quats, np.asarray(ref.quats, float), 1e-5)
    np.testing.assert_allclose(g.rgb, 0.5 + SH_C0 * np.asarray(ref.sh0, float), atol=1e-5)
    _check(g, means, sig, q, a, rgb, pos=0.5 / 4096 + 1e-6, log_sig=0.5 / 16 + 1e-6, rot=2e-4,
           colour=SH_C0 * 0.5 / (0.15 * 255) + 1e-6, alpha=0.5 / 255 + 1e-6)


def test_a_ply_that_is_not_a_ply_is_said_so(tmp_path, capsys):
    """A text file named .ply is "not a PLY file", not "not an SPZ file" (issue 46); an SPZ
    named .ply still opens as SPZ."""
    p = tmp_path / "notes.ply"
    p.write_text("hello, this is text\n")
    with pytest.raises(DreamPrintError, match="not a PLY file: it does not start with the "
                                              "line 'ply'") as exc:
        open_source(p)
    assert "SPZ" not in str(exc.value)
    p.write_bytes(b"")
    with pytest.raises(DreamPrintError, match="not a PLY file: it is empty"):
        open_source(p)
    k = _known()
    spz = tmp_path / "t.spz"
    write_spz(spz, 3, *k)
    misnamed = tmp_path / "t.ply"
    misnamed.write_bytes(spz.read_bytes())
    assert open_source(misnamed).n_total == open_source(spz).n_total
