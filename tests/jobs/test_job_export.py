"""Atomic job folders: nothing under the final name unless complete."""

import errno
import os
import signal
import subprocess
import sys
import textwrap

import pytest

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.job.write import JobWriter, check_target, slice_name


def _leftovers(folder):
    return sorted(p.name for p in folder.iterdir())


def test_commit_renames_into_place(tmp_path):
    target = tmp_path / "JOB"
    with JobWriter(target) as w:
        (w.slices_dir / slice_name(0, 3)).write_bytes(b"x")
        assert not target.exists()
        w.commit({"a": 1})
    assert (target / "slices" / "00000.png").exists()
    assert (target / "manifest.json").read_text().strip().startswith("{")
    assert _leftovers(tmp_path) == ["JOB"]


def test_exception_or_interrupt_leaves_nothing(tmp_path):
    target = tmp_path / "JOB"
    for exc in (RuntimeError("boom"), KeyboardInterrupt()):
        with pytest.raises(type(exc)), JobWriter(target) as w:
            (w.slices_dir / "00000.png").write_bytes(b"x")
            raise exc
        assert _leftovers(tmp_path) == []


def test_disk_full_is_a_clear_error_and_cleans_up(tmp_path):
    target = tmp_path / "JOB"
    with pytest.raises(DreamPrintError, match="disk is full") as e, JobWriter(target) as w:
        (w.slices_dir / "00000.png").write_bytes(b"x")
        raise OSError(errno.ENOSPC, "No space left on device")
    assert str(target) in str(e.value)
    assert _leftovers(tmp_path) == []


def test_existing_job_needs_overwrite(tmp_path):
    target = tmp_path / "JOB"
    (target / "slices").mkdir(parents=True)
    (target / "old.txt").write_text("old")
    with pytest.raises(DreamPrintError, match="--overwrite"):
        check_target(target)
    with JobWriter(target, overwrite=True) as w:
        w.commit({"new": True})
    assert not (target / "old.txt").exists() and (target / "manifest.json").exists()
    assert _leftovers(tmp_path) == ["JOB"]


def test_missing_parent_is_refused(tmp_path):
    with pytest.raises(DreamPrintError, match="does not exist"):
        check_target(tmp_path / "no" / "JOB")


def test_slice_names_are_zero_padded():
    assert slice_name(7, 10) == "00007.png"
    assert slice_name(7, 200_000) == "000007.png"


def test_killed_process_leaves_no_final_folder_and_is_cleaned_later(tmp_path):
    target = tmp_path / "JOB"
    code = textwrap.dedent(f"""
        import sys, time
        from dreamprint_gui.job.write import JobWriter
        with JobWriter({str(target)!r}) as w:
            (w.slices_dir / "00000.png").write_bytes(b"x")
            print("writing", flush=True)
            time.sleep(60)
    """)
    env = dict(os.environ, PYTHONPATH=os.getcwd())
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, env=env)
    assert proc.stdout.readline().strip() == b"writing"
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    left = _leftovers(tmp_path)
    assert "JOB" not in left and len(left) == 1 and left[0].startswith(".JOB.partial-")
    with JobWriter(target) as w:  # the next export to the same target removes the leftover
        w.commit({})
    assert _leftovers(tmp_path) == ["JOB"]
