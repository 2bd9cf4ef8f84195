"""--content auto names an InstantNGP raw volume export a radiance field (fog), not "a scalar
volume (more than two values)"."""

import numpy as np

from dreamprint_gui.io.volumes import open_source
from dreamprint_gui.job.content import choose_content


def test_ingp_raw_volume_is_a_radiance_field(tmp_path):
    # instant-ngp's save_rgba_grid_to_raw_file: float32 RGBA per voxel, x fastest, named
    # {w}x{h}x{d}_{cascade}.bin; A is the density.
    n = 8
    v = np.zeros((n, n, n, 4), np.float32)
    v[..., :3] = (0.8, 0.3, 0.1)
    v[2:6, 2:6, 2:6, 3] = 40.0
    v[3, 3, 3, 3] = 55.0                     # three density values: not a binary mask
    p = tmp_path / f"{n}x{n}x{n}_0.bin"
    v.tofile(p)
    mode, reason = choose_content(open_source(str(p)))
    assert mode == "fog" and reason.startswith("a radiance field")
