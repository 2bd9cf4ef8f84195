"""``dreamprint lookup`` and ``dreamprint gamut``: the RGB -> ink table and its gamut (issue 5)."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import click

from dreamprint_gui.cli.group import cli
from dreamprint_gui.cli.options import INTENT_HELP, INTENTS, OBJECTIVE_HELP, OBJECTIVES
from dreamprint_gui.cli.output import emit_json
from dreamprint_gui.cli.progress import notice, progress_bar, step_progress
from dreamprint_gui.core.errors import DreamPrintError

_PRINTER = click.option(
    "--printer", default=None, metavar="P",
    help="The printer whose layer thickness the densities are per (built-in name or .toml; "
         "default: the default printer): the tables a job on it uses, cached once for both.")


def _parse_rgb(text: str) -> list[float]:
    parts = [p.strip() for p in text.split(",")]
    try:
        v = [float(p) for p in parts]
    except ValueError:
        raise DreamPrintError(f"--rgb {text!r} is not three numbers R,G,B") from None
    if len(v) != 3 or not all(math.isfinite(x) and 0.0 <= x <= 1.0 for x in v):
        raise DreamPrintError(f"--rgb {text!r} must be three numbers in [0, 1]")
    return v


def _read_rgb_file(path: str) -> list[list[float]]:
    p = Path(path)
    try:
        with p.open(newline="", encoding="utf-8-sig") as fh:
            rows = list(csv.reader(fh))
    except FileNotFoundError:
        raise DreamPrintError("no such file", p) from None
    except UnicodeDecodeError:
        raise DreamPrintError("not a text CSV file (expected a header row R,G,B)", p) from None
    except OSError as exc:
        raise DreamPrintError(f"cannot read: {exc.strerror or exc}", p) from None
    if not rows:
        raise DreamPrintError("empty file; expected a header row R,G,B", p)
    header = [h.strip().upper() for h in rows[0]]
    try:
        cols = [header.index(c) for c in ("R", "G", "B")]
    except ValueError:
        raise DreamPrintError(f"header {rows[0]} must name columns R, G and B", p, 1) from None
    out = []
    for line, row in enumerate(rows[1:], start=2):
        if not any(cell.strip() for cell in row):
            continue
        try:
            v = [float(row[c]) for c in cols]
        except (IndexError, ValueError):
            raise DreamPrintError("R, G, B must be numbers", p, line) from None
        if not all(math.isfinite(x) and 0.0 <= x <= 1.0 for x in v):
            raise DreamPrintError("R, G, B must be in [0, 1]", p, line)
        out.append(v)
    if not out:
        raise DreamPrintError("no colours after the header", p)
    return out


@cli.command()
@click.option("--rgb", "rgb_text", help="One colour R,G,B (encoded sRGB in [0, 1]).")
@click.option("--rgb-file", type=click.Path(dir_okay=False),
              help="CSV with a header row R,G,B; one colour per row.")
@click.option("--density", type=float, default=None,
              help="Target density sigma (1/mm) for the alignment (default: none, the table's "
                   "mixture is kept).")
@click.option("--profile", "profile_path", default=None, help="Ink profile JSON (default: "
              "built-in).")
@click.option("--objective", type=OBJECTIVES, default=None, help=OBJECTIVE_HELP)
@click.option("--intent", type=INTENTS, default=None, help=INTENT_HELP)
@_PRINTER
@click.option("--size", type=click.IntRange(2, 200), default=100, show_default=True)
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
def lookup(rgb_text, rgb_file, density, profile_path, objective, intent, printer, size,
           as_json) -> None:
    """Ink concentrations for colours: table lookup, density alignment, reproduced colour."""
    import numpy as np

    from dreamprint_gui.core.profile import COLOUR_INKS, INKS
    from dreamprint_gui.gamut import align_density, get_tables
    from dreamprint_gui.gamut import lookup as table_lookup
    from dreamprint_gui.job.plan import profile_for_printer
    from dreamprint_gui.physics.colorimetry import delta_E2000, observer_for, srgb_to_lab
    from dreamprint_gui.physics.mixture import predict

    if (rgb_text is None) == (rgb_file is None):
        raise DreamPrintError("give exactly one of --rgb or --rgb-file")
    if density is not None and not (math.isfinite(density) and density >= 0):
        raise DreamPrintError("--density must be a finite number >= 0 (1/mm)")
    colours = [_parse_rgb(rgb_text)] if rgb_text else _read_rgb_file(rgb_file)
    profile = profile_for_printer(profile_path, printer)
    tables = get_tables(profile, objective, size, progress=progress_bar(), intent=intent,
                        notify=notice)
    rgb = np.asarray(colours, dtype=np.float64)
    conc5 = table_lookup(tables, rgb)
    pred = predict(profile, conc5)  # exactly what `dreamprint predict --mix` computes
    target_lab = srgb_to_lab(rgb, observer_for(profile.wavelengths_nm))
    de = delta_E2000(pred.Lab, target_lab)
    sig_target = pred.sigma_per_mm if density is None else np.full(len(rgb), density)
    al = align_density(tables, rgb, conc5, sig_target, profile)
    records = []
    for i, c in enumerate(colours):
        records.append({
            "rgb": c,
            "concentrations": {ink: float(conc5[i, j]) for j, ink in enumerate(COLOUR_INKS)},
            "aligned": {ink: float(al.conc[i, j]) for j, ink in enumerate(INKS)},
            "sRGB": pred.sRGB[i].tolist(),
            "Lab": pred.Lab[i].tolist(),
            "dE2000": float(de[i]),
            "sigma_per_mm": float(al.sigma[i]),
            "density_clamped": {-1: "low", 0: None, 1: "high"}[int(al.clamped[i])],
            # how far the achieved sigma stays from the target (0 when reached), 1/mm
            "density_shortfall_per_mm": float(abs(sig_target[i] - al.sigma[i]))
            if al.clamped[i] else 0.0,
        })
    if as_json:
        emit_json(records)
        return
    for r in records:
        conc = " ".join(f"{k}={v:.3f}" for k, v in r["aligned"].items())
        click.echo(f"rgb {r['rgb']} -> {conc}  sRGB "
                   f"{', '.join(f'{x:.3f}' for x in r['sRGB'])}  dE2000 {r['dE2000']:.2f}  "
                   f"sigma {r['sigma_per_mm']:.3f}/mm"
                   + (f" (clamped {r['density_clamped']})" if r["density_clamped"] else ""))


@cli.command()
@click.option("--profile", "profile_path", default=None, help="Ink profile JSON.")
@click.option("--objective", type=OBJECTIVES, default=None, help=OBJECTIVE_HELP)
@click.option("--intent", type=INTENTS, default=None, help=INTENT_HELP)
@click.option("--compare/--no-compare", default=True, show_default=True,
              help="Also build (or load) the tables of the other objectives and report their "
                   "figures under 'objectives'.")
@click.option("--size", type=click.IntRange(2, 200), default=100, show_default=True)
@click.option("--samples", type=click.IntRange(10, 100000), default=2000, show_default=True,
              help="Random colours for the LUT-vs-direct comparison.")
@click.option("--chart", type=click.Path(dir_okay=False), help="Write the Fig. 7 hexagon chart "
              "(PNG).")
@click.option("--plot", type=click.Path(dir_okay=False), help="Write the CIELAB gamut plot (PNG).")
@_PRINTER
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
def gamut(profile_path, objective, intent, compare, size, samples, chart, plot, printer,
          as_json) -> None:
    """Build (or load) the colour tables and report the printable gamut."""
    from dreamprint_gui.gamut import get_tables
    from dreamprint_gui.gamut.charts import gamut_plot, hexagon_chart
    from dreamprint_gui.gamut.evaluation import evaluate
    from dreamprint_gui.gamut.optimise import OBJECTIVES
    from dreamprint_gui.gamut.tables import resolve_choice
    from dreamprint_gui.job.plan import profile_for_printer

    profile = profile_for_printer(profile_path, printer)
    objective, intent = resolve_choice(profile, objective, intent)
    tables = get_tables(profile, objective, size, progress=progress_bar(f"{objective}, {intent}"),
                        intent=intent, notify=notice)
    others = []
    if compare:
        for other in OBJECTIVES:
            if other != objective:
                others.append(get_tables(profile, other, size, intent=intent,
                                         progress=progress_bar(f"{other}, {intent}"),
                                         notify=notice))
    label = (f"evaluating: {samples} colours solved directly vs the table"
             + (f", for {1 + len(others)} objectives" if others else "")
             + " (the lattice's best, then each objective)")
    report = evaluate(tables, profile, samples, others, progress=step_progress(label))
    for target, draw in ((chart, lambda p: hexagon_chart(tables, profile, p)),
                         (plot, lambda p: gamut_plot(profile, p))):
        if target:
            try:
                draw(target)
            except OSError as exc:
                raise DreamPrintError(f"cannot write: {exc.strerror or exc}", target) from None
    if as_json:
        emit_json(report)
        return
    lv = report["lut_vs_direct_dE2000"]
    og = report["out_of_gamut_dE2000"]
    how = (f"loaded from the cache in {report['load_seconds']:.1f} s (built earlier in "
           f"{report['built_seconds_when_cached']:.1f} s)" if report["cached"] else
           f"built in {report['build_seconds']:.1f} s")
    click.echo(f"table {report['lut_size']}^3, objective {report['objective']}, intent "
               f"{report['intent']}, {how}")
    click.echo(f"sRGB in gamut (dE2000 <= {report['in_gamut_threshold_dE2000']}): "
               f"{100 * report['srgb_in_gamut_fraction']:.1f} %; CIELAB volume printable "
               f"{report['lab_gamut_volume']:.0f} vs sRGB {report['srgb_lab_volume']:.0f}")
    if lv["count"]:
        click.echo(f"LUT vs direct dE2000: mean {lv['mean']:.3f}, p95 {lv['p95']:.3f}, "
                   f"max {lv['max']:.3f}")
    if og["count"]:
        click.echo(f"out of gamut dE2000: mean {og['mean']:.2f}, p95 {og['p95']:.2f}, "
                   f"max {og['max']:.2f}")
    click.echo("objective  LUT-vs-direct mean/p95  in gamut  lookup-lattice mean/p95  "
               "max node jump (excess)  build s")
    for name, f in report["objectives"].items():
        a, g, j = (f["lut_vs_direct_dE2000"], f["lookup_minus_lattice_best_dE2000"],
                   f["adjacent_node_dE2000"])
        click.echo(f"{name:9s}  {_num(a['mean']):>6s} / {_num(a['p95']):<6s}       "
                   f"{100 * f['srgb_in_gamut_fraction']:5.1f} %  {g['mean']:+7.3f} / "
                   f"{g['p95']:+7.3f}        {j['max']:6.2f} ({j['max_excess']:+.2f})"
                   f"          {_built(f)}")


def _built(f: dict) -> str:
    if f["cached"]:
        return f"{f['built_seconds_when_cached']:6.1f} (cached)"
    return f"{f['build_seconds']:6.1f}"


def _num(x) -> str:
    return "-" if x is None else f"{x:.3f}"
