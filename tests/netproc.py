"""Processes and sockets of the network tests: `rths3d serve` and OpenSees clients started
in their own sessions, always killed at the end, and the checks that nothing is left."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

from processes import alive_in_session

ROOT = Path(__file__).resolve().parents[1]
OPENSEES = Path(__file__).resolve().parent / "opensees"
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


def has_openseespy() -> bool:
    try:
        import openseespy.opensees  # noqa: F401
    except Exception:
        return False
    return True


def _as_from_a_terminal() -> None:
    """In the child before exec: SIGINT to its default, as a command typed in a terminal has
    it (a pytest-xdist worker ignores SIGINT, and an ignored signal stays ignored across
    exec: the server under test would never see its Ctrl-C)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


class Proc:
    """A process in its own session, SIGINT at its default; its stdout read line by line on
    a thread."""

    def __init__(self, args: list[str], cwd: Path = ROOT):
        self.args = args
        self.p = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                  start_new_session=True, cwd=cwd, env=ENV, text=True,
                                  preexec_fn=_as_from_a_terminal)
        self.lines: list[str] = []
        self._t = threading.Thread(target=self._read, daemon=True)
        self._t.start()
        self.stderr = ""

    def _read(self) -> None:
        assert self.p.stdout is not None
        for line in self.p.stdout:
            self.lines.append(line.rstrip("\n"))

    def wait_line(self, prefix: str, timeout: float = 120.0) -> str:
        t0 = time.time()
        while time.time() < t0 + timeout:
            for line in self.lines:
                if line.startswith(prefix):
                    return line
            if self.p.poll() is not None and not self._t.is_alive():
                break
            time.sleep(0.02)
        raise AssertionError(f"no line {prefix!r} from {self.args}: {self.lines} "
                             f"{self.finish(1.0)[1]}")

    def finish(self, timeout: float = 120.0) -> tuple[int, str]:
        """Wait for the process (killed after ``timeout``); its exit code and stderr."""
        try:
            self.p.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.kill()
            self.p.wait()
        self._t.join(5.0)
        if self.p.stderr is not None and not self.p.stderr.closed:
            self.stderr = self.p.stderr.read() or ""
            self.p.stderr.close()
        if self.p.stdout is not None and not self._t.is_alive():
            self.p.stdout.close()
        return self.p.returncode, self.stderr

    def kill(self) -> None:
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(self.p.pid, signal.SIGKILL)

    @property
    def json(self) -> dict:
        import json

        return json.loads(self.lines[-1])

    def left(self) -> list[tuple[int, str]]:
        """Live processes of its session a moment after it ended."""
        t0 = time.time()
        while alive_in_session(self.p.pid) and time.time() < t0 + 5.0:
            time.sleep(0.05)
        return alive_in_session(self.p.pid)


def serve(scene: Path, *extra: str) -> tuple[Proc, int]:
    """``rths3d serve SCENE --port 0 …`` running, and its port."""
    proc = Proc([sys.executable, "-m", "rths3d", "serve", str(scene), "--port", "0", *extra])
    line = proc.wait_line("listening on ")
    return proc, int(line.rsplit(":", 1)[1])


def opensees(script: str, *args: object) -> Proc:
    return Proc([sys.executable, str(OPENSEES / script), *map(str, args)])


def open_ports(pid: int) -> list[str]:
    """TCP sockets the process ``pid`` still holds (its /proc fd links), empty when it is
    gone."""
    out = []
    with contextlib.suppress(OSError):
        for fd in os.listdir(f"/proc/{pid}/fd"):
            with contextlib.suppress(OSError):
                link = os.readlink(f"/proc/{pid}/fd/{fd}")
                if link.startswith("socket:"):
                    out.append(link)
    return out


def port_listeners(port: int) -> list[str]:
    """Lines of /proc/net/tcp with local port ``port`` in LISTEN or ESTABLISHED state."""
    hexport = f"{port:04X}"
    found = []
    for path in ("/proc/net/tcp", "/proc/net/tcp6"):
        with contextlib.suppress(OSError), open(path) as f:
            for line in list(f)[1:]:
                cols = line.split()
                if cols[1].endswith(":" + hexport) and cols[3] in ("0A", "01"):
                    found.append(line.strip())
    return found
