"""The longest silence of a command: run it, time-stamp every line it writes (stdout and
stderr, and each update of a progress bar ending in a carriage return) and print the longest
gap between two of them, in wall seconds and in the CPU seconds the command used meanwhile
(issue 46: every step over 2 s of work shows progress).

    PYTHONPATH=. .venv/bin/python benchmarks/bench_silence.py -- -m dreamprint_gui.cli icc -o x.icc

Everything after ``--`` is passed to this Python interpreter. Prints the three longest
silences, ``silence W s wall (C CPU s) after: LINE``, and the total. ``--case NAME`` runs one
of :data:`CASES` instead (from the repository's folder, output in a temporary folder):

    PYTHONPATH=. .venv/bin/python benchmarks/bench_silence.py --case chart-proof

``chart-proof``: ``dreamprint proof --chart resources/charts/starter-24.csv`` at its defaults
(512 spp, 12 bands: 4 render passes of about 20 s each on the 2-core machine).
"""

from __future__ import annotations

import os
import selectors
import subprocess
import sys
import tempfile
import time

# Commands measured by name: arguments after the interpreter, "{tmp}" a temporary folder
CASES = {
    "chart-proof": ["-m", "dreamprint_gui.cli", "proof", "--chart",
                    "resources/charts/starter-24.csv", "-o", "{tmp}/chart", "--json"],
}


def _cpu(pid: int) -> float:
    """CPU seconds (user + system) of ``pid`` so far, from /proc (Linux)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, IndexError, ValueError):
        return float("nan")


def main(argv: list[str]) -> int:
    if argv[:1] == ["--case"]:
        if len(argv) < 2 or argv[1] not in CASES:
            print(f"--case: one of {', '.join(CASES)}", file=sys.stderr)
            return 2
        with tempfile.TemporaryDirectory(prefix="bench_silence_") as tmp:
            return _measure([a.replace("{tmp}", tmp) for a in CASES[argv[1]]])
    return _measure(argv[argv.index("--") + 1:] if "--" in argv else argv)


def _measure(args: list[str]) -> int:
    proc = subprocess.Popen([sys.executable, *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    sel = selectors.DefaultSelector()
    sel.register(proc.stdout, selectors.EVENT_READ, "out")
    sel.register(proc.stderr, selectors.EVENT_READ, "err")
    t0 = last_t = time.monotonic()
    last_cpu, cpu = 0.0, 0.0
    gaps: list[tuple[float, float, str]] = []
    prev_line = "(start)"
    buf = {"out": b"", "err": b""}
    open_streams = 2
    while open_streams:
        for key, _ in sel.select(timeout=0.5):
            cpu = _cpu(proc.pid) if proc.poll() is None else cpu
            data = os.read(key.fileobj.fileno(), 65536)
            if not data:
                sel.unregister(key.fileobj)
                open_streams -= 1
                continue
            buf[key.data] += data
            while True:
                cut = [i for i in (buf[key.data].find(b"\n"), buf[key.data].find(b"\r"))
                       if i >= 0]
                if not cut:
                    break
                i = min(cut)
                line = buf[key.data][:i].decode(errors="replace").strip()
                buf[key.data] = buf[key.data][i + 1:]
                now = time.monotonic()
                gaps.append((now - last_t, cpu - last_cpu, prev_line))
                last_t, last_cpu, prev_line = now, cpu, line[:100] or prev_line
    rc = proc.wait()
    now = time.monotonic()
    gaps.append((now - last_t, float("nan"), prev_line + " (until exit)"))
    for wall, cpu_s, line in sorted(gaps, reverse=True)[:3]:
        print(f"silence {wall:.1f} s wall ({cpu_s:.1f} CPU s) after: {line}")
    print(f"total {now - t0:.1f} s wall, exit {rc}, load {os.getloadavg()[0]:.1f}")
    return rc


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
