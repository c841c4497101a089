"""CLI command: ``sweep`` (run a sweep spec into a resumable Parquet table)."""

from __future__ import annotations

from pathlib import Path

import typer

from ._app import app


@app.command()
def sweep(
    spec: Path = typer.Argument(..., help="Sweep spec (TOML), e.g. "
                                "scenes/sweeps/paper280_lti.toml."),
    out: Path = typer.Option(..., "--out", help="Output folder (parts, manifest, table)."),
    workers: int = typer.Option(None, "--workers", help="Local worker processes "
                                "(default: all cores)."),
    scheduler: str = typer.Option(None, "--scheduler", help="Dask scheduler address "
                                  "(tcp://host:port): run the batches on that cluster."),
    quiet: bool = typer.Option(False, "--quiet", help="No progress bar."),
    keep_records: bool = typer.Option(False, "--keep-records",
                                      help="Also save every test's record under OUT/records."),
) -> None:
    """Run every test of SPEC not yet finished in OUT and write OUT/`<name>`.parquet.

    Resumable: finished batches are kept; re-running skips them. Unstable tests are recorded
    with their reason. Exit code 1 when a test could not run (status ``error``, e.g. an
    invalid parameter value); the table is written all the same.
    """
    from dataclasses import replace

    from ..dataset import load_spec, run_sweep
    from ..dataset.execute import table_path
    from ..errors import ConfigError
    from ..figures import check_output

    # the folder is checked, not created: a mistake in the spec leaves no folder behind
    check_output(out, "--out", folder=True, create=False)
    s = load_spec(spec)
    if keep_records:
        s = replace(s, keep_records=True)
    if scheduler and workers is not None:
        typer.echo("note: --workers is ignored with --scheduler (the cluster's workers run "
                   "the batches)", err=True)
    try:
        frame = run_sweep(s, out, workers=workers, scheduler=scheduler, progress=not quiet)
    except OSError as exc:  # the disk filled, the folder went away: the parts stay
        raise ConfigError("--out", str(out), f"cannot be written ({exc.strerror or exc}); "
                          "the finished batches are kept in its parts/ folder: run the same "
                          "command again to resume") from None
    if frame is None:
        typer.echo("sweep incomplete (see parts in the output folder)")
        raise typer.Exit(1)
    status = frame["status"] if "status" in frame.columns else None
    n_ok = int((status == "ok").sum()) if status is not None else len(frame)
    n_err = int((status == "error").sum()) if status is not None else 0
    n_stop = len(frame) - n_ok - n_err
    where = table_path(s, out)
    if n_err and n_err == len(frame):
        # nothing ran: a user mistake (every test refused by validation), not a data set
        reasons = _first_reasons(frame[status == "error"])
        raise ConfigError("sweep", s.name, f"all {n_err} tests refused; first reason: "
                          f"{reasons[0]}" + (f" (and {len(reasons) - 1} other reason"
                                             f"{'s' if len(reasons) > 2 else ''}; see the "
                                             f"'reason' column of {where})"
                                             if len(reasons) > 1 else f" (table: {where})"))
    typer.echo(f"{len(frame)} tests ({n_ok} ok, {n_stop} stopped, {n_err} error) → {where}")
    if n_err:
        # an error is a test that could not run (bad value, failed measures), not an
        # instability: the data set is not what the spec asked for
        for reason in _first_reasons(frame[status == "error"])[:3]:
            typer.echo(f"error: {reason}", err=True)
        raise typer.Exit(1)


def _first_reasons(rows) -> list[str]:
    """The distinct reasons of ``rows`` (a table's error rows), most frequent first."""
    reasons = rows["reason"].fillna("").astype(str) if "reason" in rows.columns else None
    if reasons is None or reasons.empty:
        return ["no reason recorded"]
    return [str(r) for r in reasons.value_counts(sort=True).index]
