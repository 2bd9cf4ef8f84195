"""A print job's slabs on a ``dask.distributed`` cluster (``--scheduler tcp://HOST:PORT``).

The cluster is any one started with Dask's own command line (``dask scheduler``, ``dask
worker``), dask-jobqueue or Kubernetes: workers are other processes, usually on other
machines, that import DreamPrint themselves. What reaches them: the small job context
(:class:`.plan.JobContext`: grid, halftone mask, printer; scattered once to every worker),
never the source or the tables: each worker opens the source at the same path as the client
(a shared folder) and loads the colour tables from its own cache, once per process. Each
worker writes its slabs' slices and records (:mod:`.resume`) straight into the job's temporary
folder, which must also be on a path every worker sees; :func:`check_workers` asks every
worker before any slab runs. A slab task is idempotent (slices renamed into place, then its
record), so Dask's rescheduling of a dead worker's slabs gives the same files; a slab whose
workers keep dying, or a lost scheduler, stops the job with one line and keeps the finished
slabs for ``--resume`` (:class:`.write.JobInterrupted`).
"""

from __future__ import annotations

import logging
import os
import threading
from collections.abc import Callable
from typing import Any

from dreamprint_gui import __version__
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.job.write import JobCancelled, JobInterrupted

__all__ = ["connect", "absolute_paths", "quiet_client_logs", "cluster_line", "cluster_threads",
           "check_workers", "run_distributed", "WORKER_WAIT_S"]


WORKER_WAIT_S = 10.0  # how long a job waits for a cluster's first worker


def quiet_client_logs() -> None:
    """Keep dask.distributed's client-side log records (a lost scheduler's reconnection
    tracebacks) off the operator's terminal: the job says what happened in one line. For the
    command line; ``dreamprint --debug`` leaves them."""
    import distributed  # noqa: F401 - its import sets its loggers' levels: set ours after

    for name in ("distributed", "distributed.client", "tornado", "tornado.application"):
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)


def _check_address(address: str) -> None:
    """Dask's own parsing of a scheduler address (its scheme known, a port where the scheme
    needs one), before any ``Client`` is made: ValueError as Dask words it."""
    from distributed.comm.addressing import parse_address, parse_host_port
    from distributed.comm.registry import get_backend

    scheme, location = parse_address(address)
    get_backend(scheme)
    if scheme in ("tcp", "tls", "ws", "wss"):
        parse_host_port(location)


def connect(address: str, timeout: str = "10s") -> Any:
    """A ``distributed.Client`` of the scheduler at ``address``, or one line saying why not.

    A malformed address is refused before a ``Client`` exists, and a ``Client`` that failed
    to connect is collected at once: a half-made one left to the garbage collector closed
    itself from inside the next ``Client``'s start and deadlocked on its loop's lock (seen in
    the test suite; dask.distributed's ``Client.__del__`` -> ``LoopRunner.stop``)."""
    import gc

    from distributed import Client

    def not_an_address(exc: ValueError) -> str:
        return f"--scheduler {address!r} is not a Dask scheduler's address (tcp://HOST:PORT): {exc}"

    try:
        _check_address(address)
    except ValueError as exc:  # "missing port number in ''", "unknown address scheme 'foo'"
        raise DreamPrintError(not_an_address(exc)) from None
    try:
        return Client(address, timeout=timeout)
    except (OSError, TimeoutError) as exc:
        message = f"cannot reach the Dask scheduler at {address}: {exc}"
    except ValueError as exc:
        message = not_an_address(exc)
    gc.collect()   # the failed Client's __del__ runs here, not inside another Client's start
    raise DreamPrintError(message)


def absolute_paths(settings: Any) -> Any:
    """``settings`` with the files the workers open themselves (source, profile, compensation)
    as absolute paths: a worker's folder is not the client's."""
    from dataclasses import replace

    changes = {}
    for name in ("source", "profile", "compensation"):
        v = getattr(settings, name)
        if v is not None and not os.path.isabs(os.fspath(v)) and os.path.exists(v):
            changes[name] = os.path.abspath(v)
    return replace(settings, **changes) if changes else settings


def _workers(client: Any) -> dict[str, Any]:
    return client.scheduler_info(n_workers=-1).get("workers", {})


def cluster_threads(client: Any) -> int:
    """The threads of every worker of the cluster (what the slab plan is cut for)."""
    return max(1, sum(int(w.get("nthreads", 1)) for w in _workers(client).values()))


def cluster_line(client: Any, address: str) -> str:
    """``cluster tcp://..: 2 workers, 2 threads; dashboard http://..`` (printed by the CLI)."""
    ws = _workers(client)
    line = (f"cluster {address}: {len(ws)} worker{'s' if len(ws) != 1 else ''}, "
            f"{cluster_threads(client)} threads")
    link = getattr(client, "dashboard_link", None)
    if not (link and ws):
        return line
    try:  # the dashboard is the scheduler's: it shows a page asking for bokeh without it
        served = client.run_on_scheduler(_has_bokeh)
    except Exception:  # noqa: BLE001 - a scheduler that cannot tell: give the link
        served = True
    return f"{line}; dashboard {link}" + (
        "" if served else " (install bokeh on the scheduler's machine to see it: pip install "
        "'dreamprint[cluster]')")


