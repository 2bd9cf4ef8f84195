"""``dreamprint inspect FILE [--json] [--height-mm H | --size-mm X,Y,Z]``: what a volume file
holds, per grid or element, and what ``--content auto`` would print it as."""

from __future__ import annotations

import click

from dreamprint_gui.cli.group import cli
from dreamprint_gui.cli.options import (
    parse_size,
    placement_options,
    placement_values,
    size_options,
)
from dreamprint_gui.cli.output import emit_json
from dreamprint_gui.core.errors import DreamPrintError


def _fmt_num(v) -> str:
    if v is None:
        return "-"
    if isinstance(v, (list, tuple)):
        return "(" + ", ".join(_fmt_num(x) for x in v) + ")"
    return f"{v:.6g}" if isinstance(v, float) else str(v)


def _fmt_bounds(b, unit: str = "source units") -> str:
    """``x lo .. hi, y lo .. hi, z lo .. hi <unit>`` of ((x0, y0, z0), (x1, y1, z1))."""
    if not b:
        return "-"
    return ", ".join(f"{a} {_fmt_num(lo)} .. {_fmt_num(hi)}"
                     for a, lo, hi in zip("xyz", b[0], b[1], strict=True)) + f" {unit}"


def _range(g: dict) -> str:
    lo, hi = g.get("min"), g.get("max")
    if isinstance(lo, (list, tuple)) and isinstance(hi, (list, tuple)):
        names = "rgba" if len(lo) == 4 else "xyz" if len(lo) == 3 else \
            [str(k) for k in range(len(lo))]
        parts = ", ".join(f"{a} {_fmt_num(a_lo)} .. {_fmt_num(a_hi)}"
                          for a, a_lo, a_hi in zip(names, lo, hi, strict=False))
        mag = g.get("magnitude")
        if mag:
            parts += f"; magnitude {_fmt_num(mag[0])} .. {_fmt_num(mag[1])}"
        return f"values per component {parts}"
    if lo is None or hi is None:
        return "values (range not read)"
    return f"values {_fmt_num(lo)} .. {_fmt_num(hi)}"


def _mpu(bounds, height_mm, size_mm) -> tuple[float, str] | None:
    """(mm per source unit, the option that set it) for ``bounds`` at a size
    (``io.volumes.base.mm_per_unit``, the scale of ``grid_for_source``), or None."""
    from dreamprint_gui.io.volumes.base import mm_per_unit

    if not bounds or (height_mm is None and size_mm is None):
        return None
    ext = [hi - lo for lo, hi in zip(bounds[0], bounds[1], strict=True)]
    try:
        mpu = mm_per_unit(ext, height_mm=height_mm, size_mm=size_mm)
    except DreamPrintError:
        return None  # a flat source's height, bounds with no extent: no scale to state
    if height_mm is not None:
        return mpu, f"--height-mm {height_mm:g}"
    return mpu, "--size-mm " + ",".join(f"{v:g}" for v in size_mm)


def _span(bounds, mpu: float) -> str:
    return " x ".join(f"{(hi - lo) * mpu:.2f}" for lo, hi in zip(bounds[0], bounds[1],
                                                                  strict=True)) + " mm"


def _size_line(bounds, height_mm, size_mm) -> str | None:
    """``at ...: 1 source unit = k mm; the bounds span X x Y x Z mm`` (the rule of
    ``grid_for_source``) or None without a size."""
    m = _mpu(bounds, height_mm, size_mm)
    if m is None:
        return None
    return f"  at {m[1]}: 1 source unit = {m[0]:.4g} mm; the bounds span {_span(bounds, m[0])}"


def _union(bounds_list):
    b = [x for x in bounds_list if x]
    if not b:
        return None
    return ([min(x[0][a] for x in b) for a in range(3)],
            [max(x[1][a] for x in b) for a in range(3)])


