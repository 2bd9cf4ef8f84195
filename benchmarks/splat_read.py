"""Decode speed of the splat exchange formats (issue 18): Gaussians/s of
``io.volumes.splats.formats.decode_*`` for antimatter15 ``.splat``, ``.ksplat`` level 0 and SPZ
v3 (gzip) / v4 (zstd), on ``--n`` synthetic Gaussians (default 1e6), best of ``--repeat``. The SPZ
files are written by gsply's writer, the others by the layouts' definitions (numpy). Files go to a
temporary folder (``--dir``, default the system's). Run from the checkout root:

    PYTHONPATH=. python benchmarks/splat_read.py [--n 1000000] [--repeat 3]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from dreamprint_gui.io.volumes.splats import formats as sf


def _gaussians(n: int, seed: int = 1):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return (rng.uniform(-2, 2, (n, 3)), np.exp(rng.uniform(-5, -2, (n, 3))), q,
            rng.uniform(0.05, 0.95, n), rng.uniform(0.05, 0.95, (n, 3)))


def write_splat(path: Path, means, sig, q, a, rgb) -> None:
    rec = np.zeros(len(means), [("pos", "<f4", 3), ("scale", "<f4", 3), ("rgba", "u1", 4),
                                ("rot", "u1", 4)])
    rec["pos"], rec["scale"] = means, sig
    rec["rgba"] = np.clip(np.round(np.column_stack([rgb, a]) * 255), 0, 255)
    rec["rot"] = np.clip(np.round(q * 128 + 128), 0, 255)
    rec.tofile(path)


def write_ksplat0(path: Path, means, sig, q, a, rgb) -> None:
    n = len(means)
    head = np.zeros(1024, "<u4")
    head.view(np.uint8)[1] = 1
    head[1:5] = [1, 1, n, n]
    sec = np.zeros(256, "<u4")
    sec[0:2] = [n, n]
    rec = np.zeros(n, [("c", "<f4", 3), ("s", "<f4", 3), ("r", "<f4", 4), ("rgba", "u1", 4)])
    rec["c"], rec["s"], rec["r"] = means, sig, q
    rec["rgba"] = np.clip(np.round(np.column_stack([rgb, a]) * 255), 0, 255)
    path.write_bytes(head.tobytes() + sec.tobytes() + rec.tobytes())


def write_spz(path: Path, version: int, means, sig, q, a, rgb) -> None:
    import gsply
    from gsply.gsdata import GSData

    f_dc = (rgb - 0.5) / sf.SH_C0
    data = GSData(means=means.astype(np.float32), scales=np.log(sig).astype(np.float32),
                  quats=q.astype(np.float32), opacities=np.log(a / (1 - a)).astype(np.float32),
                  sh0=f_dc.astype(np.float32), shN=None)
    gsply.write_spz(path, data, version=version)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=float, default=1e6)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--dir", default=None)
    args = ap.parse_args()
    n = int(args.n)
    g = _gaussians(n)
    with tempfile.TemporaryDirectory(dir=args.dir) as tmp:
        tmp = Path(tmp)
        cases = {".splat": (tmp / "a.splat", write_splat, sf.decode_splat),
                 ".ksplat level 0": (tmp / "a.ksplat", write_ksplat0, sf.decode_ksplat),
                 "SPZ v3 (gzip)": (tmp / "a3.spz", lambda p, *k: write_spz(p, 3, *k),
                                   sf.decode_spz),
                 "SPZ v4 (zstd)": (tmp / "a4.spz", lambda p, *k: write_spz(p, 4, *k),
                                   sf.decode_spz)}
        for name, (path, write, decode) in cases.items():
            write(path, *g)
            best = float("inf")
            for _ in range(args.repeat):
                t0 = time.perf_counter()
                out = decode(path)
                best = min(best, time.perf_counter() - t0)
            assert len(out.means) == n
            print(f"{name:16s} {n:,} Gaussians, {path.stat().st_size / 2**20:7.1f} MiB: "
                  f"{best * 1e3:7.1f} ms  ({n / best / 1e6:5.2f} M Gaussians/s)")


if __name__ == "__main__":
    main()