def _has_bokeh() -> bool:
    """Run on the scheduler: whether it can serve the dashboard."""
    import importlib.util

    return importlib.util.find_spec("bokeh") is not None


def _worker_view(source: str, folder: str) -> dict[str, Any]:
    """Run on a worker (this module imported there: ``__version__`` is the worker's): its
    DreamPrint version, and whether it reads the source and writes into the job's folder."""
    return {"version": __version__, "source": os.access(source, os.R_OK),
            "folder": os.access(folder, os.W_OK | os.X_OK)}


def check_workers(client: Any, source: str, folder: str) -> None:
    """Refuse, in one line naming the worker and the path, a cluster with no worker, or a
    worker that runs another DreamPrint version, cannot read the source (a file the client
    reads: ``demo`` is built in) or cannot write into the job's temporary folder."""
    if not _workers(client):
        try:  # workers starting with the cluster may join a little later
            client.wait_for_workers(1, timeout=WORKER_WAIT_S)
        except TimeoutError:
            raise DreamPrintError(f"the Dask cluster has no workers after {WORKER_WAIT_S:g} s "
                                  "(start some with 'dask worker tcp://HOST:PORT')") from None
    try:
        views = client.run(_worker_view, source, folder)
    except ModuleNotFoundError:
        raise DreamPrintError("a Dask worker cannot import DreamPrint: install the same "
                              f"version ({__version__}) on every worker") from None
    needs_source = os.path.exists(source)
    for worker, v in sorted(views.items()):
        if v["version"] != __version__:
            raise DreamPrintError(f"the Dask worker {worker} runs DreamPrint {v['version']}, "
                                  f"this is {__version__}: install the same version on every "
                                  "worker")
        if needs_source and not v["source"]:
            raise DreamPrintError(f"the Dask worker {worker} cannot read the source at this "
                                  "path: put it on a folder every worker sees at the same path",
                                  source)
        if not v["folder"]:
            raise DreamPrintError(f"the Dask worker {worker} cannot write into the job's "
                                  "folder: put the job on a folder every worker sees at the "
                                  "same path", os.path.dirname(folder))


def _lost(exc: BaseException, client: Any) -> bool:
    """Whether ``exc``, raised while waiting for results, says the client lost its scheduler:
    its connection closed or reset (whatever the client's status says yet), or a cancel or a
    comm error once the client is no longer running."""
    from distributed.client import FutureCancelledError
    from distributed.comm.core import CommClosedError

    if isinstance(exc, CommClosedError | ConnectionError):
        return True
    return client.status != "running" and isinstance(
        exc, OSError | TimeoutError | FutureCancelledError)


def run_distributed(client: Any, address: str, task: Callable[..., Any], ctx: Any,
                    slabs: list[tuple[int, int]], args: tuple, out_q: Any,
                    cancel: threading.Event | None
                    ) -> tuple[threading.Thread, threading.Event]:
    """Submit ``task(ctx, z0, z1, *args)`` per slab; put each result, then ``("done", None)`` or
    ``("error", exc)``, then ``("closed", None)`` on ``out_q`` (as the local schedulers do).
    A slab whose workers died ``distributed.scheduler.allowed-failures`` times, or the loss of
    the scheduler, is a :class:`.write.JobInterrupted`."""
    from distributed import as_completed
    from distributed.scheduler import KilledWorker

    stop = threading.Event()

    def drive() -> None:
        futs: list[Any] = []
        try:
            ctx_f = client.scatter(ctx, broadcast=True, hash=False)
            futs = [client.submit(task, ctx_f, z0, z1, *args, pure=False) for z0, z1 in slabs]
            for f in as_completed(futs):
                if stop.is_set() or (cancel is not None and cancel.is_set()):
                    raise JobCancelled()
                out_q.put(("result", f.result()))
            out_q.put(("done", None))
        except KilledWorker as exc:
            out_q.put(("error", JobInterrupted(
                f"a slab's Dask workers died repeatedly ({exc}); the finished layers are kept: "
                "run the same command with --resume")))
        except JobCancelled as exc:
            out_q.put(("error", exc))
        except BaseException as exc:  # noqa: BLE001 - handed to the consuming generator
            if not stop.is_set() and _lost(exc, client):
                exc = JobInterrupted(f"lost the Dask scheduler at {address}; the finished "
                                     "layers are kept: run the same command with --resume")
            out_q.put(("error", exc))
        finally:
            stop.set()
            try:
                if futs and client.status == "running":
                    client.cancel(futs)
            except Exception:  # noqa: BLE001 - the scheduler may be gone
                pass
            finally:
                out_q.put(("closed", None))

    th = threading.Thread(target=drive, name="dreamprint-distributed", daemon=True)
    th.start()
    return th, stop
