"""``dreamprint predict``, ``calibrate``, ``evaluate density-fit``."""

from __future__ import annotations

import math
from pathlib import Path

import click

from dreamprint_gui.cli.group import cli, evaluate
from dreamprint_gui.cli.output import emit_json
from dreamprint_gui.core.errors import DreamPrintError


def parse_thickness(text: str | None) -> float | None:
    if text is None:
        return None
    if text.strip().lower() in ("inf", "infinite", "infinity"):
        return math.inf
    try:
        t = float(text)
    except ValueError:
        raise DreamPrintError(f"--thickness-mm must be a number of mm or 'inf', got {text!r}") \
            from None
    if not t > 0:
        raise DreamPrintError("--thickness-mm must be > 0")
    return t


def parse_pair(text: str | None, option: str) -> tuple[float, float] | None:
    if text is None:
        return None
    try:
        a, b = (float(x) for x in text.split(","))
    except ValueError:
        raise DreamPrintError(f"{option} takes two numbers 'k1,k2', got {text!r}") from None
    return a, b


profile_option = click.option("--profile", "profile_path", default=None, metavar="P",
                              help="Ink profile JSON (default: the built-in PolyJet profile).")


@cli.command()
@click.option("--mix", "mix_text", metavar="C=0.2,M=0.3,W=0.5", help="One mixture.")
@click.option("--mix-file", type=click.Path(dir_okay=False, path_type=Path),
              help="CSV of recipes: header of ink names, one row per mixture.")
@profile_option
@click.option("--thickness-mm", default=None, metavar="T|inf",
              help="Layer thickness (default: the profile's colour reference, R_inf).")
@click.option("--saunderson", default=None, metavar="k1,k2",
              help="Predict what an instrument measures (surface correction).")
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
def predict(mix_text: str | None, mix_file: Path | None, profile_path: str | None,
            thickness_mm: str | None, saunderson: str | None, as_json: bool) -> None:
    """Spectra, colour and density of ink mixtures (Kubelka-Munk, eqs. 3-9)."""
    from dreamprint_gui.core.profile import load_profile, parse_mix
    from dreamprint_gui.io.recipes import read_recipes
    from dreamprint_gui.physics.mixture import predict as predict_mix

    if (mix_text is None) == (mix_file is None):
        raise click.UsageError("give exactly one of --mix or --mix-file")
    profile = load_profile(profile_path)
    t = parse_thickness(thickness_mm)
    sd = parse_pair(saunderson, "--saunderson")
    if mix_text is not None:
        result = predict_mix(profile, parse_mix(mix_text), t, sd)
        records: object = result.record()
        rows = [(mix_text, result.record())]
    else:
        conc = read_recipes(mix_file)
        result = predict_mix(profile, conc, t, sd)
        records = [result.record(i) for i in range(conc.shape[0])]
        rows = [(f"row {i + 1}", r) for i, r in enumerate(records)]
    if as_json:
        emit_json(records)
        return
    for label, r in rows:
        srgb = ", ".join(f"{x:.4f}" for x in r["sRGB"])
        lab = ", ".join(f"{x:.2f}" for x in r["Lab"])
        click.echo(f"{label}: sRGB ({srgb})  Lab ({lab})  sigma {r['sigma_per_mm']:.4g}/mm")


