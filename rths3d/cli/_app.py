"""The typer application shared by the command modules."""

from __future__ import annotations

import json
import math
from typing import Any

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


def _finite(o: Any) -> Any:
    """``o`` with every non-finite float replaced by None (JSON null)."""
    if isinstance(o, float) and not math.isfinite(o):
        return None
    if isinstance(o, dict):
        return {k: _finite(v) for k, v in o.items()}
    if isinstance(o, list | tuple):
        return [_finite(v) for v in o]
    return o


def json_line(obj: Any, **kw: Any) -> str:
    """``obj`` as one line of valid JSON: non-finite floats (NaN from constant data, a
    prediction from NaN inputs) become null, since a bare NaN breaks standard readers."""
    return json.dumps(_finite(obj), allow_nan=False, **kw)
