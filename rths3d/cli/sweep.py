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
    with their reason.
    """
    from dataclasses import replace

    from ..dataset import load_spec, run_sweep
    from ..dataset.execute import table_path

    s = load_spec(spec)
    if keep_records:
        s = replace(s, keep_records=True)
    frame = run_sweep(s, out, workers=workers, scheduler=scheduler, progress=not quiet)
    if frame is None:
        typer.echo("sweep incomplete (see parts in the output folder)")
        raise typer.Exit(1)
    n_ok = int((frame["status"] == "ok").sum()) if "status" in frame.columns else len(frame)
    typer.echo(f"{len(frame)} tests ({n_ok} ok, {len(frame) - n_ok} stopped) → "
               f"{table_path(s, out)}")
