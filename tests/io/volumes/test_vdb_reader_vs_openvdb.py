"""The in-process OpenVDB reader (io/volumes/vdb/vdb_file.py) against OpenVDB's own library
(Debian's python3-openvdb in a subprocess; skipped where absent): the sample file and files
written here with pyopenvdb (float fog, the 7 mask-compression codes, tiles of every level,
inactive tiles with values, vec3 colour, a level set, each also saved as half floats) and
re-encoded with zip and without compression. Compared: grid names, classes, half flags,
active voxel counts, index boxes, transforms, every active voxel and tile, every inactive
value that differs from the background, and the dense values the sampler sees. Then bad
input: one-line errors naming the file, the grid and the reason."""

import json
import random
import struct
import subprocess
import textwrap
import zlib

import numpy as np
import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes import open_source
from dreamprint_gui.io.volumes.vdb import openvdb
from dreamprint_gui.io.volumes.vdb import vdb_file as V

WRITE = textwrap.dedent('''
    import sys
    import numpy as np
    import pyopenvdb as vdb
    out = sys.argv[1]
    rng = np.random.default_rng(3)

    def xf(g, voxel=0.1, offset=(0.3, -1.0, 2.0)):
        g.transform = vdb.createLinearTransform(voxelSize=voxel)
        g.transform.translate(offset)
        return g

    a = rng.random((40, 30, 20)).astype(np.float32)
    a[a < 0.5] = 0
    fog = vdb.FloatGrid()
    fog.copyFromArray(a, (-13, 5, 7), 0.0)
    fog.name = "density"
    fog.gridClass = vdb.GridClass.FOG_VOLUME
    xf(fog)
    # one leaf per mask-compression code (io/Compression.h), background 1.5
    codes = vdb.FloatGrid(1.5)
    codes.name = "codes"
    acc = codes.getAccessor()
    inactive = [None, [-1.5], [7.0], [1.5, -1.5], [1.5, 7.0], [7.0, -3.0], [7.0, -3.0, 11.0]]
    for n, vals in enumerate(inactive):
        for x in range(8):
            for y in range(8):
                for z in range(8):
                    ijk = (n * 8 + x, y, z)
                    if (x + y + z) % 3 == 0:
                        acc.setValueOn(ijk, float(rng.random()))
                    elif vals is not None:
                        acc.setValueOff(ijk, vals[(x * 7 + y * 3 + z) % len(vals)])
    xf(codes)
    # tiles: a 128^3 tile of an upper internal node, 8^3 tiles of a lower node, inactive
    # tiles with values, voxels between them
    tiles = vdb.FloatGrid()
    tiles.name = "tiles"
    tiles.gridClass = vdb.GridClass.FOG_VOLUME
    tiles.fill((0, 0, 0), (127, 127, 127), 0.25)
    tiles.fill((128, 0, 0), (135, 7, 7), 0.5)
    tiles.fill((136, 0, 0), (143, 7, 7), 0.75, False)
    tiles.fill((0, 128, 0), (127, 255, 127), 0.125, False)
    tiles.getAccessor().setValueOn((140, 20, 3), 2.0)
    xf(tiles, voxel=0.02)
    vt = vdb.Vec3SGrid()
    vt.name = "Cd"
    vt.fill((0, 0, 0), (127, 127, 127), (0.2, 0.4, 0.8))
    vt.fill((128, 8, 0), (135, 15, 7), (1.0, 0.5, 0.25))
    vt.fill((136, 8, 0), (143, 15, 7), (0.3, 0.3, 0.3), False)
    c = rng.random((12, 10, 9, 3)).astype(np.float32)
    vt.copyFromArray(c, (150, -20, 4), (0.0, 0.0, 0.0))
    xf(vt, voxel=0.02)
    vel = vdb.Vec3SGrid()
    vel.name = "velocity"
    vel.copyFromArray((rng.random((20, 16, 12, 3)) - 0.5).astype(np.float32), (3, 3, 3),
                      (0.0, 0.0, 0.0))
    xf(vel)
    ls = vdb.createLevelSetSphere(radius=3.0, center=(0.2, 0.1, 0.0), voxelSize=0.1,
                                  halfWidth=3.0)
    ls.name = "surface"
    root = vdb.FloatGrid()
    root.name = "root_tile"
    root.fill((0, 0, 0), (4095, 4095, 4095), 0.5)
    root.fill((4096, 0, 0), (8191, 4095, 4095), 0.3, False)
    grids = [fog, codes, tiles, vt, vel]
    for half in (False, True):
        for g in grids + [ls, root]:
            g.saveFloatAsHalf = half
        sfx = "_half" if half else ""
        vdb.write(f"{out}/grids{sfx}.vdb", grids)
        vdb.write(f"{out}/levelset{sfx}.vdb", [ls])
        vdb.write(f"{out}/root_tile{sfx}.vdb", [root])
    inst = fog.copy()                 # shares the tree: written as an instance of "density"
    inst.name = "density_copy"
    vdb.write(f"{out}/instanced.vdb", [fog, inst])
    fr = vdb.FloatGrid()
    fr.fill((0, 0, 0), (7, 7, 7), 1.0)
    fr.name = "density"
    fr.transform = vdb.createFrustumTransform((0, 0, 0), (7, 7, 7), 0.5, 1.0)
    vdb.write(f"{out}/frustum.vdb", [fr])
''')

