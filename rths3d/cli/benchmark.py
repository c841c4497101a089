"""CLI commands: ``rths3d benchmark rths`` — the community RTHS benchmark (Silva et al.)."""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

import typer

from ._app import app, json_line
from ._output import Keeper

bench_app = typer.Typer(help="Community benchmarks reproduced with rths3d.", no_args_is_help=True)
app.add_typer(bench_app, name="benchmark")



def _fmt(v: float | None, width: int = 7) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "—".rjust(width)
    return f"{v:{width}.2f}"


@bench_app.command("rths")
def rths(
    case: int = typer.Option(0, "--case", help="Partitioning case 1–4 (0: all four)."),
    excitation: str = typer.Option(None, "--excitation",
                                   help="Ground motion: ElCentro (default), Kobe or Morgan."),
    trials: int = typer.Option(None, "--trials",
                               help="Perturbed-plant trials per case (paper: ≥ 20; default 0, "
                                    "or 20 with --compensator)."),
    noise: bool = typer.Option(None, "--noise/--no-noise", help="Sensor noise (default on)."),
    force_delay: bool = typer.Option(None, "--force-delay/--no-force-delay",
                                     help="One-sample delay on the measured force (default on)."),
    intensity: float = typer.Option(None, "--intensity", help="Scale of the record (0.4)."),
    convention: str = typer.Option(None, "--convention",
                                   help="J order/definitions: code (published table) or paper."),
    scene: str = typer.Option("", "--scene", help="Benchmark scene TOML (plant, controller, …)."),
    set_: list[str] = typer.Option([], "--set", help="Scene override key=value (repeatable)."),
    seed: int = typer.Option(123, "--seed", help="Seed of the perturbed-plant draws."),
    data: str = typer.Option("", "--data", help="Benchmark folder holding data/ (optional)."),
    plot: str = typer.Option("", "--plot", help="Save a PNG of the first case's time history "
                             "(and `<name>`_trials.png of the trial spread with --trials)."),
    compensator: str = typer.Option(
        "", "--compensator",
        help="Replace the controller's phase lead (its outer compensation; the PI loop stays) "
             "by this compensator, or 'all' for every one: none, velocity, polynomial, lead, "
             "ats, inverse, rls, model_based."),
    comp_set: list[str] = typer.Option(
        [], "--comp-set", help="Compensator parameter key=value (repeatable), e.g. "
        "a1_bounds=[0,0.009]; with --compensator all: name.key=value."),
    calibrate: bool = typer.Option(
        True, "--calibrate/--no-calibrate",
        help="Calibrate the compensator offline on a predefined displacement test of the "
             "nominal plant first (initial coefficients, identified model, τ_c)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
) -> None:
    """Run the RTHS benchmark and print J1–J9 beside the published Table 3.

    J1 is the tracking delay in ms, J2–J9 normalised errors in %.
    A case whose actuator force reaches 8900 N stops safely (reported with the reason); so
    does a run whose adaptive compensator drifts out of its bounds.
    Options given on the command line override the scene file. With --compensator, each case
    also runs with the compensator in place of the phase lead (same plants, same noise) and
    its J1–J9 are printed beside the benchmark controller's.
    """
    from dataclasses import replace

    from ..community.trials import J_KEYS, trial_stats
    from ..errors import ConfigError

    # the cheap checks before the benchmark's (scipy) imports
    if case not in (0, 1, 2, 3, 4):
        raise ConfigError("--case", case, "must be 1, 2, 3 or 4 (0 for all)")
    comp_names, comp_params = _compensator_args(compensator, comp_set)
    if trials is None:
        trials = 20 if compensator else 0
    if trials < 0:
        raise ConfigError("--trials", trials, "must be ≥ 0")

    from ..community import PUBLISHED_TABLE3, BenchmarkConfig, load_excitation, run_case, run_trials
    from ..community.scene import config_from_dict, load_benchmark_scene
    if plot:
        from ..figures import check_output, png_path

        plot_path = check_output(png_path(plot), "--plot")
        trials_path = plot_path.with_name(plot_path.stem + "_trials" + plot_path.suffix)
        check_output(trials_path, "--plot")
    if scene:
        base = load_benchmark_scene(scene, set_)
    else:
        base = config_from_dict(_overrides_only(set_)) if set_ else BenchmarkConfig()
    given = {k: v for k, v in (("excitation", excitation), ("noise", noise),
                                ("force_delay", force_delay), ("intensity", intensity),
                                ("convention", convention)) if v is not None}
    base = replace(base, **given)
    cases = [case] if case else ([base.case] if scene else [1, 2, 3, 4])
    excitation, intensity, noise = base.excitation, base.intensity, base.noise
    force_delay, convention = base.force_delay, base.convention
    gm = load_excitation(base.excitation, intensity, data or None)
    published_applies = (base.excitation == "ElCentro" and intensity == 0.4 and noise
                         and force_delay and convention == "code"
                         and base == replace(BenchmarkConfig(), case=base.case))
    out: dict[str, Any] = {
        "excitation": base.excitation, "intensity": intensity, "noise": noise,
        "force_delay": force_delay, "convention": convention, "trials": trials,
        "units": {"J1": "ms", "J2-J9": "%"}, "cases": {},
    }
    from rich.progress import Progress

    total = len(cases) * (1 + trials)
    first = None
    trial_rows: dict[int, list] = {}
    comp_configs: dict[str, Any] = {}
    bench_trials: dict[int, list] = {}
    comp_first = None
    if comp_names:
        from ..community.compensated import calibrated_config, calibration_record

        record = calibration_record(replace(base, case=1)) if calibrate else None
        for name in comp_names:
            if calibrate:
                comp_configs[name] = calibrated_config(name, base, comp_params.get(name),
                                                       record=record)
            else:
                from ..compensation import config_from_dict

                comp_configs[name] = config_from_dict(name, comp_params.get(name),
                                                      "--comp-set")
        out["compensators"] = {n: _config_dict(c) for n, c in comp_configs.items()}
        out["calibrated"] = calibrate
        total += len(cases) * len(comp_names)
    with Progress(transient=True, disable=as_json or not sys.stderr.isatty()) as prog:
        task = prog.add_task("benchmark", total=total)
        for c in cases:
            cfg = replace(base, case=c)
            res = run_case(cfg, gm=gm)
            first = first or res
            prog.advance(task)
            # a stopped test has no criteria (its record is partial); the reason says why
            ok_run = res.status == "ok" and bool(res.j)
            entry: dict[str, Any] = dict(res.table_row()) if ok_run else dict.fromkeys(J_KEYS)
            entry.update(status=res.status, reason=res.reason,
                         max_force_N=round(res.peak_force, 1),
                         published=PUBLISHED_TABLE3[c] if published_applies else None)
            if trials:
                rs = run_trials(cfg, n_trials=trials, seed=seed, gm=gm,
                                progress=lambda _i: prog.advance(task))
                bench_trials[c] = rs
                ok = [r for r in rs if r.status == "ok"]
                trial_rows[c] = [r.table_row() for r in ok]
                entry["trials"] = {
                    "n": len(rs), "ok": len(ok),
                    "stopped": [r.reason for r in rs if r.status != "ok"],
                    "max_force_N": round(max(r.peak_force for r in rs), 1),
                }
                if ok:
                    entry["trials"].update(trial_stats(trial_rows[c],
                                                       ("mean", "std", "min", "max", "median")))
            if comp_names:
                from ..community.compensated import run_compensated

                entry["compensators"] = {}
                for name in comp_names:
                    rs = run_compensated(cfg, name, comp_configs[name], n_trials=trials,
                                         seed=seed, gm=gm, history_every=64 if plot else 0)
                    comp_first = comp_first or rs[0]
                    entry["compensators"][name] = _compensated_entry(rs, bench_trials.get(c))
                    prog.advance(task)
            out["cases"][str(c)] = entry
    keeper = Keeper()
    if plot:
        from ..community.plots import plot_compensator, plot_result, plot_trials

        if comp_first is not None and len(comp_names) == 1:
            out["plot"] = str(keeper.write(lambda p: plot_result(comp_first, p), plot_path,
                                           "--plot"))
            coef_path = plot_path.with_name(plot_path.stem + "_compensator" + plot_path.suffix)
            out["plot_compensator"] = str(keeper.write(
                lambda p: plot_compensator(comp_first, first, p), coef_path, "--plot"))
        else:
            out["plot"] = str(keeper.write(lambda p: plot_result(first, p), plot_path,
                                           "--plot"))
        if trial_rows:
            out["plot_trials"] = str(keeper.write(
                lambda p: plot_trials(trial_rows, p,
                                      PUBLISHED_TABLE3 if published_applies else None),
                trials_path, "--plot"))
    if as_json:
        typer.echo(json_line(out))
        keeper.finish()
        return
    if comp_names:
        _print_compensated(out, base, intensity, noise, force_delay, convention, trials)
        if not published_applies:
            typer.echo("(the paper publishes Table 3 only for El Centro × 0.4, nominal plant, "
                       "noise on)")
        keeper.finish()
        return
    head = "case  row        " + "".join(k.rjust(7) for k in J_KEYS)
    typer.echo(f"RTHS benchmark: {base.excitation} × {intensity}, noise "
               f"{'on' if noise else 'off'}, force delay {'on' if force_delay else 'off'}, "
               f"{convention} convention (J1 in ms, J2–J9 in %)")
    typer.echo(head)
    for c, e in out["cases"].items():
        if e["status"] != "ok":
            typer.echo(f"{c:>4}  STOPPED    {e['reason']}")
        else:
            typer.echo(f"{c:>4}  ours       " + "".join(_fmt(e[k]) for k in J_KEYS))
        if e["published"]:
            typer.echo(f"{'':>4}  published  " + "".join(_fmt(e['published'][k])
                                                         for k in J_KEYS))
        tr = e.get("trials")
        if tr:
            if "mean" in tr:
                typer.echo(f"{'':>4}  mean({tr['ok']:>2})   "
                           + "".join(_fmt(tr["mean"][k]) for k in J_KEYS))
                typer.echo(f"{'':>4}  std        " + "".join(_fmt(tr["std"][k])
                                                             for k in J_KEYS))
                typer.echo(f"{'':>4}  min        " + "".join(_fmt(tr["min"][k])
                                                             for k in J_KEYS))
                typer.echo(f"{'':>4}  max        " + "".join(_fmt(tr["max"][k])
                                                             for k in J_KEYS))
            typer.echo(f"{'':>4}  trials: {tr['ok']}/{tr['n']} completed, "
                       f"max |F_act| = {tr['max_force_N']:.0f} N")
            for reason in tr["stopped"]:
                typer.echo(f"{'':>4}  stopped trial: {reason}")
    for key in ("plot", "plot_trials", "plot_compensator"):
        if key in out:
            typer.echo(f"wrote {out[key]}")
    if not published_applies:
        typer.echo("(the paper publishes Table 3 only for El Centro × 0.4, nominal plant, "
                   "noise on)")
    keeper.finish()


def _overrides_only(items: list[str]) -> dict:
    """A scene mapping built from ``--set key=value`` items alone."""
    from ..scene import apply_overrides

    return apply_overrides({}, items)


def _compensator_args(compensator: str, items: list[str]) -> tuple[list[str], dict]:
    """The compensators to run and their parameters per name from ``--comp-set``."""
    from ..compensation import COMPENSATORS, compensator_names
    from ..errors import ConfigError
    from ..scene import apply_overrides

    if not compensator:
        if items:
            raise ConfigError("--comp-set", items[0], "needs --compensator")
        return [], {}
    names = compensator_names() if compensator == "all" else [compensator]
    if compensator != "all" and compensator not in COMPENSATORS:
        raise ConfigError("--compensator", compensator,
                          "must be one of " + ", ".join(compensator_names()) + " or all")
    raw = apply_overrides({}, items)
    if compensator == "all":
        for key, value in raw.items():
            if key not in COMPENSATORS or not isinstance(value, dict):
                raise ConfigError(f"--comp-set {key}", value, "with --compensator all, give "
                                  "name.key=value (name: " + ", ".join(names) + ")")
        params = raw
    else:
        params = {compensator: raw}
    from ..compensation import config_from_dict

    for name, p in params.items():  # refuse bad keys before anything runs
        config_from_dict(name, p, "--comp-set")
    return names, params


def _config_dict(config: Any) -> dict:
    from dataclasses import asdict

    return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(config).items()}


