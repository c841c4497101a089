"""A sweep worker's life bound to the sweep process's, set first thing in the worker.

The sweep process holds the only write end of a pipe (the lifeline); each pool worker gets
the read end. EOF on it means the sweep process has gone, even by SIGKILL, and the worker
must go too, so that nothing is left running (with the workers gone, the pool's forkserver
and resource tracker end as well). This module imports nothing heavy: unpickling it in a new
worker arms the lifeline before the worker spends seconds importing rths3d's kernels.
"""

from __future__ import annotations

import os
import select
import sys
import threading

__all__ = ["worker_init"]


def worker_init(lifeline=None, progress=None) -> None:
    """Pool initializer: arm the lifeline, then the worker's set-up
    (:func:`rths3d.dataset.execute.worker_setup`)."""
    if lifeline is not None and not _kill_on_eof(lifeline):
        threading.Thread(target=_watch, args=(lifeline,), daemon=True,
                         name="rths3d-lifeline").start()
    from .dataset.execute import worker_setup

    worker_setup(progress)


def _kill_on_eof(conn) -> bool:
    """On Linux, have the kernel kill this process the moment the lifeline's write end
    closes (O_ASYNC with F_SETSIG = SIGKILL: no thread, no GIL, so even a worker busy in a
    long compiled call goes at once). Returns False where this is not available."""
    if not sys.platform.startswith("linux"):
        return False
    import fcntl
    import signal

    fd = conn.fileno()
    try:
        fcntl.fcntl(fd, fcntl.F_SETOWN, os.getpid())
        fcntl.fcntl(fd, getattr(fcntl, "F_SETSIG", 10), signal.SIGKILL)
        fcntl.fcntl(fd, fcntl.F_SETFL, fcntl.fcntl(fd, fcntl.F_GETFL) | os.O_ASYNC)
    except OSError:  # pragma: no cover - a kernel without it: the watcher thread remains
        return False
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
