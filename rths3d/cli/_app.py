"""The typer application shared by the command modules."""

from __future__ import annotations

import json
import math
from typing import Any

import typer


def _flags_take_no_value() -> None:
    """Show no value type for on/off flags in the rich help.

    typer's rich help renders a boolean flag like an option that takes a value (``--json
    <bool>``, also ``--help <bool>``); a flag takes none, so the type column stays empty, as
    in click's plain help. Options that take a value keep their type.
    """
    try:
        from typer.core import TyperOption
    except ImportError:  # pragma: no cover - an older typer renders flags through click
        return
    shown = getattr(TyperOption, "display_type_rich", None)
    if shown is None or getattr(shown, "flags_take_no_value", False):
        return

    def display_type_rich(self, ctx):
        if getattr(self, "is_flag", False) or getattr(self, "count", False):
            return None
        return shown(self, ctx)

    display_type_rich.flags_take_no_value = True  # type: ignore[attr-defined]
    TyperOption.display_type_rich = display_type_rich  # type: ignore[method-assign]


_flags_take_no_value()

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


def warn_implausible(record: Any, source: Any) -> None:
    """Print one warning line (stderr) per number of ``record`` implausible in SI units (a
    record in mm or with time in ms): its measures would be wrong by factors of 1000."""
    from ..plausibility import implausible

    for line in implausible(record):
        typer.echo(f"warning: {source}: {line}", err=True)