def _compensated_entry(rs: list, bench: list | None) -> dict:
    """The nominal run (first) and, with more, the perturbed trials of one compensator."""
    import numpy as np

    from ..community.trials import J_KEYS, trial_stats

    r0 = rs[0]
    ok0 = r0.status == "ok" and bool(r0.j)
    e: dict[str, Any] = dict(r0.table_row()) if ok0 else dict.fromkeys(J_KEYS)
    e.update(status=r0.status, reason=r0.reason, max_force_N=round(r0.peak_force, 1),
             coefficients={k: float(v) for k, v in r0.coefficients.items()})
    tr = rs[1:]
    if tr:
        ok = [r for r in tr if r.status == "ok" and r.j]
        t: dict[str, Any] = {"n": len(tr), "ok": len(ok),
                             "stopped": [r.reason for r in tr if r.status != "ok"],
                             "max_force_N": round(max(r.peak_force for r in tr), 1)}
        if ok:
            t.update(trial_stats([r.table_row() for r in ok],
                                 ("median", "mean", "std", "min", "max")))
        if bench is not None and len(bench) == len(tr):
            ratios = [r.table_row()["J2"] / b.table_row()["J2"]
                      for r, b in zip(tr, bench, strict=True)
                      if r.status == "ok" and b.status == "ok" and r.j and b.j]
            if ratios:
                t["J2_ratio_median"] = round(float(np.median(ratios)), 4)
                t["J2_ratio_max"] = round(float(np.max(ratios)), 4)
        e["trials"] = t
    return e


