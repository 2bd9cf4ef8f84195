"""``--content solid`` on a source with a fused layer plan: the solid wrapper must not hand the
inner source's plan (which samples the inner density) to the job."""

import numpy as np

from dreamprint_gui.io.volumes import grid_for_source, open_source
from dreamprint_gui.job.content import SOLID_SIGMA, apply_content


def test_solid_demo_takes_the_general_path_and_is_binary():
    inner = open_source("demo")
    assert getattr(inner, "layer_plan", None) is not None  # the demo has a fused plan
    src, choice = apply_content(inner, "solid", 0.05)
    assert choice.mode == "solid"
    assert getattr(src, "layer_plan", None) is None
    grid = grid_for_source(src, (0.5, 0.5, 0.5), height_mm=8.0)
    z = grid.shape_xyz[2] // 2
    _, sigma = src.sample_slab(grid, z, z + 1, density_scale=1.0)
    values = np.unique(np.asarray(sigma))
    assert set(values.tolist()) <= {0.0, float(SOLID_SIGMA)}
    assert (np.asarray(sigma) == SOLID_SIGMA).any() and (np.asarray(sigma) == 0).any()
