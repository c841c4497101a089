"""CLI commands: ``rths3d diagnose`` (model vs measurement) and ``rths3d effects``."""

from __future__ import annotations

from pathlib import Path

import typer

from ._app import app, json_line
from ._output import Keeper


@app.command()
def diagnose(
    measurement: Path = typer.Argument(..., help="Measurement record (.parquet or .csv)."),
    scene: str | None = typer.Option(None, "--scene",
                                     help="Bench model: 'bench' (1-D heave bench), 'stewart' "
                                          "(six-leg platform) — parameters from the record "
                                          "metadata or the defaults — or a TOML file with a "
                                          "[bench] table. Default: as the record's metadata "
                                          "says, else 'bench'."),
    add: list[str] = typer.Option([], "--add",
                                  help="EFFECT (fitted) or EFFECT=value (held at value, SI "
                                       "unit); repeatable."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON object."),
    report: Path | None = typer.Option(None, "--report",
                                       help="Write report.md, plots and replay.parquet here."),
    auto: bool = typer.Option(False, "--auto",
                              help="Accept the proposal round by round until only noise "
                                   "remains."),
    top_k: int = typer.Option(5, "--top-k", min=1, help="Candidates refitted per round."),
) -> None:
    """Compare a measurement with the bench model, rank the missing physical effects."""
    import math

    from ..diagnose import Diagnosis, load_measurement
    from ..diagnose.bench import resolve_scene
    from ..effects import parse_effect_arg
    from ..errors import ConfigError
    from ..figures import check_output

    adds = [parse_effect_arg(a) for a in add]
    names = [name for name, _ in adds]
    for a, name in zip(add, names, strict=True):
        if names.count(name) > 1:
            raise ConfigError("--add", a, f"effect {name!r} given twice")
    if report is not None:
        check_output(report, "--report", folder=True)
    keeper = Keeper()
    rec, channels, warns = load_measurement(measurement)
    bench, kind = resolve_scene(scene, rec.meta)
    diag = Diagnosis(rec, bench, model=kind, top_k=top_k)
    for name, value in adds:
        diag.add(name, value, fix=value is not None)
    rounds = diag.auto() if auto else [diag.run()]
    result = rounds[-1]
    report_path = None
    if report is not None:
        from ..diagnose.report import write_report

        report_path = keeper.write(
            lambda d: write_report(diag, result, d, warns, first_round=rounds[0]), report,
            "--report", folder=True)
    if json_out:
        payload = result.as_dict()
        payload["waterfall"] = diag.waterfall
        payload["rounds"] = [r.proposal.effect if r.proposal else None for r in rounds]
        payload["warnings"] = warns
        payload["report"] = str(report_path) if report_path else None
        payload["ignored_channels"] = list(diag.ignored)
        from ..diagnose.report import localisation

        loc = localisation(diag)
        payload["localisation"] = {"fei": loc["fei"], "contact": loc["contact"]}

        typer.echo(json_line(payload))
        keeper.finish()
        return
    from rich.console import Console
    from rich.table import Table

    con = Console()
    for w in warns:
        con.print(f"[yellow]warning:[/] {w}")
    con.print(f"channels: {', '.join(channels)}; error (noise units) training "
              f"{result.error_train:.3f}, validation {result.error_val:.3f}")
    tab = Table(title="candidate effects (ranked by held-out ΔBIC)")
    for col in ("rank", "effect", "value", "ΔBIC", "val. error", "significant"):
        tab.add_column(col)
    for i, c in enumerate(result.candidates, 1):
        tab.add_row(str(i), c.effect,
                    f"{c.value:.4g} {c.unit}" if c.fitted and math.isfinite(c.value) else "–",
                    f"{c.score:.1f}" if c.fitted else "–",
                    f"{c.error_before:.3f} → {c.error_after:.3f}" if c.fitted else "–",
                    "yes" if c.significant else "no")
    con.print(tab)
    for a, b, cos in result.confounded:
        con.print(f"confounded: {a} ↔ {b} (cos {cos:.3f})")
    if result.noise_only:
        con.print("[green]only noise remains[/]: no effect proposed")
    elif result.proposal is None:
        con.print(f"[red]unexplained residual[/]: {result.error_val:.3g} noise units remain "
                  "that no library effect explains; check the scene or add an effect")
    else:
        p = result.proposal
        con.print(f"proposal: add [bold]{p.effect}[/] ({p.param} = {p.value:.4g} {p.unit}); "
                  f"rerun with --add {p.effect}")
    for w in diag.waterfall:
        con.print(f"  {w['step']}: training {w['error_train']:.3f}, validation "
                  f"{w['error_val']:.3f}")
    if report_path:
        con.print(f"report: {report_path}")
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
    for col in ("effect", "stage", "parameter", "off", "bounds", "signature"):
        tab.add_column(col)
    for r in rows:
        tab.add_row(r["effect"], r["stage"], f"{r['param']} [{r['unit']}]", f"{r['off']:g}",
                    f"[{r['lo']:g}, {r['hi']:g}]", r["signature"])
    Console().print(tab)