def _print_compensated(out: dict, base: Any, intensity: float, noise: bool, force_delay: bool,
                       convention: str, trials: int) -> None:
    from ..community.trials import J_KEYS

    names = list(out["compensators"])
    typer.echo(f"RTHS benchmark: {base.excitation} × {intensity}, noise "
               f"{'on' if noise else 'off'}, force delay {'on' if force_delay else 'off'}, "
               f"{convention} convention (J1 in ms, J2–J9 in %)")
    typer.echo("outer compensation (the phase lead) replaced by: " + ", ".join(names)
               + (" — calibrated on a predefined displacement test" if out["calibrated"]
                  else ""))
    n_ok = max((e.get("trials", {}).get("ok", 0) for e in out["cases"].values()), default=0)
    width = max(14, *(len(f"{n} median({n_ok})") + 1 for n in ("bench", *names)))
    head = "case  " + "row".ljust(width) + "".join(k.rjust(7) for k in J_KEYS)
    typer.echo(head)

    def row(c: str, label: str, vals: dict) -> None:
        typer.echo(f"{c:>4}  {label.ljust(width)}" + "".join(_fmt(vals[k]) for k in J_KEYS))

    for c, e in out["cases"].items():
        if e["published"]:
            row(c, "published", e["published"])
        if e["status"] != "ok":
            typer.echo(f"{c:>4}  {'benchmark'.ljust(width)}STOPPED  {e['reason']}")
        else:
            row(c, "benchmark", e)
        for name, ce in e["compensators"].items():
            if ce["status"] != "ok":
                typer.echo(f"{c:>4}  {name.ljust(width)}STOPPED  {ce['reason']}")
            else:
                row(c, name, ce)
        if trials:
            bt = e.get("trials", {})
            if "median" in bt:
                row("", f"bench median({bt['ok']})", bt["median"])
            for name, ce in e["compensators"].items():
                t = ce.get("trials", {})
                if "median" in t:
                    row("", f"{name} median({t['ok']})", t["median"])
            for name, ce in e["compensators"].items():
                t = ce.get("trials", {})
                ratio = (f", median J2 ratio to the benchmark {t['J2_ratio_median']:.3f} (max "
                         f"{t['J2_ratio_max']:.3f})" if "J2_ratio_median" in t else "")
                worst = (f", max J1 {t['max']['J1']:.1f} ms, max J2 {t['max']['J2']:.2f} %"
                         if "max" in t else "")
                typer.echo(f"{'':>4}  {name}: {t.get('ok', 0)}/{t.get('n', 0)} trials completed"
                           f"{worst}{ratio}")
                for reason in t.get("stopped", []):
                    typer.echo(f"{'':>4}    stopped trial: {reason}")
    for key in ("plot", "plot_compensator"):
        if key in out:
            typer.echo(f"wrote {out[key]}")


