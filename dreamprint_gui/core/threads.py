"""One call on a daemon thread whose result or error comes back to the caller: :class:`DaemonCall`.

The job's preparation (:mod:`...job.run`, which relays its notices meanwhile), the pre-flight's
slab timing (:mod:`...job.preflight`, timed off the main thread as the job's workers run) and
the GUI's abandonable engine calls (:func:`...gui.workers.abandonable`) run this way. A daemon
thread never holds up the process's exit (Ctrl-C, quitting the application); the standard
library's executors join their threads at exit.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

__all__ = ["DaemonCall"]


class DaemonCall:
    """``fn()`` started at once on a daemon thread named ``name``."""

    def __init__(self, fn: Callable[[], Any], name: str) -> None:
        self._box: dict[str, Any] = {}

        def target() -> None:
            try:
                self._box["value"] = fn()
            except BaseException as exc:  # noqa: BLE001 - raised again by result()
                self._box["error"] = exc

        self._thread = threading.Thread(target=target, name=name, daemon=True)
        self._thread.start()

    def is_alive(self) -> bool:
        return self._thread.is_alive()

    def join(self, timeout: float | None = None) -> None:
        self._thread.join(timeout)

    def result(self) -> Any:
        """Wait for the call; its return value, or its exception raised here."""
        self._thread.join()
        if "error" in self._box:
            raise self._box["error"]
        return self._box["value"]
