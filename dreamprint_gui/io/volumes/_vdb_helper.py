"""Out-of-process OpenVDB reader, run as ``/usr/bin/python3 -I _vdb_helper.py CMD ...``.

Debian's ``python3-openvdb`` (pyopenvdb, OpenVDB 10) reads every VDB variant correctly (blosc,
zip, half floats, all grid classes) but only under Debian's own Python and NumPy 1.x, so it runs
here, isolated, and hands over plain files.  Commands (JSON on stdout, ``{"error": ...}`` and
exit status 1 on failure):

* ``info FILE``: per grid name, class, value type, active voxels, index bbox, min/max,
  background, half-float flag and the index-to-world affine map.
* ``extract FILE OUTDIR NAME...``: for each named grid, ``OUTDIR/<n>.origins.npy`` (L, 3) int32
  leaf origins (multiples of 8) and ``OUTDIR/<n>.values`` raw float32 (L, 8, 8, 8, C) values
  indexed [leaf, i%8, j%8, k%8, c].  Leaves are found chunk by chunk (128^3, one lower internal
  node) with ``getValueDepth``: a chunk held by a root/upper tile is constant (skipped when it is
  the background), otherwise its values are copied densely and the 8^3 blocks that differ from
  the background are kept.  Values include inactive ones, as OpenVDB's own samplers read them.

Must import under Debian's Python without this package (no relative imports).
"""

import json
import sys

CHUNK = 128


def _transform(g):
    t = g.transform
    o = t.indexToWorld((0, 0, 0))
    cols = [[t.indexToWorld(e)[r] - o[r] for r in range(3)]
            for e in ((1, 0, 0), (0, 1, 0), (0, 0, 1))]
    return {"origin": list(o), "columns": cols, "linear": bool(t.isLinear)}


VEC_RANGE_LIMIT = 4_000_000  # active values read one by one (~1.4 us each) for a vector range


def _vector_range(g):
    """Per-component (min, max) and magnitude (min, max) over the active values of a vector grid
    (a tile counts as its value), or None when it has more than VEC_RANGE_LIMIT active voxels."""
    if g.activeVoxelCount() > VEC_RANGE_LIMIT or g.activeVoxelCount() == 0:
        return None
    lo = [float("inf")] * 3
    hi = [float("-inf")] * 3
    mlo, mhi = float("inf"), 0.0
    for it in g.citerOnValues():
        v = it["value"]
        m2 = 0.0
        for c in range(3):
            x = float(v[c])
            lo[c] = min(lo[c], x)
            hi[c] = max(hi[c], x)
            m2 += x * x
        m = m2 ** 0.5
        mlo = min(mlo, m)
        mhi = max(mhi, m)
    return {"component_min": lo, "component_max": hi, "magnitude": [mlo, mhi]}


def _grid_info(g):
    empty = g.empty() or g.activeVoxelCount() == 0
    bbox = g.evalActiveVoxelBoundingBox()
    try:
        lo, hi = g.evalMinMax()
    except Exception:  # noqa: BLE001
        lo = hi = None
    meta = {}
    for k, v in dict(g.metadata).items():
        if isinstance(v, (int, float, str, bool)):
            meta[k] = v
    vec = _vector_range(g) if g.valueTypeName.startswith("vec") else None
    return {"name": g.name, "class": str(g.gridClass), "type": g.valueTypeName, "vector": vec,
            "active_voxels": int(g.activeVoxelCount()), "empty": bool(empty),
            "bbox": [list(bbox[0]), list(bbox[1])], "min": lo, "max": hi,
            "background": g.background, "half": bool(g.saveFloatAsHalf),
            "transform": _transform(g), "metadata": meta}


def _extract(g, out_prefix):
    import numpy as np

    nc = 3 if g.valueTypeName.startswith("vec3") else 1
    bg = np.asarray(g.background, np.float32).reshape(nc)
    origins = []
    n = 0
    with open(out_prefix + ".values", "wb") as out:
        if not (g.empty() or g.activeVoxelCount() == 0):
            (i0, j0, k0), (i1, j1, k1) = g.evalActiveVoxelBoundingBox()
            acc = g.getConstAccessor()
            shape = (CHUNK, CHUNK, CHUNK) + ((3,) if nc == 3 else ())
            arr = np.empty(shape, np.float32)
            starts = [range((a // CHUNK) * CHUNK, b + 1, CHUNK)
                      for a, b in ((i0, i1), (j0, j1), (k0, k1))]
            grid_idx = np.stack(np.meshgrid(*(np.arange(16) * 8,) * 3, indexing="ij"), -1)
            grid_idx = grid_idx.reshape(-1, 3)
            for ci in starts[0]:
                for cj in starts[1]:
                    for ck in starts[2]:
                        depth = acc.getValueDepth((ci, cj, ck))
                        if depth < 0:
                            continue
                        if depth <= 1:       # a tile covering the whole chunk: constant
                            v = np.asarray(acc.getValue((ci, cj, ck)), np.float32).reshape(nc)
                            if np.array_equal(v, bg):
                                continue
                            blocks = np.broadcast_to(v, (4096, 8, 8, 8, nc))
                            keep = np.arange(4096)
                        else:
                            arr[...] = bg.reshape(()) if nc == 1 else bg
                            g.copyToArray(arr, (ci, cj, ck))
                            b = arr.reshape(16, 8, 16, 8, 16, 8, nc)
                            b = b.transpose(0, 2, 4, 1, 3, 5, 6).reshape(4096, 8, 8, 8, nc)
                            keep = np.nonzero(np.any((b != bg).reshape(4096, -1), axis=1))[0]
                            blocks = b[keep]
                        if len(keep) == 0:
                            continue
                        out.write(np.ascontiguousarray(blocks, np.float32).tobytes())
                        origins.append(grid_idx[keep] + np.array([ci, cj, ck]))
                        n += len(keep)
    o = np.concatenate(origins).astype(np.int32) if origins else np.zeros((0, 3), np.int32)
    np.save(out_prefix + ".origins.npy", o)
    return {"name": g.name, "leaves": int(n), "channels": nc,
            "background": bg.tolist()}


def main(argv):
    import pyopenvdb as vdb

    cmd, path = argv[0], argv[1]
    if cmd == "info":
        grids, meta = vdb.readAll(path)
        file_meta = {k: v for k, v in dict(meta).items()
                     if isinstance(v, (int, float, str, bool))}
        return {"grids": [_grid_info(g) for g in grids], "metadata": file_meta}
    if cmd == "extract":
        outdir, names = argv[2], argv[3:]
        done = []
        for n, name in enumerate(names):
            g = vdb.read(path, name)
            info = _extract(g, f"{outdir}/{n}")
            info.update(_grid_info(g))
            done.append(info)
        return {"grids": done}
    raise SystemExit(f"unknown command {cmd}")


if __name__ == "__main__":
    try:
        if len(sys.argv) > 3 and sys.argv[1] == "--max-bytes":
            import resource

            limit = int(sys.argv[2])
            resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
            del sys.argv[1:3]
        result = main(sys.argv[1:])
    except ImportError as exc:
        print(json.dumps({"error": f"missing reader: {exc}", "missing": True}))
        sys.exit(1)
    except MemoryError:
        print(json.dumps({"error": "not enough memory to read this grid (damaged header?)"}))
        sys.exit(1)
    except Exception as exc:  # noqa: BLE001 - reported to the parent as one line
        print(json.dumps({"error": str(exc) or type(exc).__name__}))
        sys.exit(1)
    print(json.dumps(result))
