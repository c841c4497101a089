"""`rths3d view` as a user runs it: ports, and shutting down on SIGTERM without leaks."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from rths3d.record import Record

sys.path.insert(0, str(Path(__file__).resolve().parent))
from processes import alive_in_session  # noqa: E402


def view(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "rths3d", "view", *args], capture_output=True,
                          text=True, timeout=timeout)


@pytest.fixture
def busy_port():
    """A port that another server listens on."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        yield s.getsockname()[1]


@pytest.mark.parametrize("target", ["paper_contact", "record"])
def test_busy_port_is_an_error_naming_it(busy_port, target, tmp_path) -> None:
    """A port another server holds: one line naming --port and the port, exit 2, nothing
    served (not quietly the next port)."""
    if target == "record":
        import numpy as np

        t = np.arange(200) * 1e-3
        z = 1e-3 * np.sin(6.0 * t)
        target = str(Record(t, {"z_cmd.z": z, "z_meas.z": z}, {}).save(tmp_path / "r.csv"))
    p = view(target, "--port", str(busy_port), "--seconds", "1")
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert p.stderr.strip().splitlines() == [p.stderr.strip()]
    assert p.stderr.startswith(f"error: --port: {busy_port} (cannot listen on 127.0.0.1")
    assert "rths3d view:" not in p.stdout


@pytest.mark.parametrize("port", ["70000", "-1"])
def test_port_out_of_range_is_one_line(port) -> None:
    p = view("paper_contact", "--port", port, "--seconds", "1")
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert p.stderr.strip() == (f"error: --port: {port} (must be a TCP port in [0, 65535] "
                                "(0: any free port))")


def test_port_zero_picks_a_free_port_and_says_so() -> None:
    """--port 0: the address printed carries the port picked, and the line says it was
    picked."""
    p = view("paper_contact", "--port", "0", "--seconds", "1")
    assert p.returncode == 0, p.stderr
    line = next(ln for ln in p.stdout.splitlines() if ln.startswith("rths3d view:"))
    port = int(line.split("http://127.0.0.1:")[1].split()[0])
    assert port > 0 and "a free port was picked" in line


def test_sigterm_shuts_down_cleanly(tmp_path) -> None:
    """SIGTERM to a live `view --out`: exit 0, the record saved, no leaked shared memory
    reported, and no process of the command left (the view process included)."""
    out = tmp_path / "live.parquet"
    proc = subprocess.Popen([sys.executable, "-m", "rths3d", "view", "paper_contact",
                             "--port", "0", "--out", str(out)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        line = proc.stdout.readline()
        assert line.startswith("rths3d view: http://"), proc.stderr.read()
        time.sleep(1.0)
        assert len([p for p, _ in alive_in_session(proc.pid)]) >= 2  # the command and its view process
        proc.send_signal(signal.SIGTERM)
        stdout, stderr = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 0, stderr
    assert "leaked" not in stderr and "Traceback" not in stderr
    assert f"record saved: {out}" in stdout
    assert Record.load(out).meta["status"] == "stopped"
    deadline = time.time() + 5
    while [p for p, _ in alive_in_session(proc.pid)] and time.time() < deadline:
        time.sleep(0.1)
    assert [p for p, _ in alive_in_session(proc.pid)] == []
