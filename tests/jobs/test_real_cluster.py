"""A job on a real Dask cluster: a ``dask scheduler`` and ``dask worker`` processes started with
Dask's own command line (no LocalCluster, nothing shared with this interpreter), a worker or
the scheduler killed mid-job; the slices' hashes against ``--scheduler sync``."""

import hashlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from dreamprint_gui import __version__
from dreamprint_gui.cli import main
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.job.cluster import check_workers
from dreamprint_gui.job.resume import find_interrupted
from dreamprint_gui.job.write import SLABS

REPO = Path(__file__).resolve().parents[2]
DASK = str(Path(sys.executable).with_name("dask"))
JOB = ["--table-size", "17", "--seed", "3", "--slab-layers", "1"]


class Cluster:
    """``dask scheduler`` + ``dask worker`` processes on 127.0.0.1 (random ports), each worker
    one thread and no nanny (a killed worker stays dead)."""

    def __init__(self, folder: Path, n_workers: int) -> None:
        self.folder = folder
        self.env = dict(os.environ, PYTHONPATH=str(REPO), DASK_DISTRIBUTED__WORKER__DAEMON="0")
        self.file = folder / "scheduler.json"
        self.scheduler = self._start(["scheduler", "--host", "127.0.0.1", "--port", "0",
                                      "--dashboard-address", "127.0.0.1:0",
                                      "--scheduler-file", str(self.file)], "scheduler")
        deadline = time.time() + 60
        while not self.file.exists():
            assert time.time() < deadline and self.scheduler.poll() is None, "no scheduler"
            time.sleep(0.1)
        time.sleep(0.2)  # written whole
        self.address = json.loads(self.file.read_text())["address"]
        self.workers = [self._start(["worker", "--scheduler-file", str(self.file), "--nthreads",
                                     "1", "--no-nanny", "--no-dashboard"], f"worker{i}")
                        for i in range(n_workers)]
        from distributed import Client

        with Client(self.address, timeout="30s") as c:
            c.wait_for_workers(n_workers, timeout=60)

    def _start(self, args, name):
        log = open(self.folder / f"{name}.log", "wb")  # noqa: SIM115 - closed with the process
        return subprocess.Popen([DASK, *args], stdout=log, stderr=log, env=self.env,
                                cwd=self.folder)

    def close(self) -> None:
        for p in [*self.workers, self.scheduler]:
            if p.poll() is None:
                p.kill()
            p.wait(timeout=30)


@pytest.fixture
def cluster(tmp_path_factory):
    made = []

    def start(n_workers):
        c = Cluster(tmp_path_factory.mktemp("dask"), n_workers)
        made.append(c)
        return c

    yield start
    for c in made:
        c.close()


def _digests(job):
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted((job / "slices").iterdir())}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The slices' digests of a ``--scheduler sync`` conversion at a height: one conversion per
    height in this module (the tests at the same height compare with the same slices)."""
    made = {}

    def digests(height):
        if height not in made:
            out = tmp_path_factory.mktemp("sync") / "SYNC"
            assert main(["convert", "demo", "-o", str(out), "--height-mm", height, *JOB,
                         "--scheduler", "sync", "-q"]) == 0
            made[height] = _digests(out)
        return made[height]

    return digests


def _convert(out, height, address, *extra):
    return subprocess.Popen(
        [sys.executable, "-m", "dreamprint_gui.cli", "convert", "demo", "-o", str(out),
         "--height-mm", height, *JOB, "--scheduler", address, *extra],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=dict(os.environ, PYTHONPATH=str(REPO)))


def _wait_done(proc, folder, share, nz, timeout=180):
    """Wait until ``share`` of the job's ``nz`` layers are recorded done; returns that count."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        parts = [p for p in folder.iterdir() if p.name.startswith(".JOB.partial-")]
        n = len(list((parts[0] / SLABS).glob("*.json"))) if parts else 0
        if n >= share * nz:
            return n
        assert proc.poll() is None, proc.communicate()[1].decode()[-2000:]
        time.sleep(0.01)
    raise AssertionError("the job did not progress in time")


