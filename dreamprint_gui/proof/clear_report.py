"""What of a proof's error rests on the modelled Clear: ``proof.json``'s ``clear`` entry.

For a profile whose Clear is modelled (``core.profile.ink_origins``), the proof can render the
same labels once more with the Clear at its plausible low bound
(:mod:`dreamprint_gui.physics.clear_bounds`, ``--clear-low-bound``; one more print render, so
off by default). :func:`clear_report` puts the figures at both bounds side by side: the mean
dE2000 and S-CIELAB dE2000 over the object pixels, the coverage error, and the same over the
object pixels where the source is empty (the Clear block's body: its share of the mean divided
by its fraction, :func:`.compare.summarise`'s ``empty_source_*``) and where it is not.
:func:`clear_lines` words them for the command line and the proof tab.
"""

from __future__ import annotations

from typing import Any

from dreamprint_gui.core.profile import InkProfile, ink_origins
from dreamprint_gui.physics.clear_bounds import describe_low_bound
from dreamprint_gui.proof.compare import inside_source

__all__ = ["clear_report", "bound_figures", "clear_lines"]


def bound_figures(overall: dict[str, Any]) -> dict[str, float | None]:
    """The figures compared at the two bounds, from a proof's ``overall``."""
    frac = overall.get("empty_source_fraction", 0.0)
    body = {k: (overall[f"empty_source_{k}"] / frac if frac > 0 else None)
            for k in ("de2000", "scielab_de2000", "coverage_error")}
    return {"mean_de2000": overall["mean_de2000"],
            "mean_scielab_de2000": overall["mean_scielab_de2000"],
            "coverage_error": overall["coverage_error"],
            "clear_block_fraction": frac,
            "clear_block_de2000": body["de2000"],
            "clear_block_scielab_de2000": body["scielab_de2000"],
            "clear_block_coverage_error": body["coverage_error"],
            "inside_source_de2000": inside_source(overall, "mean_de2000"),
            "inside_source_scielab_de2000": inside_source(overall, "mean_scielab_de2000")}


def clear_report(profile: InkProfile, bounds: tuple[dict, dict] | None,
                 asked: bool) -> dict[str, Any]:
    """``proof.json``'s ``clear``: the Clear's origin and, when rendered, the figures at both
    bounds (``bounds``: the overall figures of the modelled and the low-bound print, on the
    same pixels)."""
    origin = ink_origins(profile)["Cl"]
    out: dict[str, Any] = {"origin": origin}
    if origin == "measured":
        out["note"] = "the Clear is measured: its K and S are no guess"
        return out
    out["low_bound"] = describe_low_bound()
    if bounds is None:
        out["figures"] = None
        out["note"] = ("the Clear is modelled; --clear-low-bound renders the print again with "
                       "it at its low bound (one more print render)" if not asked else "")
        return out
    out["figures"] = {"modelled": bound_figures(bounds[0]), "low_bound": bound_figures(bounds[1])}
    out["labels"] = ("the same labels (planned with the modelled Clear), rendered at each bound "
                     "and compared on the same pixels (either print's or the source's)")
    return out


def clear_lines(clear: dict[str, Any] | None) -> list[str]:
    """Plain-text lines for an operator (empty when there is nothing to say)."""
    if not clear:
        return []
    if clear.get("figures") is None:
        return [f"Clear: {clear['origin']}" + (f" ({clear['note']})" if clear.get("note")
                                                else "")]
    a, b = clear["figures"]["modelled"], clear["figures"]["low_bound"]
    lines = [f"Clear modelled, not measured; at its low bound ({clear['low_bound']}):"]
    if a["clear_block_de2000"] is not None:
        lines.append(f"  Clear block body ({100 * a['clear_block_fraction']:.0f} % of the object "
                     f"pixels): {a['clear_block_de2000']:.2f} dE2000 at the modelled Clear, "
                     f"{b['clear_block_de2000']:.2f} at the low bound; S-CIELAB "
                     f"{a['clear_block_scielab_de2000']:.2f} -> "
                     f"{b['clear_block_scielab_de2000']:.2f}; coverage error "
                     f"{a['clear_block_coverage_error']:+.3f} -> "
                     f"{b['clear_block_coverage_error']:+.3f}")
    if a["inside_source_de2000"] is not None:
        lines.append(f"  inside the source: dE2000 {a['inside_source_de2000']:.2f} -> "
                     f"{b['inside_source_de2000']:.2f}, S-CIELAB "
                     f"{a['inside_source_scielab_de2000']:.2f} -> "
                     f"{b['inside_source_scielab_de2000']:.2f}")
    lines.append(f"  all object pixels: dE2000 {a['mean_de2000']:.2f} -> {b['mean_de2000']:.2f}, "
                 f"S-CIELAB {a['mean_scielab_de2000']:.2f} -> {b['mean_scielab_de2000']:.2f}, "
                 f"coverage error {a['coverage_error']:+.3f} -> {b['coverage_error']:+.3f}")
    return lines
