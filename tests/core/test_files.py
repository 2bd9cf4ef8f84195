"""Output files written whole or not at all, readable like any new file (core/files.py)."""

import os

import pytest

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.files import write_atomically
from dreamprint_gui.core.profile import default_profile, load_profile, save_profile


def _new_file_mode() -> int:
    umask = os.umask(0o022)
    os.umask(umask)
    return 0o666 & ~umask


def test_replaces_whole_with_a_new_file_s_permissions(tmp_path):
    target = tmp_path / "out.bin"
    write_atomically(target, b"first")
    write_atomically(target, b"second")
    assert target.read_bytes() == b"second"
    assert target.stat().st_mode & 0o777 == _new_file_mode()
    assert [p.name for p in tmp_path.iterdir()] == ["out.bin"]


def test_bad_targets_name_the_path(tmp_path):
    with pytest.raises(DreamPrintError, match="is a folder; give a file name such as x.icc"):
        write_atomically(tmp_path, b"x", "x.icc")
    missing = tmp_path / "no" / "out.bin"
    with pytest.raises(DreamPrintError, match="the folder does not exist") as err:
        write_atomically(missing, b"x")
    assert str(missing.parent) in str(err.value)
    assert not list(tmp_path.iterdir())


def test_profiles_are_saved_through_it(tmp_path):
    path = tmp_path / "p.json"
    save_profile(default_profile(), path)
    assert load_profile(path).name == default_profile().name
    assert path.stat().st_mode & 0o777 == _new_file_mode()
    with pytest.raises(DreamPrintError, match="the folder does not exist"):
        save_profile(default_profile(), tmp_path / "none" / "p.json")
