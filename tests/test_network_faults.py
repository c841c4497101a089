"""Faults of a served test, each a safe stop with its partial record or one error line with
exit code 2, and nothing left running or listening: the OpenSees client killed with
`kill -9` mid-test, a client that stops answering, a malformed message, Ctrl-C on the
server, a malformed header, a wrong `dataSize`, a port in use, and a second client while
the first is served."""

from __future__ import annotations

import os
import signal
import socket
import sys
import time
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from netproc import Proc, has_openseespy, opensees, port_listeners, serve  # noqa: E402
from test_network_serve import write_scene  # noqa: E402

from rths3d.network.simapp import Header  # noqa: E402
from rths3d.record import Record  # noqa: E402

GENERIC = Header((2, 2, 2, 0, 1), (0, 0, 0, 2, 0), 256)


class RawClient:
    """A SimApp client written here from the protocol: header, then per step a trial
    (action 3), getForce (10) and commit (5)."""

    def __init__(self, port: int, header: Header | bytes = GENERIC):
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=10)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.sock.sendall(header.pack() if isinstance(header, Header) else header)
        self.ds = header.data_size if isinstance(header, Header) else 256
        self.buf = np.zeros(self.ds)

    def send(self, action: float, *values: float) -> None:
        self.buf[:] = 0.0
        self.buf[0] = action
        self.buf[1:1 + len(values)] = values
        self.sock.sendall(self.buf.tobytes())

    def recv(self) -> np.ndarray:
        data = b""
        while len(data) < 8 * self.ds:
            chunk = self.sock.recv(8 * self.ds - len(data))
            if not chunk:
                raise ConnectionError("closed")
            data += chunk
        return np.frombuffer(data)

    def steps(self, n: int, amp: float = 1e-3) -> None:
        for i in range(n):
            u = amp * np.sin(2 * np.pi * 2.0 * (i + 1) * 1e-3)
            self.send(3, 0.0, u, 0.0, 0.0, 0.0, 0.0, (i + 1) * 1e-3)
            self.send(10)
            self.recv()
            self.send(5)

    def closed_by_peer(self, within: float) -> bool:
        """Whether the server closes the connection within ``within`` s."""
        self.sock.settimeout(within)
        try:
            return self.sock.recv(1) == b""
        except (TimeoutError, ConnectionError):
            return False

    def close(self) -> None:
        self.sock.close()


def _stopped(server: Proc, rec: Path, words: str) -> dict:
    code, err = server.finish(60)
    assert code == 0, err
    summary = server.json
    assert summary["status"] == "stopped" and words in summary["reason"], summary
    r = Record.load(rec)
    assert r.meta["status"] == "stopped" and words in r.meta["reason"]
    assert r.n == summary["steps"] + 1
    assert server.left() == []
    return summary


@pytest.mark.skipif(not has_openseespy(), reason="needs openseespy")
def test_opensees_client_killed_mid_test(tmp_path) -> None:
    """`kill -9` of the OpenSees client 2 s into a 300 s test (an idle machine steps its
    ~0.1 ms loopback steps far from the end): the server stops the test ("closed the
    connection"), keeps the executed steps in its record, exits 0; nothing of either session
    lives on, nothing listens."""
    scene = write_scene(tmp_path, duration=300.0)
    rec = tmp_path / "partial.parquet"
    server, port = serve(scene, "--out", str(rec), "--json")
    client = None
    try:
        client = opensees("sdof_client.py", port, tmp_path / "u.npy", 299000)
        time.sleep(2.0)
        assert client.p.poll() is None, client.finish(1)
        os.killpg(client.p.pid, signal.SIGKILL)
        client.finish(10)
        summary = _stopped(server, rec, "closed the connection")
    finally:
        server.kill()
        if client is not None:
            client.kill()
    assert 0 < summary["steps"] < 299000
    assert client.left() == []
    assert port_listeners(port) == []


def test_silent_client_malformed_message_busy_server(tmp_path) -> None:
    """A client that stops answering after 50 steps: the test stops after the timeout
    (0.3 s) with 50 steps recorded; while it is served a second client is refused. Then a
    client whose message carries action 7.5: a safe stop naming it."""
    scene = write_scene(tmp_path, timeout=0.3)
    rec = tmp_path / "silent.parquet"
    server, port = serve(scene, "--out", str(rec), "--json")
    c = None
    try:
        c = RawClient(port)
        c.steps(50)
        with pytest.raises(ConnectionRefusedError):
            socket.create_connection(("127.0.0.1", port), timeout=5).close()
        t0 = time.time()
        assert c.closed_by_peer(10.0)
        assert time.time() - t0 < 5.0
        summary = _stopped(server, rec, "stopped answering")
        assert summary["steps"] == 50
    finally:
        server.kill()
        if c is not None:
            c.close()
    assert port_listeners(port) == []

    rec2 = tmp_path / "malformed.parquet"
    server, port = serve(scene, "--out", str(rec2), "--json")
    try:
        c = RawClient(port)
        c.steps(20)
        c.send(7.5)
        assert c.closed_by_peer(10.0)
        summary = _stopped(server, rec2, "action 7.5")
        assert summary["steps"] == 20
    finally:
        server.kill()
        c.close()