ORACLE = textwrap.dedent('''
    import json, sys
    import numpy as np
    import pyopenvdb as vdb
    path, out = sys.argv[1], sys.argv[2]
    grids, _ = vdb.readAll(path)
    res = []
    for n, g in enumerate(grids):
        t = g.transform
        o = t.indexToWorld((0, 0, 0))
        nc = 3 if g.valueTypeName.startswith("vec3") else 1
        bg = np.ravel(np.asarray(g.background, np.float64))
        ent = {"on": [], "off": []}
        for key, it in (("on", g.citerOnValues()), ("off", g.citerOffValues())):
            for v in it:
                val = np.ravel(np.asarray(v["value"], np.float64))
                if key == "off" and np.array_equal(val, bg):
                    continue
                ent[key].append(list(v["min"]) + list(v["max"]) + list(val))
        for key, rows in ent.items():
            np.save(f"{out}/{n}.{key}.npy", np.asarray(rows, np.float64).reshape(-1, 6 + nc))
        (lo, hi) = g.evalActiveVoxelBoundingBox()
        dense = None
        if g.activeVoxelCount() and np.prod(np.subtract(hi, lo) + 1) <= 4e6:
            a = np.empty(tuple(np.subtract(hi, lo) + 1) + ((3,) if nc == 3 else ()), np.float32)
            a[...] = np.float32(bg) if nc == 1 else bg.astype(np.float32)
            g.copyToArray(a, lo)
            np.save(f"{out}/{n}.dense.npy", a.reshape(a.shape[:3] + (nc,)))
            dense = True
        res.append({"name": g.name, "class": str(g.gridClass), "type": g.valueTypeName,
                    "half": bool(g.saveFloatAsHalf), "active": int(g.activeVoxelCount()),
                    "bbox": [list(lo), list(hi)], "origin": list(o), "dense": dense,
                    "columns": [[t.indexToWorld(e)[r] - o[r] for r in range(3)]
                                for e in ((1, 0, 0), (0, 1, 0), (0, 0, 1))]})
    print(json.dumps(res))
''')


@pytest.fixture(scope="module")
def written(tmp_path_factory, openvdb_python):
    out = tmp_path_factory.mktemp("vdbx")
    (out / "write.py").write_text(WRITE)
    subprocess.run([openvdb_python, "-I", str(out / "write.py"), str(out)], check=True)
    return out


def _oracle(py, path, tmp):
    d = tmp / (path.stem + "-oracle")
    d.mkdir()
    (d / "o.py").write_text(ORACLE)
    r = subprocess.run([py, "-I", str(d / "o.py"), str(path), str(d)], capture_output=True,
                       text=True, check=True)
    return json.loads(r.stdout), d


