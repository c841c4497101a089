"""PNG figures for every module that draws one: make a figure, then write it.

The figures are :class:`matplotlib.figure.Figure` objects made without pyplot, so drawing a
plot neither switches the user's matplotlib backend (a notebook keeps its inline backend) nor
leaves figures open in pyplot's registry; writing one lays it out, creates the folder and
saves the PNG.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any


def new_figure(figsize: tuple[float, float] = (6.4, 4.8)) -> Any:
    """A :class:`~matplotlib.figure.Figure` of ``figsize`` inches (width, height), detached
    from pyplot; add axes with ``fig.subplots(rows, cols, ...)`` or ``fig.add_subplot``."""
    from matplotlib.figure import Figure

    return Figure(figsize=figsize)


def save_figure(fig: Any, path: str | os.PathLike, *, title: str = "", dpi: int = 110,
                rect: tuple[float, float, float, float] | None = None) -> Path:
    """Give ``fig`` its title, lay it out (inside ``rect``, figure fractions) and write the PNG.

    The folder of ``path`` is created. Returns the path written.
    """
    if title:
        fig.suptitle(title)
    if rect is None:
        fig.tight_layout()
    else:
        fig.tight_layout(rect=rect)
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=dpi)
    return out


__all__ = ["new_figure", "save_figure"]