def test_a_worker_killed_mid_job_gives_the_slices_of_a_local_run(cluster, reference, tmp_path):
    height, nz = "8", 297
    c = cluster(2)
    ref = reference(height)
    out = tmp_path / "JOB"
    proc = _convert(out, height, c.address)
    done = _wait_done(proc, tmp_path, 0.3, nz)
    c.workers[0].send_signal(signal.SIGKILL)
    outs, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err.decode()[-2000:]
    assert done < 0.6 * nz  # killed within 30-60 % of the job
    assert c.workers[0].wait(timeout=30) == -signal.SIGKILL
    assert _digests(out) == ref
    text = err.decode()
    assert f"cluster {c.address}: 2 workers, 2 threads; dashboard http://127.0.0.1:" in text
    import importlib.util

    # the scheduler runs in this environment: without bokeh its dashboard only asks for it
    assert ("install bokeh on the scheduler's machine" in text) == (
        importlib.util.find_spec("bokeh") is None)
    # progress stayed honest: layers counted once each, never past the job
    layers = [int(line.split()[1].split("/")[0]) for line in text.splitlines()
              if line.startswith("converting:")]
    assert layers == sorted(layers) and layers[-1] == nz
    assert json.loads((out / "manifest.json").read_text())["execution"]["workers"] == 2


def test_a_lost_scheduler_stops_in_one_line_and_resume_finishes(cluster, reference, tmp_path):
    height, nz = "8", 297
    c = cluster(1)
    ref = reference(height)
    out = tmp_path / "JOB"
    proc = _convert(out, height, c.address, "-q")
    _wait_done(proc, tmp_path, 0.2, nz)
    c.scheduler.send_signal(signal.SIGKILL)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 2
    lines = err.decode().strip().splitlines()
    assert len(lines) == 1 and "lost the Dask scheduler at " + c.address in lines[0], lines
    assert "--resume" in lines[0] and not out.exists()
    left = find_interrupted(out)
    assert left is not None and 0 < left[1] < nz
    # finished elsewhere (here on this computer's threads): the same slices
    assert main(["convert", "demo", "-o", str(out), "--height-mm", height, *JOB, "--resume",
                 "-q"]) == 0
    assert _digests(out) == ref


class _FakeClient:
    def __init__(self, view):
        self.view = view

    def scheduler_info(self, n_workers=-1):
        return {"workers": {"tcp://10.0.0.2:4000": {"nthreads": 1}}}

    def run(self, fn, *args):
        return {"tcp://10.0.0.2:4000": self.view}


@pytest.mark.parametrize("view, says", [
    ({"version": "0.1", "source": True, "folder": True}, "runs DreamPrint 0.1"),
    ({"version": __version__, "source": False, "folder": True}, "cannot read the source"),
    ({"version": __version__, "source": True, "folder": False}, "cannot write into the job"),
])
def test_workers_that_cannot_do_the_job_are_refused_in_one_line(tmp_path, view, says):
    src = tmp_path / "cloud.vdb"
    src.write_bytes(b"x")
    with pytest.raises(DreamPrintError, match=says) as e:
        check_workers(_FakeClient(view), str(src), str(tmp_path / ".J.partial-1-a" / "slices"))
    assert "tcp://10.0.0.2:4000" in str(e.value) and "\n" not in str(e.value)


def test_the_client_killed_then_resume_on_the_cluster(cluster, reference, tmp_path):
    """kill -9 of the converting client at half the job; the workers may still finish the
    slabs they were running; --resume against the same cluster gives the local slices."""
    height, nz = "6", 223
    c = cluster(2)
    ref = reference(height)
    out = tmp_path / "JOB"
    proc = _convert(out, height, c.address, "-q")
    _wait_done(proc, tmp_path, 0.5, nz)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    left = find_interrupted(out)
    assert left is not None and left[1] < nz and not out.exists()
    res = subprocess.run(
        [sys.executable, "-m", "dreamprint_gui.cli", "convert", "demo", "-o", str(out),
         "--height-mm", height, *JOB, "--scheduler", c.address, "--resume", "-q"],
        capture_output=True, text=True, env=dict(os.environ, PYTHONPATH=str(REPO)), timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]
    assert "layers kept from the interrupted run" in res.stdout
    assert _digests(out) == ref
