"""PNG figures for every module that draws one: make a figure, then write it.

The figures are :class:`matplotlib.figure.Figure` objects made without pyplot, so drawing a
plot neither switches the user's matplotlib backend (a notebook keeps its inline backend) nor
leaves figures open in pyplot's registry; writing one lays it out, creates the folder and
saves the PNG.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
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

    The folder of ``path`` is created; a path without a suffix gets ``.png`` (as matplotlib
    would add). Returns the path written.
    """
    if title:
        fig.suptitle(title)
    if rect is None:
        fig.tight_layout()
    else:
        fig.tight_layout(rect=rect)
    out = png_path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    # written under a temporary name and renamed: a failed write leaves no partial PNG
    tmp = out.with_name(f".{out.name}.tmp{os.getpid()}")
    try:
        fig.savefig(tmp, dpi=dpi, format=out.suffix[1:].lower() or "png")
        os.replace(tmp, out)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink(missing_ok=True)
        raise
    return out


def png_path(path: str | os.PathLike) -> Path:
    """``path`` as a PNG file name: ``.png`` appended when it has no suffix."""
    out = Path(path)
    return out if out.suffix else out.with_name(out.name + ".png")


def check_output(path: str | os.PathLike, option: str, *, folder: bool = False,
                 create: bool = True) -> Path:
    """Check, before any long work, that ``path`` can be written: a file (its folder is
    created; not an existing folder) or, with ``folder=True``, a folder (created; not an
    existing file). The folder is tried with a probe file. ``create=False``: nothing is
    created; the nearest existing folder on the way is tried instead. ConfigError naming
    ``option``."""
    from .errors import ConfigError

    p = Path(path)
    if folder and p.exists() and not p.is_dir():
        raise ConfigError(option, str(p), "exists and is not a folder")
    if not folder and p.is_dir():
        raise ConfigError(option, str(p), "is a folder; give a file name")
    where = p if folder else p.parent
    file = next((q for q in (where, *where.parents) if q.exists() and not q.is_dir()), None)
    if file is not None:
        raise ConfigError(option, str(p), f"cannot create the folder: {str(file)!r} is a "
                          "file, not a folder")
    if create:
        try:
            where.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise ConfigError(option, str(p), "cannot create the folder: "
                              f"{exc.strerror or exc}") from None
    else:
        where = next(q for q in (where, *where.parents) if q.exists())
    # try it: os.access says yes to root even on a read-only file system
    try:
        fd, probe = tempfile.mkstemp(prefix=".rths3d-probe-", dir=where)
    except OSError as exc:
        raise ConfigError(option, str(p), f"folder {str(where)!r} is not writable "
                          f"({exc.strerror or exc})") from None
    os.close(fd)
    os.unlink(probe)
    return p


__all__ = ["check_output", "new_figure", "png_path", "save_figure"]
