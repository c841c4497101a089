"""CLI commands: ``rths3d diagnose`` (model vs measurement) and ``rths3d effects``."""

from __future__ import annotations

from pathlib import Path

import typer

from ._app import app, json_line
from ._output import Keeper, write_text


def _bench_origin(sc, scene: str | None, meta: dict) -> list[str]:
    """The header lines: where the bench came from, part by part (scene or default)."""
    from ..scene.bench import bench_origin

    if scene:
        source = f"the scene {scene}"
    elif isinstance(meta.get("scene_def"), dict):
        source = f"the record's scene ({meta.get('scene', 'scene_def')})"
    else:
        source = (f"no scene: the record has none and none was given (--scene); using the "
                  f"default {sc.name!r}")
    return bench_origin(sc, source)


@app.command()
def diagnose(
    measurement: Path = typer.Argument(..., help="Measurement record (.parquet or .csv)."),
    scene: str | None = typer.Option(
        None, "--scene",
        help="The bench to compare with: a scene TOML file or the name of a shipped scene of "
             "any experiment kind (paper_contact, paper_linear, multidof). Default: the bench "
             "in the record's metadata (scene, part, leg servos, effects); a fallback to a "
             "default is a warning naming it. Replayed through the Stewart platform."),
    add: list[str] = typer.Option([], "--add",
                                  help="`EFFECT[.leg<i>][.<axis>]` (fitted) or `...=value` (held "
                                       "at value, SI unit), or kinematic_calibration / "
                                       "fts_calibration, or a revision of the "
                                       "description as ranked (`scene:controller.hold=zoh`); "
                                       "repeatable."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON object."),
    report: Path | None = typer.Option(None, "--report",
                                       help="Write report.md, plots and replay.parquet here."),
    auto: bool = typer.Option(False, "--auto",
                              help="Accept the proposal round by round until only noise "
                                   "remains."),
    refit: int = typer.Option(8, "--refit", min=1, help="Candidates refitted per round."),
    save_scene: Path | None = typer.Option(
        None, "--save-scene",
        help="Write the bench with the accepted effects as a scene TOML ([[effect]] tables); "
             "`rths3d run` it to reproduce the measured test."),
    screen_integrator: str = typer.Option(
        "implicitfast", "--screen-integrator",
        help="Integrator of the screening probes: implicitfast (default, ≈ 0.4 of an RK4 "
             "replay; each probe's change anchored on the RK4 replay) or RK4. Refits, "
             "calibrations, revisions and the ranking's figures use the scene's own."),
    baseline: Path | None = typer.Option(
        None, "--baseline",
        help="A record of the healthy bench running the same commands (the same test before "
             "the change): the discrepancy common to both is taken out and what changed is "
             "ranked."),
    hybrid: bool = typer.Option(False, "--hybrid",
                                help="Run the uncalibrated and the calibrated scene closed "
                                     "loop and add their e_rel,track and FEI delay to the "
                                     "report's waterfall (with --report or --json)."),
) -> None:
    """Compare a measurement with its bench model, rank the missing physical effects (each
    effect on each leg and axis, kinematic and FTS calibration), and say where the model
    fails."""
    import math

    from ..diagnose import Diagnosis, load_measurement
    from ..diagnose.bench import resolve_bench
    from ..diagnose.candidates import is_revision
    from ..diagnose.engine import MULTI, SCREEN_INTEGRATORS
    from ..effects import parse_effect_arg
    from ..errors import ConfigError, RthsError
    from ..figures import check_output

    if screen_integrator not in SCREEN_INTEGRATORS:
        raise ConfigError("--screen-integrator", screen_integrator,
                          f"one of {', '.join(SCREEN_INTEGRATORS)}")
    adds = [(a.strip(), None) if a.strip() in MULTI or is_revision(a.strip())
            else parse_effect_arg(a) for a in add]
    names = [name for name, _ in adds]
    for a, name in zip(add, names, strict=True):
        if names.count(name) > 1:
            raise ConfigError("--add", a, f"effect {name!r} given twice")
    if report is not None:
        check_output(report, "--report", folder=True)
    keeper = Keeper()
    if save_scene is not None:
        if save_scene.suffix.lower() != ".toml":
            raise ConfigError("--save-scene", str(save_scene), "must end in .toml")
        check_output(save_scene, "--save-scene")
    rec, channels, warns = load_measurement(measurement)
    sc, bench_warns = resolve_bench(scene, rec.meta)
    origin = _bench_origin(sc, scene, rec.meta)
    if not json_out:
        # first: which parts of the bench came from the scene and which from defaults
        for line in origin:
            typer.echo(line)
    warns = [*warns, *bench_warns]
    healthy = None
    if baseline is not None:
        if not baseline.is_file():
            raise ConfigError("--baseline", str(baseline), "file not found")
        try:
            healthy, _, base_warns = load_measurement(baseline)
        except RthsError as exc:
            raise ConfigError("--baseline", str(baseline), str(exc)) from None
        warns += [f"baseline: {w}" for w in base_warns]
    diag = Diagnosis(rec, sc, refit=refit, screen_integrator=screen_integrator,
                     baseline=healthy)
    warns += diag.warnings
    for name, value in adds:
        diag.add(name, value, fix=value is not None)
    rounds = diag.auto() if auto else [diag.run()]
    result = rounds[-1]
    hyb = None
    if hybrid:
        from ..diagnose.report import hybrid_figures

        hyb = hybrid_figures(diag)
    report_path = None
    if report is not None:
        from ..diagnose.report import write_report

        report_path = keeper.write(
            lambda d: write_report(diag, result, d, warns, first_round=rounds[0], hybrid=hyb),
            report, "--report", folder=True)
    saved = None
    if save_scene is not None:
        from ..scene import scene_to_toml

        text = scene_to_toml(diag.calibrated_scene())

        def save(p: Path) -> Path:
            p.parent.mkdir(parents=True, exist_ok=True)
            return write_text(p, text)

        saved = str(keeper.write(save, save_scene, "--save-scene"))
    if json_out:
        payload = result.as_dict()
        payload["waterfall"] = diag.waterfall
        payload["revisions"] = diag.revisions
        payload["rounds"] = [r.proposal.effect if r.proposal else None for r in rounds]
        payload["warnings"] = warns
        payload["report"] = str(report_path) if report_path else None
        payload["scene"] = saved
        payload["hybrid"] = hyb
        payload["ignored_channels"] = list(diag.ignored)
        payload["bench"] = {"scene": sc.name, "part": sc.experiment.kind,
                            "effects": [e.label for e in sc.effects], "origin": origin}
        typer.echo(json_line(payload))
        keeper.finish()
        return
    from rich.console import Console
    from rich.table import Table

    con = Console()
    for w in warns:
        con.print(f"[yellow]warning:[/] {w}")
    con.print(f"bench: scene {sc.name!r} ({sc.experiment.kind}); {len(diag.channels)} "
              f"channels; error (noise units) training {result.error_train:.3f}, validation "
              f"{result.error_val:.3f}")
    tab = Table(title="candidate effects (ranked by held-out ΔIC; top 15)")
    for col in ("rank", "effect", "value", "ΔIC", "val. error", "significant"):
        tab.add_column(col)
    for i, c in enumerate(result.candidates[:15], 1):
        val = f"{c.value:.4g} {c.unit}" if math.isfinite(c.value) else \
            (f"{len(c.values)} parameters" if c.values else
             f"{c.k} parameter(s) of the scene" if c.changes else "–")
        tab.add_row(str(i), c.effect, val,
                    f"{c.score:.1f}" if math.isfinite(c.score) else "–",
                    f"{c.error_before:.3f} → {c.error_after:.3f}"
                    if math.isfinite(c.error_after) else "–",
                    "yes" if c.significant else "no")
    con.print(tab)
    for a, b, cos in result.confounded:
        con.print(f"confounded: {a} ↔ {b} (cos {cos:.3f})")
    st = result.status
    if st == "noise_only":
        con.print("[green]only noise remains[/]: no effect proposed")
    elif st == "unexplained":
        con.print(f"[red]unexplained systematic residual of {result.systematic_sigma:.3g} σ"
                  f"[/] (validation error {result.error_val:.3g} noise units) that no "
                  "candidate takes most of the way to noise; detection limit "
                  f"{result.detection_limit:.3g} σ; check what the scene cannot state, or "
                  "diagnose against a healthy record (--baseline)")
        if result.absorbed:
            con.print("not proposed (would absorb part of it): " + ", ".join(
                f"{k} ({v:.0%})" for k, v in list(result.absorbed.items())[:4]))
    else:
        p = result.proposal
        if p is not None:
            what = f"{p.param} = {p.value:.4g} {p.unit}" if math.isfinite(p.value) else \
                ", ".join(f"{k} = {v}" for k, v in p.changes.items()) if p.changes else \
                f"{len(p.values)} parameters"
            verb = "proposal: add" if st == "effect_proposed" else "partly explained by"
            con.print(f"{verb} [bold]{p.effect}[/] ({what}); rerun with --add {p.effect}")
        else:
            con.print("[yellow]partly explained[/]: structure remains after the accepted "
                      "effects")
    if result.remaining:
        r = result.remaining
        con.print("residual remains in " + ", ".join(
            f"{c} ({v:.3g} σ)" for c, v in r.get("channels", {}).items()) +
            (f"; band {r['band_hz'][0]:.3g}–{r['band_hz'][1]:.3g} Hz" if "band_hz" in r
             else "") + "; correlated with " + ", ".join(
            f"{k} ({v:+.2f})" for k, v in r.get("state_correlation", {}).items()))
    for r in diag.revisions:
        con.print("description revised: " + "; ".join(
            f"{k}: {v['stated']!r} → {v['revised']!r}" for k, v in r["changes"].items())
            + (f" — {r['evidence']}" if r.get("evidence") else ""))
    for w in diag.waterfall:
        con.print(f"  {w['step']}: training {w['error_train']:.3f}, validation "
                  f"{w['error_val']:.3f}")
    if hyb:
        for n in ("measured", "uncalibrated", "calibrated"):
            con.print(f"  hybrid test, {n}: e_rel,track {100 * hyb[n]['e_rel_track']:.4f} %, "
                      f"FEI delay {1e3 * hyb[n]['fei_d']:.4f} ms")
    if report_path:
        con.print(f"report: {report_path}")
    if saved:
        con.print(f"calibrated scene: {saved} (rths3d run {saved})")
    keeper.finish()


@app.command()
def effects(json_out: bool = typer.Option(False, "--json", help="Print JSON.")) -> None:
    """List the physical effects the diagnosis knows, with parameter, unit and off value."""
    import json

    from ..effects import describe

    rows = describe()
    if json_out:
        typer.echo(json.dumps(rows, default=str))
        return
    from rich.console import Console
    from rich.table import Table

    tab = Table(title="physical effects")
    for col in ("effect", "stage", "parameter", "off", "bounds", "target", "signature"):
        tab.add_column(col)
    for r in rows:
        tab.add_row(r["effect"], r["stage"], f"{r['param']} [{r['unit']}]", f"{r['off']:g}",
                    f"[{r['lo']:g}, {r['hi']:g}]", r["target"], r["signature"])
    Console().print(tab)
