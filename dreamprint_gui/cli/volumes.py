"""``dreamprint inspect FILE [--json] [--height-mm H | --size-mm X,Y,Z]``: what a volume file
holds, per grid or element, and what ``--content auto`` would print it as."""

from __future__ import annotations

import json

import click

from dreamprint_gui.cli import cli
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


def _size_line(bounds, height_mm, size_mm) -> str | None:
    """``at ...: 1 source unit = k mm; the bounds span X x Y x Z mm`` (the rule of
    ``grid_for_source``) or None without a size."""
    if not bounds or (height_mm is None and size_mm is None):
        return None
    ext = [hi - lo for lo, hi in zip(bounds[0], bounds[1], strict=True)]
    if height_mm is not None:
        if ext[2] <= 0:
            return None
        mpu, what = height_mm / ext[2], f"--height-mm {height_mm:g}"
    else:
        ok = [(b / e) for b, e in zip(size_mm, ext, strict=True) if e > 0]
        if not ok:
            return None
        mpu, what = min(ok), "--size-mm " + ",".join(f"{v:g}" for v in size_mm)
    return (f"  at {what}: 1 source unit = {mpu:.4g} mm; the bounds span "
            + " x ".join(f"{e * mpu:.2f}" for e in ext) + " mm")


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
    if info.get("grids"):
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
    return "\n".join(lines)


def describe(file: str) -> dict:
    """The ``inspect`` description of ``file`` plus ``content``: what ``--content auto`` picks."""
    from dreamprint_gui.io.volumes.registry import inspect_source
    from dreamprint_gui.job.content import choose_content, content_of_info

    info, src = inspect_source(file)
    mode, reason = choose_content(src) if src is not None else content_of_info(info)
    return {**info, "content": {"mode": mode, "reason": reason}}


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
@click.option("--height-mm", type=float, default=None,
              help="Also give the size in mm at this print height.")
@click.option("--size-mm", default=None, help="Also give the size in mm fitted into X,Y,Z mm.")
def inspect(file: str, as_json: bool, height_mm: float | None, size_mm: str | None) -> None:
    """Describe a volume file: format, the material intent --content auto picks, and per grid
    its class, voxels, value range and bounds (source units; index; mm with a size).

    FILE is an OpenVDB, NanoVDB, VTK/MetaImage/NRRD image, radiance .npz or EXR stack (file or
    folder), Gaussian splats (PLY, SPZ, .splat, .ksplat, SOG .sog / folder / meta.json),
    MagicaVoxel file, InstantNGP snapshot (.ingp/.msgpack) or volume export (RGBA PNG slice
    folder, WxHxD_C.bin), or "demo".
    """
    from dreamprint_gui.cli.jobs import _size

    if height_mm is not None and size_mm is not None:
        raise DreamPrintError("give at most one of --height-mm and --size-mm")
    if height_mm is not None and not height_mm > 0:
        raise DreamPrintError(f"--height-mm must be positive, got {height_mm}")
    info = describe(file)
    if as_json:
        click.echo(json.dumps(info, indent=2))
    else:
        click.echo(format_info(file, info, height_mm, _size(size_mm)))
