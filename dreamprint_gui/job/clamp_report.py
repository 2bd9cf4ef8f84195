"""What a finished job says about the voxels its density alignment clamped (manifest
``clamped_density``), in one line, for the command line and the GUI's job summary alike.

Density alignment (eq. 12) clamps a voxel *high* when its target density is above what its
colour's mixture reaches (it prints at the inks' densest, less dense than the source states) and
*low* when the target is below pure Clear's density (it prints as Clear). Only the first is
worth the operator's attention: a near-empty voxel printed as Clear is what the background is
too (a MetaImage of an MR head holds tens of millions of them), so it is neither counted nor
reported. The line says what to do: the density scale at which the pre-flight's sample found
no clamping, when the job's manifest holds it.
"""

from __future__ import annotations

from typing import Any

__all__ = ["clamp_summary"]


def clamp_summary(manifest: dict[str, Any]) -> str | None:
    """The line about voxels printed less dense than the source states, or None when none
    were (voxels clamped low alone are not reported: they print as Clear, as the background)."""
    c = manifest.get("clamped_density") or {}
    hi = int(c.get("n_clamped_high", 0))
    if hi <= 0:
        return None
    n = max(1, int(manifest.get("total_voxels", 1)))
    counts = manifest.get("voxel_counts") or {}
    coloured = sum(int(v) for k, v in counts.items() if k not in ("Cl", "empty"))
    share = f"{100 * hi / n:.2f} % of the job"
    if coloured:
        share += f", {100 * min(hi, coloured) / coloured:.2f} % of its coloured voxels"
    line = (f"clamped: {hi:,} voxels too dense ({share}) printed at their inks' densest, up "
            f"to {float(c.get('max_shortfall_high', 0.0)):.3g}/mm less dense than the source "
            "states")
    pf = manifest.get("preflight") or {}
    safe = pf.get("density_scale_without_clamping")
    scale = pf.get("density_scale")
    if safe and scale and safe < scale:
        line += f"; --density-scale {safe:.3g} prints them as stated"
    return line
