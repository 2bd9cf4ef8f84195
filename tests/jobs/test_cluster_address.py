"""A --scheduler that is no Dask address is one line naming it, before any work."""

import pytest

from dreamprint_gui.cli import main


@pytest.mark.parametrize("address, says", [
    ("tcp://", "missing port"), ("foo://bar", "unknown address scheme"),
])
def test_a_malformed_scheduler_address_is_named(tmp_path, capsys, address, says):
    assert main(["convert", "demo", "-o", str(tmp_path / "JOB"), "--height-mm", "0.3",
                 "--scheduler", address]) == 2
    err = capsys.readouterr().err.strip()
    assert f"--scheduler '{address}' is not a Dask scheduler's address" in err and says in err
    assert "\n" not in err
    assert list(tmp_path.iterdir()) == []
