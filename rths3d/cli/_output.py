"""Output paths of the commands: checked before the work, and a result kept when writing
still fails after it.

Every command that writes checks its output paths first (:func:`check_file`,
:func:`check_folder`), so a mistake costs nothing. Writing can still fail at the end (the
disk fills, the folder is removed or made read-only while the test runs); then the result is
written to a fresh temporary folder instead, and the command ends with one error line naming
the option, the path, the reason and where the result was kept (exit code 2).
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from ..errors import ConfigError, RthsError
from ..figures import check_output

KEPT_PREFIX = "rths3d-kept-"
"""Prefix of the temporary folders that keep a result its target could not take."""


def check_file(path: str | os.PathLike, option: str,
               suffixes: Sequence[str] = ()) -> Path:
    """``path`` as a file that can be written (its folder is created): not a folder, in a
    writable folder, and ending in one of ``suffixes`` when given. ConfigError naming
    ``option`` otherwise."""
    p = Path(path)
    if suffixes and p.suffix.lower() not in suffixes:
        raise ConfigError(option, str(p), f"must end in {' or '.join(suffixes)}")
    return check_output(p, option)


def check_folder(path: str | os.PathLike, option: str) -> Path:
    """``path`` as a folder that can be written (created); ConfigError naming ``option``."""
    return check_output(path, option, folder=True)


def _write_error(exc: BaseException) -> OSError | None:
    """The OSError behind ``exc`` when it is a failure to write (also when a saver wrapped
    it in one of our errors), else None."""
    seen = exc
    while seen is not None:
        if isinstance(seen, OSError):
            return seen
        if not isinstance(seen, RthsError):
            return None
        seen = seen.__cause__ or seen.__context__
    return None


def write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` atomically (temporary name, then renamed): a failed write leaves no
    partial file that looks complete."""
    p = Path(path)
    tmp = p.with_name(f".{p.name}.tmp{os.getpid()}")
    try:
        tmp.write_text(text)
        os.replace(tmp, p)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink(missing_ok=True)
        raise
    return p


class Keeper:
    """Writes a command's results; what cannot be written where asked is kept elsewhere.

    ``keeper.write(fn, path, option)`` calls ``fn(path)``; if that fails for a reason of the
    file system, it calls ``fn`` again on the same name in a new temporary folder
    (``folder=True``: on that folder) and remembers the failure. :meth:`finish`, called when
    the command has printed its results, raises one ConfigError naming every failure and
    where its result is.
    """

    def __init__(self) -> None:
        self.kept: list[tuple[str, str, str, Path]] = []
        self._spare: dict[str, Path] = {}

    def write(self, fn: Callable[[Path], Any], path: str | os.PathLike, option: str, *,
              folder: bool = False) -> Any:
        """``fn(path)``, or ``fn`` on the same name in a temporary folder when the file
        system refuses ``path``. With ``folder=True``, ``path`` is the option's folder: once
        it has failed, further writes of that option go straight to its temporary folder."""
        p = Path(path)
        if folder and option in self._spare:
            return fn(self._spare[option])
        try:
            return fn(p)
        except Exception as exc:
            err = _write_error(exc)
            if err is None:
                raise
            reason = err.strerror or str(err)
        spare = Path(tempfile.mkdtemp(prefix=KEPT_PREFIX))
        target = spare if folder else spare / p.name
        if folder:
            self._spare[option] = spare
        out = fn(target)
        self.kept.append((option, str(p), reason, target))
        return out

    def finish(self) -> None:
        """Raise the one-line error for the results written elsewhere (if any)."""
        if not self.kept:
            return
        option, path, reason, where = self.kept[0]
        more = "".join(f"; {o} could not be written either ({r}), kept in {w}"
                       for o, _, r, w in self.kept[1:])
        raise ConfigError(option, path, f"cannot be written ({reason}); the result is kept in "
                          f"{where}{more}")


__all__ = ["KEPT_PREFIX", "Keeper", "check_file", "check_folder", "write_text"]
