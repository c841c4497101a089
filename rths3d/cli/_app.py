"""The typer application shared by the command modules."""

from __future__ import annotations

import typer

app = typer.Typer(
    name="rths3d",
    help=(
        "Virtual real-time hybrid substructure testing (vRTHS) on a MuJoCo Stewart platform.\n\n"
        "Run a hybrid test, compute its accuracy measures, generate training data, train the "
        "fidelity ANN, watch a test live in the browser and diagnose a model against "
        "measurements. SI units throughout."
    ),
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode="markdown",
)


@app.callback()
def _root() -> None:
    """rths3d: virtual real-time hybrid substructure testing on a MuJoCo Stewart platform."""

