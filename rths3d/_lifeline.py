"""A sweep worker's life bound to the sweep process's, set first thing in the worker.

The sweep process holds the only write end of a pipe (the lifeline); each pool worker gets
the read end. EOF on it means the sweep process has gone, even by SIGKILL, and the worker
must go too, so that nothing is left running (with the workers gone, the pool's forkserver
and resource tracker end as well). On Linux the worker also asks the kernel for SIGKILL when
its parent (the forkserver, which ends with the sweep process) goes. This module imports
nothing heavy and nothing of the package at import time: unpickling it in a new worker arms
the lifeline before the worker spends seconds importing rths3d's kernels; the worker's
set-up and warm-up (:func:`rths3d.dataset.runner.worker_setup`) come after.
"""

from __future__ import annotations

import os
import select
import sys
import threading

__all__ = ["worker_init"]


def worker_init(lifeline=None, progress=None, warm: bytes | None = None,
                inherited=None) -> None:
    """Pool initializer: arm the lifeline and the parent-death signal, then the worker's
    set-up and warm-up (:func:`rths3d.dataset.runner.worker_setup`: ``progress`` is the
    sweep's shared counter, ``warm`` the pickled work that loads the kernels a batch uses;
    None for a worker forked from a warm sweep process). ``inherited``: the lifeline's write
    end a forked worker inherited, closed first (only the sweep process may hold it)."""
    if inherited is not None:
        inherited.close()
    if lifeline is not None and not _kill_on_eof(lifeline):
        threading.Thread(target=_watch, args=(lifeline,), daemon=True,
                         name="rths3d-lifeline").start()
    _die_with_parent()
    from .dataset.runner import worker_setup

    worker_setup(progress, warm)


def _die_with_parent() -> None:
    """On Linux: SIGKILL from the kernel when this process's parent ends (prctl
    PR_SET_PDEATHSIG); if the parent has already gone, end now."""
    if not sys.platform.startswith("linux"):
        return
    import ctypes
    import signal

    parent = os.getppid()
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)  # 1 = PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # pragma: no cover - no prctl: the lifeline remains
        return
    if os.getppid() != parent or parent == 1:
        os._exit(1)


_OWN: list[int] = []
"""This worker's own descriptor of the lifeline (kept open for the worker's life)."""


def _kill_on_eof(conn) -> bool:
    """On Linux, have the kernel kill this process the moment the lifeline's write end
    closes (O_ASYNC with F_SETSIG = SIGKILL: no thread, no GIL, so even a worker busy in a
    long compiled call goes at once). Returns False where this is not available.

    The signal's owner (F_SETOWN) belongs to the open file description, which the workers'
    copies of the read end share (they are passed, not reopened): the last worker to set it
    would be the only one killed. So each worker opens the pipe anew (``/proc/self/fd``), a
    description of its own, and arms that."""
    if not sys.platform.startswith("linux"):
        return False
    import fcntl
    import signal

    try:
        fd = os.open(f"/proc/self/fd/{conn.fileno()}", os.O_RDONLY | os.O_CLOEXEC)
    except OSError:  # pragma: no cover - no /proc: the watcher thread remains
        return False
    try:
        fcntl.fcntl(fd, fcntl.F_SETOWN, os.getpid())
        fcntl.fcntl(fd, getattr(fcntl, "F_SETSIG", 10), signal.SIGKILL)
        fcntl.fcntl(fd, fcntl.F_SETFL, fcntl.fcntl(fd, fcntl.F_GETFL) | os.O_ASYNC)
    except OSError:  # pragma: no cover - a kernel without it: the watcher thread remains
        os.close(fd)
        return False
    _OWN.append(fd)
    if select.select([fd], [], [], 0)[0]:  # the sweep process was gone before the call
        os._exit(1)
    return True


def _watch(conn) -> None:
    """End this process when the lifeline's write end has closed (the thread fallback)."""
    try:
        while True:
            conn.recv()  # nothing is ever sent: this returns only by EOF
    except (EOFError, OSError):
        pass
    os._exit(1)