def format_info(path: str, info: dict, height_mm: float | None = None,
                size_mm: tuple[float, float, float] | None = None) -> str:
    """The human-readable form of a source's ``info()`` (with ``content``, if present): one
    heading line per grid, then its voxels, values and bounds with their units."""
    lines = [f"{path}: {info['format']}"]
    c = info.get("content")
    if c:
        lines.append(f"  content: {c['mode']} (--content auto: {c['reason']})")
    if "gaussians" in info:
        lines.append(f"  {info['gaussians']:,} Gaussians, SH degree {info['sh_degree']}"
                     + (f" ({info['skipped']:,} skipped: zero opacity or scale, or non-finite)"
                        if info.get("skipped") else ""))
        lines.append(f"    bounds {_fmt_bounds(info['bounds'])}")
        if not info.get("placement"):
            s = _size_line(info["bounds"], height_mm, size_mm)
            if s:
                lines.append(s)
    for g in info.get("grids", []):
        shape = g.get("shape") or g.get("shape_zyx", [])[::-1]
        head = f"  {g['name']!s}: {g.get('class', 'grid')}"
        if g.get("dtype"):
            head += f", {g['dtype']}"
        lines.append(head)
        vox = " x ".join(str(v) for v in shape) if shape else "-"
        act = g.get("active_voxels")
        row = f"    voxels {vox}" + (f" ({act:,} active)" if act is not None else "")
        if "min" in g:
            row += f"; {_range(g)}"
        lines.append(row)
        if g.get("bounds"):
            lines.append(f"    bounds {_fmt_bounds(g['bounds'])}")
            ib = g.get("index_bounds")
            if ib:
                lines.append("    index " + ", ".join(
                    f"{a} {lo} .. {hi}" for a, lo, hi in zip("ijk", ib[0], ib[1], strict=True))
                    + " (voxel coordinates)")
        elif g.get("baked_from"):
            lines.append(f"    baked from {g['baked_from']}; bounds x 0 .. 1, y 0 .. 1, "
                         "z 0 .. 1 source units")
    place = info.get("placement")
    if info.get("grids") and not place:
        bounds = _union([g.get("bounds") for g in info["grids"]])
        if bounds is None and info["grids"][0].get("baked_from"):
            bounds = ([0, 0, 0], [1, 1, 1])
        s = _size_line(bounds, height_mm, size_mm)
        if s:
            lines.append(s)
    if "density_network" in info:
        lines.extend(_ingp_lines(info))
    elif not info.get("grids") and "gaussians" not in info:
        lines.append("  (no grids)")
    if place:
        lines.extend(_placement_lines(place, height_mm, size_mm))
    return "\n".join(lines)


def _placement_lines(place: dict, height_mm, size_mm) -> list[str]:
    """The print's orientation and the object's size (``placement`` of :func:`describe`)."""
    lines = [f"  print orientation: {place['orientation_text']}"]
    occ, box = place.get("occupied_bounds"), place["declared_bounds"]
    lines.append(f"    declared box (print axes) {_fmt_bounds(box)}")
    lines.append("    occupied (non-empty) " + (_fmt_bounds(occ) if occ else
                                                 "nothing: every sampled density is 0"))
    fit_b = place["fit_bounds"]
    m = _mpu(fit_b, height_mm, size_mm)
    if m is not None:
        lines.append(f"  at {m[1]} (--fit {place['fit']}): 1 source unit = {m[0]:.4g} mm; "
                     f"the print is {_span(fit_b, m[0])} (x, y, z)")
        if occ:
            lines.append(f"    the object itself (occupied) {_span(occ, m[0])}")
    return lines


def describe(file: str, up: str | None = None, rotate: int = 0, fit: str = "occupied",
             place: bool = True) -> dict:
    """The ``inspect`` description of ``file`` plus ``content`` (what ``--content auto``
    picks) and ``placement``: the orientation (``up`` None: auto), the declared and the
    occupied bounds in print coordinates (source units) and the bounds ``fit`` sizes."""
    from dreamprint_gui.io.volumes.registry import inspect_source
    from dreamprint_gui.job.content import choose_content, content_of_info

    info, src = inspect_source(file)
    mode, reason = choose_content(src) if src is not None else content_of_info(info)
    out = {**info, "content": {"mode": mode, "reason": reason}}
    if place:
        out["placement"] = _placement(file, src, up, rotate, fit)
    return out