def test_ctrl_c_on_the_server_keeps_the_record(tmp_path) -> None:
    """SIGINT to `rths3d serve` mid-test: stopped by the user, record kept, exit 0, the
    client sees the connection closed."""
    scene = write_scene(tmp_path, timeout=5.0)
    rec = tmp_path / "user.parquet"
    server, port = serve(scene, "--out", str(rec), "--json")
    c = None
    try:
        c = RawClient(port)
        c.steps(30)
        os.kill(server.p.pid, signal.SIGINT)
        assert c.closed_by_peer(10.0)
        summary = _stopped(server, rec, "stopped by the user")
        assert summary["steps"] == 30
    finally:
        server.kill()
        if c is not None:
            c.close()


@pytest.mark.parametrize("header, words", [
    (b"\xff" * 44, "malformed header"),
    (Header((2, 2, 2, 0, 1), (0, 0, 0, 2, 0), 4).pack(), "dataSize = 4"),
    (Header((1, 0, 0, 0, 0), (0, 0, 0, 1, 0), 256).pack(), "sizeCtrl disp = 1"),
])
def test_bad_header_is_one_line_exit_2(tmp_path, header, words) -> None:
    """A header that cannot be one, a dataSize too short for the messages, or sizes that do
    not fit the scene's element: one error line naming it, exit code 2, no record."""
    scene = write_scene(tmp_path)
    rec = tmp_path / "none.parquet"
    server, port = serve(scene, "--out", str(rec))
    c = None
    try:
        c = RawClient(port, header)
        assert c.closed_by_peer(10.0)
        code, err = server.finish(60)
    finally:
        server.kill()
        if c is not None:
            c.close()
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith("error:"), err
    assert words in lines[0] and "Traceback" not in err
    assert not rec.exists()
    assert server.left() == [] and port_listeners(port) == []


def test_port_in_use_is_one_line_exit_2(tmp_path) -> None:
    """`rths3d serve --port P` with P taken: one line naming --port and the port, exit 2."""
    scene = write_scene(tmp_path)
    taken = socket.socket()
    taken.bind(("127.0.0.1", 0))
    taken.listen(1)
    port = taken.getsockname()[1]
    try:
        p = Proc([sys.executable, "-m", "rths3d", "serve", str(scene), "--port", str(port)])
        code, err = p.finish(60)
    finally:
        taken.close()
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1, err
    assert "--port" in lines[0] and str(port) in lines[0] and "in use" in lines[0]
    assert p.left() == []


def test_ctrl_c_delivered_to_another_thread_stops_within_a_slice(tmp_path) -> None:
    """The kernel may deliver a process's SIGINT to any of its threads (a library's worker);
    the main thread's wait for the client then is not interrupted. The server waits in
    slices of ``WAIT_SLICE`` (0.1 s), so it sees the signal and stops by the user within a
    slice or two, not at the 5 s timeout: SIGINT sent here to an idle thread of this
    process while an in-process server waits for its client's next step."""
    import threading

    from rths3d.network.server import LabServer
    from rths3d.network.simapp import WAIT_SLICE
    from rths3d.scene import load_scene

    server = LabServer(load_scene(write_scene(tmp_path, timeout=5.0)), port=0)
    idle = threading.Event()
    worker = threading.Thread(target=idle.wait, daemon=True)
    worker.start()
    sent: list[float] = []

    def client() -> None:
        c = RawClient(server.port)
        c.steps(30)
        time.sleep(0.3)  # the server is waiting for step 31
        sent.append(time.monotonic())
        signal.pthread_kill(worker.ident, signal.SIGINT)
        c.closed_by_peer(10.0)
        c.close()

    # Ctrl-C's default action, as in a terminal (a pytest-xdist worker ignores SIGINT)
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    t = threading.Thread(target=client, daemon=True)
    t.start()
    try:
        res = server.serve(accept_timeout=10.0)
    finally:
        signal.signal(signal.SIGINT, before)
    took = time.monotonic() - sent[0]
    t.join(10.0)
    idle.set()
    assert res.status == "stopped" and "stopped by the user" in res.reason, res.reason
    assert res.steps == 30
    assert took < 4 * WAIT_SLICE, took
