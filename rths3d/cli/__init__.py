"""Command line interface: ``rths3d COMMAND``. Commands only; the logic lives in the core.

Each command group lives in its own module and registers itself on the shared app. User
mistakes (:class:`rths3d.errors.RthsError`) print one line and exit with code 2.
"""

from __future__ import annotations

import sys

import typer

from . import (  # noqa: F401  (modules register their commands on import)
    bench,
    benchmark,
    diagnose,
    metrics,
    platform,
    run,
    serve,
    sweep,
    train,
    view,
)
from ._app import app

__all__ = ["app", "main"]


@app.command()
def version() -> None:
    """Print the versions of rths3d and of the physics and learning libraries."""
    from importlib.metadata import version as v

    for pkg in ("rths3d", "mujoco", "numpy", "scipy", "torch", "viser"):
        try:
            typer.echo(f"{pkg} {v(pkg)}")
        except Exception:
            typer.echo(f"{pkg} not installed")


def main(argv: list[str] | None = None) -> None:
    """Entry point of the ``rths3d`` console script."""
    try:
        from typer._click.exceptions import ClickException  # newer typer vendors click
    except ImportError:  # pragma: no cover - older typer uses click itself
        from click.exceptions import ClickException

    from ..errors import RthsError

    try:
        rv = app(args=argv, prog_name="rths3d", standalone_mode=False)
    except typer.Abort:
        print("aborted", file=sys.stderr)
        sys.exit(130)
    except typer.Exit as exc:
        sys.exit(exc.exit_code)
    except ClickException as exc:
        # one line, like every other user mistake (click would add usage and a blank line)
        ctx = getattr(exc, "ctx", None)
        hint = f" (see '{ctx.command_path} --help')" if ctx is not None else ""
        message = " ".join(exc.format_message().split())
        print(f"error: {message}{hint}", file=sys.stderr)
        sys.exit(exc.exit_code)
    except RthsError as exc:
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(2)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        sys.exit(130)
    sys.exit(rv if isinstance(rv, int) else 0)