def _placement(file: str, src, up: str | None, rotate: int, fit: str) -> dict | None:
    from dreamprint_gui.io.volumes.orient import choose_orientation, orient_source
    from dreamprint_gui.io.volumes.registry import open_source
    from dreamprint_gui.job.plan import fitted_bounds

    if src is None:
        from dreamprint_gui.job.plan import source_options_for

        try:  # as a job with its defaults opens it (content auto: a level set as a solid)
            src = open_source(file, **source_options_for(file, {}, "auto"))
        except DreamPrintError:
            return None  # described, not printable as opened by default (inspect says why)
    o = choose_orientation(src, up, rotate)
    turned = orient_source(src, o)
    # the job's rule (job.plan.fitted_bounds); the occupied box is shown whatever --fit is
    occ, occupied = fitted_bounds(turned, "occupied")
    placed = occupied if fit == "occupied" else fitted_bounds(turned, fit)[1]
    return {"orientation": o.to_json(), "orientation_text": o.describe(),
            "declared_bounds": placed["declared_bounds"],
            "occupied_bounds": None if occ is None else occupied["bounds"], "fit": fit,
            "fit_bounds": placed["bounds"]}


def _ingp_lines(info: dict) -> list[str]:
    """The InstantNGP snapshot part of ``format_info``."""
    e, d, c = info["encoding"], info["density_network"], info["colour_network"]
    occ = info.get("occupancy_grid")
    return [
        f"  {info['kind']}",
        f"  encoding: {e['type']} grid, {e['levels']} levels x {e['features_per_level']} "
        f"features, 2^{e['log2_hashmap_size']} table, resolution {e['base_resolution']}.."
        f"{e['finest_resolution']} ({e['hashed_levels']} levels hashed)",
        f"  density network: {d['type']} {d['neurons']} wide, {d['hidden_layers']} hidden; "
        f"colour network: {c['type']} {c['neurons']} wide, {c['hidden_layers']} hidden; "
        f"{info['direction_encoding']}",
        f"  {info['parameters']:,} parameters ({info['params_type']}), aabb "
        f"{_fmt_bounds(info['aabb'])}, render box {_fmt_bounds(info['render_aabb'])}",
        "  occupancy grid: " + ("none (every cell evaluated)" if not occ else
                                f"{occ['cascades']} cascade(s), occupied "
                                + ", ".join(f"{100 * f:.1f} %" for f in occ["occupied_fraction"])
                                + ("" if occ["used"] else " (not used)")),
        f"  colour: {info['colour']}",
        f"  samples: density ({info['density_units']}) and colour within bounds "
        f"{_fmt_bounds(info['bounds'])}",
    ]


@cli.command()
@click.argument("file")
@click.option("--json", "as_json", is_flag=True, help="Print the description as JSON.")
@size_options
@placement_options
def inspect(file: str, as_json: bool, height_mm: float | None, size_mm: str | None,
            up: str, rotate: str, fit: str) -> None:
    """Describe a volume file: format, the material intent --content auto picks, and per grid
    its class, voxels, value range and bounds (source units; index; mm with a size); then how
    the print stands (--up, --rotate) and the printed object's size (--fit: occupied or box).

    FILE is an OpenVDB, NanoVDB, VTK/MetaImage/NRRD image, radiance .npz or EXR stack (file or
    folder), Gaussian splats (PLY, SPZ, .splat, .ksplat, SOG .sog / folder / meta.json),
    MagicaVoxel file, InstantNGP snapshot (.ingp/.msgpack) or volume export (RGBA PNG slice
    folder, WxHxD_C.bin), or "demo".
    """

    from dreamprint_gui.core.print_size import check_print_size
    from dreamprint_gui.job.prepare_time import opening_notice

    check_print_size(height_mm, parse_size(size_mm), required=False)
    up_axis, turn = placement_values(up, rotate)
    notice = opening_notice(file)
    if notice is not None:   # a wait of seconds is said before it (stderr: --json stays JSON)
        click.echo(notice, err=True)
    info = describe(file, up_axis, turn, fit)
    if as_json:
        emit_json(info)
    else:
        click.echo(format_info(file, info, height_mm, parse_size(size_mm)))