def _mine(g: V.VdbGrid, bg):
    """Rows (min xyz, max xyz, value...) of active and of non-background inactive entries."""
    nc = g.channels
    on, off = [], []
    act = g.leaf_active
    vals = g.leaf_values.astype(np.float64)
    pos = np.stack(np.meshgrid(*(np.arange(8),) * 3, indexing="ij"), -1).reshape(512, 3)
    for m, rows in ((act, on), (~act & np.any(vals != bg, axis=2), off)):
        li, vi = np.nonzero(m)
        xyz = g.leaf_origins[li] + pos[vi]
        rows.append(np.concatenate([xyz, xyz, vals[li, vi]], 1))
    for o, v, a in g.root_tiles:
        v = np.asarray(v, np.float64)
        if a or np.any(v != bg):
            (on if a else off).append(np.concatenate([o, np.asarray(o) + V.UPPER - 1, v])[None])
    for nodes, side, dim in ((g.upper, V.LOWER, 32), (g.lower, V.LEAF, 16)):
        for nd in nodes:                         # the node's tiles: every slot without a child
            s = np.nonzero(~nd.child)[0]
            loc = np.stack([s // (dim * dim), (s // dim) % dim, s % dim], 1) * side
            o = np.asarray(nd.origin) + loc
            v = nd.values[s].astype(np.float64).reshape(s.size, nc)
            a = np.asarray(nd.active[s], bool)
            rows = np.concatenate([o, o + side - 1, v], 1)
            on.append(rows[a])
            off.append(rows[~a & np.any(v != bg, axis=1)])
    return [np.concatenate(r).reshape(-1, 6 + nc) if r else np.zeros((0, 6 + nc))
            for r in (on, off)]


def _sorted(a):
    return a[np.lexsort(a.T[::-1])] if len(a) else a


def _compare(py, path, tmp):
    """Every grid of ``path`` through vdb_file against OpenVDB's reading of it."""
    want, d = _oracle(py, path, tmp)
    vf = V.read_file(path)
    by_name = {gd.name: gd for gd in vf.grids}
    assert sorted(by_name) == sorted(w["name"] for w in want)
    res, _ = openvdb._read(path)
    infos = {i["name"]: i for i in res["grids"]}
    for n, w in enumerate(want):
        g = V.read_grid(vf, by_name[w["name"]])
        st = g.stats()
        assert (g.grid_class, g.value_type, g.half) == (w["class"], w["type"], w["half"])
        assert st["active_voxels"] == w["active"], w["name"]
        assert st["bbox"] == w["bbox"], w["name"]
        assert g.transform["origin"] == w["origin"] and g.transform["columns"] == w["columns"]
        bg = g.background.astype(np.float64)
        on, off = _mine(g, bg)
        np.testing.assert_array_equal(_sorted(on), _sorted(np.load(d / f"{n}.on.npy")))
        np.testing.assert_array_equal(_sorted(off), _sorted(np.load(d / f"{n}.off.npy")))
        if w["dense"]:
            # the blocks the sampler gets, made dense over the active box: OpenVDB's values
            ref = np.load(d / f"{n}.dense.npy")
            lo = np.asarray(w["bbox"][0])
            o, v = g.blocks(*w["bbox"], max_bytes=1 << 30)
            dense = np.empty(ref.shape, np.float32)
            dense[...] = bg.astype(np.float32)
            for org, blk in zip(o - lo, v, strict=True):
                s = [slice(max(c, 0), c + 8) for c in org]
                src = blk[tuple(slice(max(-c, 0), 8) for c in org)]
                tgt = dense[tuple(s)]
                tgt[...] = src[:tgt.shape[0], :tgt.shape[1], :tgt.shape[2]]
            np.testing.assert_array_equal(dense, ref, err_msg=w["name"])
        info = infos[w["name"]]
        assert info["active_voxels"] == w["active"] and info["bbox"] == w["bbox"]
    return want


@pytest.mark.parametrize("name", ["grids.vdb", "grids_half.vdb", "levelset.vdb",
                                  "levelset_half.vdb", "root_tile.vdb", "root_tile_half.vdb"])
def test_written_files_read_as_openvdb_reads_them(written, openvdb_python, tmp_path, name):
    want = _compare(openvdb_python, written / name, tmp_path)
    assert want


def test_sample_file_reads_as_openvdb_reads_it(shared_data, openvdb_python, tmp_path):
    want = _compare(openvdb_python,
                    shared_data / "volumes" / "blender_mantaflow_fluid_data_0190.vdb", tmp_path)
    assert {w["name"] for w in want} == {"density", "flame", "shadow", "temperature",
                                         "velocity"}


def _recode(src, dst, mode: str) -> None:
    """Re-encode every value chunk of ``src`` as zip (``mode="zip"``) or raw (``"none"``),
    set each grid's compression flags accordingly and move the descriptors' offsets: the
    layout of io/Compression.cc (``zipToStream``: int64 size + zlib stream). The grids'
    delayed-load metadata (the compressed size of each leaf) gets an unknown temporary type
    name of the same length, which OpenVDB skips."""
    raw = src.read_bytes().replace(b"__delayedload", b"__delayedlxad")
    vf = V.read_file(src)
    edits = []                                   # (start, end, new bytes)
    for gd in vf.grids:
        log = []
        V.read_grid(vf, gd, chunk_log=log)
        flags = struct.unpack_from("<I", raw, gd.grid_pos)[0]
        new = (flags & V.COMPRESS_ACTIVE_MASK) | (V.COMPRESS_ZIP if mode == "zip" else 0)
        edits.append((gd.grid_pos, gd.grid_pos + 4, struct.pack("<I", new)))
        for a, b, data in log:
            if a == b:                           # no chunk at all (zero half floats)
                continue
            if mode == "zip" and not data:       # zipToStream of nothing: size 0
                rep = struct.pack("<q", 0)
            elif mode == "zip":
                z = zlib.compress(data)
                rep = struct.pack("<q", len(z)) + z
            else:
                rep = data
            edits.append((a, b, rep))
    edits.sort()

    def moved(p):                                # new position of old offset p
        return p + sum(len(r) - (b - a) for a, b, r in edits if b <= p)

    out, last = bytearray(), 0
    for a, b, r in edits:
        out += raw[last:a] + r
        last = b
    out += raw[last:]
    for gd in vf.grids:                          # the three int64 offsets end at grid_pos
        at = moved(gd.grid_pos) - 24
        out[at:at + 24] = struct.pack("<qqq", moved(gd.grid_pos), moved(gd.block_pos),
                                      moved(gd.end_pos))
    dst.write_bytes(bytes(out))


@pytest.mark.parametrize("mode", ["zip", "none"])
@pytest.mark.parametrize("name", ["grids.vdb", "grids_half.vdb", "levelset.vdb"])
def test_zip_and_uncompressed_files(written, openvdb_python, tmp_path, mode, name):
    f = tmp_path / f"{mode}-{name}"
    _recode(written / name, f, mode)
    vf = V.read_file(f)
    flags = {struct.unpack_from("<I", vf.buf, gd.grid_pos)[0] for gd in vf.grids}
    assert flags == ({V.COMPRESS_ZIP | V.COMPRESS_ACTIVE_MASK} if mode == "zip"
                     else {V.COMPRESS_ACTIVE_MASK})
    _compare(openvdb_python, f, tmp_path)        # OpenVDB reads the re-encoded file too


def test_product_opens_tiles_and_half_grids(written):
    s = open_source(written / "grids_half.vdb", density_grid="tiles", colour_grid="Cd")
    # the 128^3 tile and the 8^3 tile (active), filled at their own size, in the blocks
    b = s.density.blocks
    assert b.n_leaves == 4096 + 1 + 1 + 1          # 128^3 tile, 8^3 tiles x2, one leaf
    assert s.info()["grids"][0]["dtype"].endswith("(half on disk)")


# ------------------------------------------------------------------------------ bad input
def _one_line(capsys, f, *extra):
    assert main(["inspect", str(f), *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith(f"dreamprint: error: {f}: ")
    return err


def test_unsupported_content_named(written, tmp_path, capsys):
    with pytest.raises(DreamPrintError, match="grid 'density_copy': an instance of grid "
                                              "'density'"):
        open_source(written / "instanced.vdb", density_grid="density_copy")
    # the instance's parent still opens
    assert open_source(written / "instanced.vdb", density_grid="density").density.blocks.n_leaves
    with pytest.raises(DreamPrintError, match="grid 'density': a frustum transform"):
        open_source(written / "frustum.vdb")
    raw = (written / "grids.vdb").read_bytes()
    f = tmp_path / "type.vdb"
    f.write_bytes(raw.replace(b"Tree_float_5_4_3", b"Tree_fluat_5_4_3"))
    with pytest.raises(DreamPrintError, match=r"type\.vdb: grid 'density': holds fluat "
                                              r"values \(Tree_fluat_5_4_3\)"):
        open_source(f)
    info = openvdb.inspect_path(f)         # listed, with its reason; the others still read
    assert {g["name"]: g["class"].split(" ")[0] for g in info["grids"]} == {
        "density": "unsupported", "codes": "unsupported", "tiles": "unsupported",
        "Cd": "unknown", "velocity": "unknown"}
    f.write_bytes(raw[:8] + struct.pack("<I", 226) + raw[12:])
    assert "format version 226 is newer than 225" in _one_line(capsys, f)
    with pytest.raises(DreamPrintError, match="root_tile.*GB of voxel values, more than"):
        open_source(written / "root_tile.vdb", density_grid="root_tile")


def test_damaged_data_named(written, tmp_path, capsys):
    src = written / "grids.vdb"
    raw = bytearray(src.read_bytes())
    vf = V.read_file(src)
    gd = next(g for g in vf.grids if g.name == "density")
    log = []
    V.read_grid(vf, gd, chunk_log=log)
    a, b, _ = log[-1]                             # the last leaf's blosc chunk
    f = tmp_path / "d.vdb"
    bad = bytearray(raw)
    bad[a + 8 + 4:a + 8 + 8] = struct.pack("<I", 123456)    # blosc header: wrong size
    f.write_bytes(bytes(bad))
    assert "grid 'density': damaged: a leaf's values does not decompress" in \
        _one_line(capsys, f)
    bad = bytearray(raw)
    bad[a - 1] = 9                                # the leaf's compression metadata byte
    f.write_bytes(bytes(bad))
    assert "grid 'density': damaged: a leaf's values has compression metadata 9" in \
        _one_line(capsys, f)
    bad = bytearray(raw)
    at = gd.grid_pos - 16                         # the descriptor's block offset
    bad[at:at + 8] = struct.pack("<q", gd.block_pos + 8)
    f.write_bytes(bytes(bad))
    assert "grid 'density': damaged: its topology ends at byte" in _one_line(capsys, f)


def test_random_damage_never_crashes(written, tmp_path):
    """Bytes overwritten anywhere in the grids' data: a DreamPrintError or a read, never
    another exception."""
    raw = (written / "levelset.vdb").read_bytes()
    start = V.read_file(written / "levelset.vdb").grids[0].grid_pos
    rng = random.Random(5)
    f = tmp_path / "r.vdb"
    errors = 0
    for _ in range(150):
        b = bytearray(raw)
        p = rng.randrange(start, len(b) - 4)
        b[p:p + 4] = rng.randbytes(4)
        f.write_bytes(bytes(b))
        try:
            openvdb.inspect_path(f)
        except DreamPrintError as exc:
            assert str(exc).startswith(str(f)) and "\n" not in str(exc)
            errors += 1
    assert errors > 0


# ---------------------------------------------------------- double and vec3d, by the spec
def _spec_file(path, value_type: str, nc: int) -> None:
    """A one-grid .vdb written to the layout of OpenVDB's io/Archive.cc, tree/RootNode.h,
    InternalNode.h and LeafNode.h, uncompressed with all values stored (flags 0, metadata
    code 6): an inactive root tile with a value, an active 128^3 tile, an active 8^3 tile, an
    active/inactive leaf. pyopenvdb writes no double grids: this writer is checked against
    OpenVDB with float / vec3s, then gives the same content as double / vec3d."""
    dt = {"float": "<f4", "vec3s": "<f4", "double": "<f8", "vec3d": "<f8"}[value_type]

    def val(*v):
        return np.asarray(np.broadcast_to(np.asarray(v, np.float64), (nc,)), dt).tobytes()

    def s(x: str) -> bytes:
        return struct.pack("<I", len(x)) + x.encode()

    def mask(n, on) -> bytes:
        bits = np.zeros(n, bool)
        bits[list(on)] = True
        return np.packbits(bits, bitorder="little").tobytes()

    leaf_vals = (np.arange(512 * nc, dtype=np.float64).reshape(512, nc) % 97) / 64 - 0.5
    leaf_on = [n for n in range(512) if n % 5 != 0]
    grid = struct.pack("<I", 0)                                   # flags: no compression
    grid += struct.pack("<I", 2) + s("class") + s("string") + s("fog volume")
    grid += s("name") + s("string") + s("density")
    grid += s("ScaleTranslateMap") + struct.pack("<18d", 0.5, -1.0, 2.0, 0.1, 0.1, 0.1,
                                                 *([0.1] * 3 + [10.0] * 3 + [100.0] * 3
                                                   + [5.0] * 3))
    grid += struct.pack("<i", 1) + val(0.0)                       # buffer count, background
    grid += struct.pack("<II", 1, 1)                              # one tile, one child
    grid += struct.pack("<3i", 4096, 0, 0) + val(0.375) + b"\x00"  # inactive root tile
    grid += struct.pack("<3i", 0, 0, 0)
    up = np.zeros((32768, nc))
    up[1] = 0.25                                                  # slot 1: (0, 0, 128)
    grid += mask(32768, [0]) + mask(32768, [1]) + b"\x06" + up.astype(dt).tobytes()
    lo = np.zeros((4096, nc))
    lo[1] = 0.75                                                  # slot 1: (0, 0, 8)
    grid += mask(4096, [0]) + mask(4096, [1]) + b"\x06" + lo.astype(dt).tobytes()
    grid += mask(512, leaf_on)                                    # the leaf's topology
    block = len(grid)
    grid += mask(512, leaf_on) + b"\x06" + leaf_vals.astype(dt).tobytes()
    uuid = b"6f1d2c3a-8b4e-4f60-9a7b-2c5d8e9f0a1b"   # OpenVDB lists no grids for all-zero text
    head = struct.pack("<qIIIb", V.MAGIC, 224, 10, 0, 1) + uuid + struct.pack("<Ii", 0, 1)
    desc = s("density") + s(f"Tree_{value_type}_5_4_3") + s("")
    g0 = len(head) + len(desc) + 24
    path.write_bytes(head + desc + struct.pack("<qqq", g0, g0 + block, g0 + len(grid)) + grid)


@pytest.mark.parametrize("single, double, nc", [("float", "double", 1), ("vec3s", "vec3d", 3)])
def test_double_grids_by_the_spec(openvdb_python, tmp_path, single, double, nc):
    a, b = tmp_path / f"{single}.vdb", tmp_path / f"{double}.vdb"
    _spec_file(a, single, nc)
    _spec_file(b, double, nc)
    _compare(openvdb_python, a, tmp_path)        # the writer, checked by OpenVDB
    ga, gb = (V.read_grid(V.read_file(f), V.read_file(f).grids[0]) for f in (a, b))
    assert gb.value_type == double and gb.leaf_values.dtype == np.float64
    sa, sb = ga.stats(), gb.stats()
    assert sa["active_voxels"] == sb["active_voxels"] == 128 ** 3 + 512 + 409
    assert sa["bbox"] == sb["bbox"] == [[0, 0, 0], [127, 127, 255]]
    np.testing.assert_array_equal(sa["active_values"], sb["active_values"])
    np.testing.assert_array_equal(_mine(ga, 0.0)[1], _mine(gb, 0.0)[1])
    assert openvdb.inspect_path(b)["grids"][0]["dtype"] == double
    if nc == 1:
        assert open_source(b).density.blocks.n_leaves == 4096 + 1 + 1
