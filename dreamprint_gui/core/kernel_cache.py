"""Which compiled kernels numba has not cached yet, and what a command says while it compiles
them (issue 46: a first run after an install or upgrade compiles for seconds to a minute).

Defines :func:`uncached` (the one rule: a module's ``cache=True`` kernels, wherever they are
defined, have no index file in ``NUMBA_CACHE_DIR``; the package keys that folder on its
sources, so a code change or an upgrade starts an empty one), :func:`compile_notice` (the
announcement's wording) and :func:`while_compiling` (a heartbeat while numba compiles, from
numba's compile events: nothing when the kernels load from the cache).
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from types import ModuleType

from dreamprint_gui.core import progress as core_progress
from dreamprint_gui.core.durations import about_text

__all__ = ["uncached", "compile_notice", "while_compiling"]


def uncached(module: ModuleType) -> bool:
    """True when ``module`` holds a cached compiled kernel (``cache=True``; its own or one it
    imported) whose defining module has no index (``*.nbi``) in ``NUMBA_CACHE_DIR``: calling it
    compiles. False without ``NUMBA_CACHE_DIR`` (nothing is cached: the package always sets
    it) or without such kernels."""
    from numba.core.dispatcher import Dispatcher

    if not os.environ.get("NUMBA_CACHE_DIR"):
        return False
    folder = Path(os.environ["NUMBA_CACHE_DIR"])
    # a kernel inlined into its callers (inline="always") is never cached on its own
    homes = {v.py_func.__module__.rsplit(".", 1)[-1] for v in vars(module).values()
             if isinstance(v, Dispatcher)
             and type(getattr(v, "_cache", None)).__name__ != "NullCache"
             and v.targetoptions.get("inline") != "always"}
    return any(not any(folder.glob(f"*/{home}.*.nbi")) for home in homes)


def compile_notice(what: str, why: str, seconds: float) -> str:
    """``compiling the colour kernels: first run after an install or upgrade, about 16 s;
    cached after``: the line said before a first-use compile."""
    return f"{what}: {why}, {about_text(seconds)}; cached after"


@contextmanager
def while_compiling(say: Callable[[float], None]) -> Iterator[None]:
    """While the block runs, ``say(elapsed_s)`` every :data:`.progress.HEARTBEAT_S` seconds in
    which numba compiled (``elapsed_s`` since the block's first compile started), and only
    then: kernels loaded from the cache, or the block's own work between compiles, say
    nothing. Compiles are numba's ``numba:compile`` events (a listener while the block runs;
    the heartbeat's thread, :func:`.progress.heartbeat`, says it)."""
    from numba.core import event

    state: dict = {"depth": 0, "first": None, "since": False}
    lock = threading.Lock()

    class _Listener(event.Listener):
        def on_start(self, ev) -> None:
            with lock:
                state["depth"] += 1
                state["since"] = True
                if state["first"] is None:
                    state["first"] = time.monotonic()

        def on_end(self, ev) -> None:
            with lock:
                state["depth"] -= 1

    def beat(_el: float) -> None:
        with lock:
            busy = state["depth"] > 0 or state["since"]
            state["since"] = False
        if busy:
            say(time.monotonic() - state["first"])

    with event.install_listener("numba:compile", _Listener()), core_progress.heartbeat(beat):
        yield
