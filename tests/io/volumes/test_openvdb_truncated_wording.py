"""A .vdb cut inside a grid descriptor names the field and the grid in plain words
(no "grid 'velocity''s type")."""

import pytest

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes import open_source


def test_cut_in_descriptor_reads_cleanly(shared_data, tmp_path):
    raw = (shared_data / "volumes" / "blender_mantaflow_fluid_data_0190.vdb").read_bytes()
    p = tmp_path / "t.vdb"
    p.write_bytes(raw[:100])          # inside the first grid descriptor (its type string)
    with pytest.raises(DreamPrintError) as e:
        open_source(str(p))
    msg = str(e.value)
    assert "truncated" in msg and "the type of grid 'velocity'" in msg and "''s" not in msg