# ---------------------------------------------------------------------------------------
# the multi-axial benchmark (maRTHS) with RoDeAC


@bench_app.command("marths")
def marths(
    record: str = typer.Option("ElCentro", "--record",
                               help="Ground motion: ElCentro, Kobe, Morgan or all."),
    intensity: float = typer.Option(0.4, "--intensity", help="Scale of the record (0.4)."),
    compensator: str = typer.Option(
        "rodeac", "--compensator",
        help="Compensator per actuator: rodeac (the benchmark's controller), none, polynomial, "
             "ats, inverse, rls, model_based, velocity; or 'all' for rodeac and the six "
             "project compensators."),
    comp_set: list[str] = typer.Option(
        [], "--comp-set", help="Compensator parameter key=value (repeatable); with "
        "--compensator all: name.key=value."),
    trials: int = typer.Option(0, "--trials",
                               help="Perturbed plants besides the nominal one (mean reported)."),
    seed: int = typer.Option(123, "--seed", help="Seed of the perturbed-plant draws."),
    initial: str = typer.Option("stored", "--initial",
                                help="RoDeAC's θ0, P0: stored (the benchmark's) or calibrated "
                                     "(this project's offline calibration)."),
    calibrate: bool = typer.Option(
        True, "--calibrate/--no-calibrate",
        help="Calibrate the project's compensators per actuator on the open-loop targets of "
             "the three records (nominal plant) first."),
    noise: bool = typer.Option(True, "--noise/--no-noise", help="Sensor noise (default on)."),
    t_end: float = typer.Option(None, "--t-end", help="Stop time (s); default: the record's."),
    data: str = typer.Option("", "--data", help="maRTHS benchmark folder holding data/."),
    plot: str = typer.Option("", "--plot", help="Save a PNG of the (first) nominal run: "
                             "tracking in x and θ, storey drifts against the reference."),
    opensees: str = typer.Option(
        "", "--opensees", help="The numerical substructure from an OpenSees model file "
        "(build(ops); node e = SAP2000 equation e), e.g. scenes/opensees/marths_frame.py; "
        "nominal plant only."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
) -> None:
    """Run the multi-axial RTHS benchmark (Condori Uribe et al. 2023) and print J1–J10.

    24 numbers per run: J1, J4 delays in ms; J2, J3 tracking, J5, J6 estimation, J7–J10 global
    errors in %. With --trials the perturbed plants' mean is reported beside the nominal run
    (as the benchmark does, rounded to 0.1). A run whose measured actuator displacement
    leaves 100 mm, or whose compensator leaves its bounds, stops safely with the reason.
    """
    from ..errors import ConfigError

    # the cheap checks first, before the benchmark's imports
    if not (math.isfinite(intensity) and 0.0 < intensity <= 10.0):
        raise ConfigError("--intensity", intensity, "must be in (0, 10]")
    if trials < 0:
        raise ConfigError("--trials", trials, "must be ≥ 0")
    if t_end is not None and not t_end > 0.0:
        raise ConfigError("--t-end", t_end, "must be > 0 s")
    if initial not in ("stored", "calibrated"):
        raise ConfigError("--initial", initial, "must be stored or calibrated")
    if opensees:
        if trials:
            raise ConfigError("--trials", trials, "must be 0 with --opensees (one OpenSees "
                              "domain per process: the nominal plant only)")
        if not Path(opensees).is_file():
            raise ConfigError("--opensees", opensees, "file not found")
    from ..community.marths.data import RECORDS, record_name

    if record.lower() == "all":
        records = list(RECORDS)
    else:
        try:
            records = [record_name(record)]
        except ConfigError:
            raise ConfigError("--record", record, "must be ElCentro, Kobe, Morgan or all"
                              ) from None
    from ..community.marths.summary import COMPARED

    if compensator == "all":
        names = list(COMPARED)
        comp_names, comp_params = _compensator_args("all", comp_set)
        comp_params = {n: comp_params.get(n) for n in names}
    else:
        comp_names, comp_params = _compensator_args(compensator, comp_set)
        names = comp_names
    if "lead" in names:
        raise ConfigError("--compensator", "lead", "the single-actuator benchmark's phase lead "
                          "has no maRTHS setting; choose another")
    from ..community.marths.data import data_dir

    data_path = str(data_dir(data or None))
    if plot:
        from ..figures import check_output, png_path

        plot_path = check_output(png_path(plot), "--plot")
    from rich.progress import Progress

    from ..community.marths.criteria import J_LABELS
    from ..community.marths.summary import run_set

    first: list = []
    frame = None
    if opensees:
        from ..community.marths.opensees_frame import OpenSeesFrame

        frame = OpenSeesFrame(opensees, 1.0 / 1024.0)
    try:
        with Progress(transient=True, disable=as_json or not sys.stderr.isatty()) as prog:
            task = prog.add_task("maRTHS", total=len(records) * len(names))
            res = run_set(names, records, intensity, trials, seed, initial, calibrate,
                          comp_params, noise, t_end, data_path=data_path,
                          keep=lambda _r, _n, r: first.append(r) if not first else None,
                          progress=lambda _r, _n: prog.advance(task), numerical=frame)
    finally:
        if frame is not None:
            frame.close()
    out: dict[str, Any] = {
        "benchmark": "maRTHS (Condori Uribe et al. 2023), RoDeAC (Quiroz et al. 2024)",
        "intensity": intensity, "fs_Hz": 1024.0, "noise": noise, "trials": trials,
        "seed": seed, "initial": initial, "calibrated": calibrate, "t_end": t_end,
        "opensees": str(Path(opensees).resolve()) if opensees else None,
        "units": {"J1": "ms", "J4": "ms", "J2-J3,J5-J10": "%"},
        "labels": {k: list(v) for k, v in J_LABELS.items()}, "records": res,
    }
    keeper = Keeper()
    if plot and first:
        from ..community.marths.plots import plot_run

        out["plot"] = str(keeper.write(lambda p: plot_run(first[0], p), plot_path, "--plot"))
    if as_json:
        typer.echo(json_line(out))
        keeper.finish()
        return
    _print_marths(out, names, J_LABELS)
    keeper.finish()


def _print_marths(out: dict, names: list[str], labels: dict) -> None:
    """J1–J10 (rows) per compensator (columns), nominal and the trials' mean."""
    typer.echo(f"maRTHS benchmark × {out['intensity']}, noise {'on' if out['noise'] else 'off'}"
               f", RoDeAC θ0/P0 {out['initial']}; J1, J4 in ms, the others in %")
    for rec, comps in out["records"].items():
        cols = []
        for n in names:
            cols.append((n, comps[n].get("J")))
            tr = comps[n].get("trials")
            if tr:
                cols.append((f"{n} μ{tr['ok']}/{tr['n']}", tr.get("J")))
        width = max(9, *(len(c[0]) + 1 for c in cols))
        typer.echo(f"\n{rec}")
        typer.echo("J".ljust(12) + "".join(c[0].rjust(width) for c in cols))
        for k, labs in labels.items():
            for i, lab in enumerate(labs):
                cells = "".join((f"{c[1][k][i]:.1f}" if c[1] else "—").rjust(width)
                                for c in cols)
                typer.echo(f"{k}.{lab}".ljust(12) + cells)
        for n in names:
            e = comps[n]
            if e["status"] != "ok":
                typer.echo(f"{n}: STOPPED — {e['reason']}")
            tr = e.get("trials")
            if tr:
                for reason in tr["stopped"]:
                    typer.echo(f"{n}: stopped trial — {reason}")
                if not tr["realizable"]:
                    typer.echo(f"{n}: NOT realizable (both commands beyond 3.8 V in a trial)")
    if "plot" in out:
        typer.echo(f"wrote {out['plot']}")