@cli.command()
@click.argument("measurements", required=False,
                type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Profile JSON to write.")
@click.option("--chart", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="Recipes CSV of a printed mixture chart.")
@click.option("--reflectance", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="Measured reflectance of the chart's patches (any format `dreamprint spectra` "
                   "reads), one spectrum per recipe in the same order.")
@click.option("--base-profile", default=None, metavar="P",
              help="Profile to start from / keep unmeasured inks from (default: built-in).")
@click.option("--name", default=None, help="Name of the new profile.")
@click.option("--saunderson", default=None, metavar="k1,k2",
              help="Chart readings include surface reflections (Saunderson k1,k2).")
@click.option("--folds", default=5, show_default=True, help="Cross-validation folds (chart).")
@click.option("--slabs", is_flag=True,
              help="The layers are free-standing slabs measured in air (the translucency "
                   "wedge, `dreamprint target wedge`): fit the bulk K, S with both faces "
                   "(Saunderson), their uncertainty and each slab's residual.")
@click.option("--refractive-index", default=1.5, show_default=True, type=float,
              help="With --slabs: the slabs' refractive index (gives k1 and k2).")
@click.option("--fit-k2", is_flag=True,
              help="With --slabs: fit the faces' internal reflectance k2 per ink (two or more "
                   "thicknesses) instead of the diffuse value of the refractive index.")
@click.option("--json", "as_json", is_flag=True, help="Print the fit report as JSON.")
@click.option("-q", "--quiet", is_flag=True, help="No progress on stderr.")
def calibrate(measurements: Path | None, output: Path, chart: Path | None,
              reflectance: Path | None, base_profile: str | None, name: str | None,
              saunderson: str | None, folds: int, slabs: bool, refractive_index: float,
              fit_k2: bool, as_json: bool, quiet: bool) -> None:
    """Fit ink K and S from measurements and write a profile.

    MEASUREMENTS is a calibration set (.toml, naming instrument files per ink) or a CSV in
    DreamPrint's layout (docs/measurements-csv.md). With --slabs they are a thickness series
    of slabs measured in air (docs/translucency.md). With --chart and --reflectance, refit all
    inks jointly to a printed mixture chart and report cross-validated dE2000.
    """
    from dreamprint_gui.core.profile import load_profile

    base = load_profile(base_profile)
    ctx = click.get_current_context()
    index_given = ctx.get_parameter_source("refractive_index") is not \
        click.core.ParameterSource.DEFAULT
    if chart is not None or reflectance is not None:
        if chart is None or reflectance is None or measurements is not None:
            raise click.UsageError("a chart needs both --chart and --reflectance (and no "
                                   "MEASUREMENTS)")
        if slabs or fit_k2 or index_given:
            raise click.UsageError("--slabs, --refractive-index and --fit-k2 apply to "
                                   "MEASUREMENTS of slabs, not to a chart")
        report = _calibrate_chart(base, chart, reflectance, name, parse_pair(
            saunderson, "--saunderson"), folds, output, quiet)
    else:
        if measurements is None:
            raise click.UsageError("give MEASUREMENTS (.toml or .csv) or --chart/--reflectance")
        slab_options = None
        if slabs:
            from dreamprint_gui.physics.slab_fit import SlabOptions

            if not 1.0 <= refractive_index <= 3.0:
                raise DreamPrintError(f"--refractive-index must lie in 1-3, got "
                                      f"{refractive_index:g}")
            slab_options = SlabOptions(refractive_index, fit_k2)
        elif fit_k2 or index_given:
            raise click.UsageError("--refractive-index and --fit-k2 apply to --slabs")
        report = _calibrate_layers(base, measurements, name, output, slab_options)
    if as_json:
        emit_json(report)
    else:
        _print_report(report)


def _calibrate_layers(base, path: Path, name: str | None, output: Path, slabs=None) -> dict:
    from dreamprint_gui.core.profile import ink_origins, save_profile
    from dreamprint_gui.physics.calibration import calibrate_profile

    if path.suffix.lower() == ".toml":
        from dreamprint_gui.io.spectra.calibration_set import load_calibration_set

        layers = load_calibration_set(path, base.wavelengths_nm)
    else:
        from dreamprint_gui.io.measurements_csv import read_measurements_csv

        layers = read_measurements_csv(path, base.wavelengths_nm)
    profile, fits = calibrate_profile(layers, base, name or output.stem, slabs=slabs)
    save_profile(profile, output)
    return {"profile": str(output), "kind": "slabs" if slabs else "layers",
            "inks": [f.summary() for f in fits],
            "inks_from_base_profile": sorted(profile.provenance["inks_from_base_profile"]),
            "ink_origin": ink_origins(profile)}


def _calibrate_chart(base, chart: Path, reflectance: Path, name: str | None,
                     saunderson, folds: int, output: Path, quiet: bool = False) -> dict:
    from dreamprint_gui.core.profile import save_profile
    from dreamprint_gui.io.chart_files import read_chart
    from dreamprint_gui.physics.chart_calibration import fit_chart

    files = read_chart(chart, reflectance, base.wavelengths_nm)
    recipes, spectra = files.recipes, files.reflectance
    from dreamprint_gui.cli.progress import step_progress

    fit = fit_chart(base, recipes, spectra, folds=folds, saunderson=saunderson,
                    name=name or output.stem, source=str(chart),
                    progress=step_progress(f"calibrate --chart, {len(recipes)} patches: fits (all "
                                           "patches, then each fold)", quiet))
    save_profile(fit.profile, output)
    return {"profile": str(output), "kind": "chart", **fit.report()}


def _print_report(report: dict) -> None:
    click.echo(f"wrote {report['profile']}")
    if report["kind"] == "layers":
        for ink in report["inks"]:
            r = ink["max_rms_R"]
            t = ink["max_rms_T"]
            click.echo(f"  {ink['ink']:>2}: {ink['method']}, {len(ink['layers'])} layer(s), "
                       f"worst-wavelength RMS residual R {'-' if r is None else f'{r:.2e}'}, "
                       f"T {'-' if t is None else f'{t:.2e}'}")
        if report["inks_from_base_profile"]:
            click.echo("  kept from the base profile: "
                       + ", ".join(report["inks_from_base_profile"]))
    elif report["kind"] == "slabs":
        _print_slabs(report)
    else:
        for key in ("base_dE2000", "fit_dE2000", "cross_validated_dE2000"):
            s = report[key]
            click.echo(f"  {key.replace('_', ' ')}: mean {s['mean']:.3f}, p95 {s['p95']:.3f}, "
                       f"max {s['max']:.3f}")


def _print_slabs(report: dict) -> None:
    def num(x: float | None, f: str = ".2f") -> str:
        return "-" if x is None else format(x, f)

    for ink in report["inks"]:
        k2 = "fitted" if ink["k2_fitted"] else "from n"
        click.echo(f"  {ink['ink']:>2}: {len(ink['slabs'])} slab(s), faces k1 {ink['k1']:.3f} "
                   f"k2 {ink['k2']:.3f} ({k2}); 1-sigma over 450-700 nm up to "
                   f"K {num(ink['max_rel_sigma_K_450_700'], '.1%')}, "
                   f"S {num(ink['max_rel_sigma_S_450_700'], '.1%')}")
        for s in ink["slabs"]:
            t = "inf" if s["thickness_mm"] is None else f"{s['thickness_mm']:g}"
            click.echo(f"      {t:>5} mm: rms R {num(s['rms_R'], '.4f')} T "
                       f"{num(s['rms_T'], '.4f')}, dE2000 R {num(s['dE2000_R'])} T "
                       f"{num(s['dE2000_T'])}{'' if s['fits'] else '  DOES NOT FIT'}")
        for w in ink["warnings"]:
            click.echo(f"  warning: {w}", err=True)
    origin = report["ink_origin"]
    click.echo("  measured: " + (", ".join(i for i, o in origin.items() if o == "measured")
                                 or "none") + "; modelled: "
               + (", ".join(i for i, o in origin.items() if o == "modelled") or "none"))


@evaluate.command("density-fit")
@profile_option
@click.option("--t-max-mm", default=5.0, show_default=True, help="Thickness range of the fit.")
@click.option("--samples", default=100, show_default=True, help="Thickness samples.")
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
def density_fit(profile_path: str | None, t_max_mm: float, samples: int, as_json: bool) -> None:
    """The paper's Table 1: error of approximating T(t) by exp(-sigma t), per ink."""
    from dreamprint_gui.core.profile import load_profile
    from dreamprint_gui.physics.density import exp_fit_errors

    profile = load_profile(profile_path)
    mean, worst = exp_fit_errors(profile.K, profile.S, t_max_mm, samples)
    inks = {ink: {"mean_percent": float(mean[i] * 100), "max_percent": float(worst[i] * 100)}
            for i, ink in enumerate(profile.inks)}
    if as_json:
        emit_json({"profile": profile.name, "t_max_mm": t_max_mm, "samples": samples,
                   "inks": inks})
        return
    click.echo(f"{'':6}" + "".join(f"{ink:>9}" for ink in inks))
    click.echo("Mean  " + "".join(f"{v['mean_percent']:8.3f}%" for v in inks.values()))
    click.echo("Max   " + "".join(f"{v['max_percent']:8.3f}%" for v in inks.values()))
