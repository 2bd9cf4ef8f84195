"""``dreamprint inspect FILE [--json]``: what a volume file holds, per grid or element."""

from __future__ import annotations

import json

import click

from . import cli


def _fmt_num(v) -> str:
    if v is None:
        return "-"
    if isinstance(v, (list, tuple)):
        return "(" + ", ".join(_fmt_num(x) for x in v) + ")"
    return f"{v:.6g}" if isinstance(v, float) else str(v)


def _fmt_bounds(b) -> str:
    return f"{_fmt_num(b[0])} .. {_fmt_num(b[1])}" if b else "-"


def format_info(path: str, info: dict) -> str:
    """The human-readable form of a source's ``info()``."""
    lines = [f"{path}: {info['format']}"]
    if "gaussians" in info:
        lines.append(f"  {info['gaussians']:,} Gaussians, SH degree {info['sh_degree']}, "
                     f"bounds {_fmt_bounds(info['bounds'])}")
    for g in info.get("grids", []):
        shape = " x ".join(str(s) for s in g["shape"]) if g.get("shape") else "-"
        lines.append(f"  {g['name']!s}: {g['class']}, {shape}, "
                     f"{g['active_voxels']:,} active voxels, range {_fmt_num(g['min'])} .. "
                     f"{_fmt_num(g['max'])}, {g['dtype']}, bounds {_fmt_bounds(g['bounds'])}")
    if "density_network" in info:
        lines.extend(_ingp_lines(info))
    elif not info.get("grids") and "gaussians" not in info:
        lines.append("  (no grids)")
    return "\n".join(lines)


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
def inspect(file: str, as_json: bool) -> None:
    """Describe a volume file: format and, per grid, class, size, active voxels, range, bounds.

    FILE is an OpenVDB, NanoVDB, VTK/MetaImage/NRRD image, radiance .npz or EXR stack (file or
    folder), splat PLY/SPZ or MagicaVoxel file, InstantNGP snapshot (.ingp/.msgpack) or volume
    export (RGBA PNG slice folder, WxHxD_C.bin), or "demo".
    """
    from ..io.volumes.base import inspect_file

    info = inspect_file(file)
    if as_json:
        click.echo(json.dumps(info, indent=2))
    else:
        click.echo(format_info(file, info))
