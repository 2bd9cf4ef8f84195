"""Where a proof's seconds go: one ``dreamprint proof`` run, stage by stage, and Dr.Jit's kernels.

Runs the proof as the CLI does (:func:`dreamprint_gui.proof.runner.run_proof`) in this process
and prints:

- the import of Mitsuba and Dr.Jit and the selection of the LLVM variant (wall seconds);
- the proof's own stages (``proof.json`` ``timings_s``: labels, source render, print render,
  comparison), wall and CPU seconds (all threads) and the load average before and after;
- every ``mitsuba.render`` call of the print (one per view, pass and half): wall seconds and,
  from Dr.Jit's kernel history (``dr.JitFlag.KernelHistory``), the JIT kernels it launched:
  how many were compiled (codegen + LLVM backend milliseconds) and how many were found in
  Dr.Jit's kernel cache (in memory, or on disk under ``~/.drjit``), and the milliseconds the
  kernels ran. A render whose kernels are cache hits paid no compilation.

    python benchmarks/profile_proof.py [SOURCE] [--height-mm 40] [--views 4]
                                       [--resolution 256] [--spp 64]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from collections import Counter
from pathlib import Path


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("source", nargs="?", default="demo")
    ap.add_argument("--height-mm", type=float, default=40.0)
    ap.add_argument("--views", type=int, default=None)
    ap.add_argument("--resolution", type=int, default=None)
    ap.add_argument("--spp", type=int, default=None)
    ap.add_argument("--per-render", action="store_true", help="one line per Mitsuba render")
    args = ap.parse_args()

    print(f"load average before: {os.getloadavg()}")
    t0, c0 = time.perf_counter(), time.process_time()
    from dreamprint_gui.proof.mitsuba_setup import load_mitsuba

    mi, variant, note = load_mitsuba()
    import drjit as dr

    t_import = time.perf_counter() - t0
    print(f"import mitsuba + drjit, variant     {t_import:7.1f} s  ({note})")

    renders: list[dict] = []
    real_render = mi.render

    def render(scene, *a, **kw):
        # the proof renders in a worker thread: Dr.Jit's flags are per thread
        dr.set_flag(dr.JitFlag.KernelHistory, True)
        dr.kernel_history()             # drop what came before
        t = time.perf_counter()
        out = real_render(scene, *a, **kw)
        dr.eval(out)
        dr.sync_thread()
        wall = time.perf_counter() - t
        hist = [h for h in dr.kernel_history() if h["type"] == dr.KernelType.JIT]
        renders.append({
            "sensor": kw.get("sensor").id() if kw.get("sensor") is not None else "",
            "spp": kw.get("spp"), "seed": kw.get("seed"), "wall": wall,
            "kernels": len(hist),
            "compiled": sum(1 for h in hist if not h.get("cache_hit")),
            "disk": sum(1 for h in hist if h.get("cache_disk")),
            "codegen_ms": sum(h.get("codegen_time", 0.0) for h in hist),
            "backend_ms": sum(h.get("backend_time", 0.0) for h in hist
                              if not h.get("cache_hit")),
            "exec_ms": sum(h.get("execution_time", 0.0) for h in hist),
            "hashes": [str(h.get("hash")) for h in hist]})
        return out

    mi.render = render
    dr.set_flag(dr.JitFlag.KernelHistory, True)

    from dreamprint_gui.proof.runner import ProofSettings, run_proof

    kw = {k: v for k, v in (("views", args.views), ("resolution", args.resolution),
                            ("spp", args.spp)) if v is not None}
    with tempfile.TemporaryDirectory() as tmp:
        s = ProofSettings(source=args.source, output=str(Path(tmp) / "proof"),
                          height_mm=args.height_mm, **kw)
        t1, c1 = time.perf_counter(), time.process_time()
        gen = run_proof(s)
        try:
            while True:
                next(gen)
        except StopIteration as stop:
            report = stop.value
        wall, cpu = time.perf_counter() - t1, time.process_time() - c1
    mi.render = real_render

    tim = report["timings_s"]
    print(f"proof {args.source} {args.height_mm} mm: {s.views} views, {s.resolution} px, "
          f"{s.spp} spp; cells {report['medium'].get('cells_xyz')}")
    for k, v in tim.items():
        print(f"  {k:32s} {v:7.1f} s")
    print(f"  source views read from the cache  {report.get('source_renders_cached', 0)}")
    print(f"  {'whole run_proof (wall / CPU)':32s} {wall:7.1f} s / {cpu:.1f} CPU s")
    print(f"  {'process so far (wall / CPU)':32s} {time.perf_counter() - t0:7.1f} s / "
          f"{time.process_time() - c0:.1f} CPU s")
    n = len(renders)
    tot = {k: sum(r[k] for r in renders) for k in ("wall", "kernels", "compiled", "disk",
                                                   "codegen_ms", "backend_ms", "exec_ms")}
    uniq = Counter(h for r in renders for h in r["hashes"])
    print(f"print: {n} Mitsuba renders, {tot['wall']:.1f} s; JIT kernels {tot['kernels']} "
          f"({len(uniq)} distinct), compiled {tot['compiled']} (disk-cache hits "
          f"{tot['disk']}), codegen {tot['codegen_ms'] / 1e3:.1f} s, LLVM compile "
          f"{tot['backend_ms'] / 1e3:.1f} s, kernels ran {tot['exec_ms'] / 1e3:.1f} s")
    first = [r for r in renders if r["compiled"]]
    print(f"  renders that compiled a kernel: {len(first)} of {n}")
    if args.per_render:
        for r in renders:
            print(f"  {r['sensor']:24s} spp {r['spp']:4d} seed {r['seed']:6d} "
                  f"{r['wall']:6.1f} s  kernels {r['kernels']} compiled {r['compiled']} "
                  f"codegen {r['codegen_ms']:.0f} ms LLVM {r['backend_ms']:.0f} ms "
                  f"ran {r['exec_ms'] / 1e3:.1f} s")
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
