"""The live view in its own process, fed through shared memory.

A view in the loop's process shares the loop's GIL: MuJoCo releases it at every step, so
each wake-up of the view or of the web server's thread hands the GIL over and back, and on a
busy machine each hand-over costs the loop a scheduling delay. Here the viser server, the
drawing and the network run in a child process with its own interpreter. The rows reach it
through shared memory: the loop's own thread copies the rows written since its last copy at
its regular control checks, at most 30 times a second (see
:class:`rths3d.viz.live.PacedControl`), so no thread of the loop's process wakes up to feed
the view. A relay thread, asleep unless the page sends a control or twice a second for the
status line, carries out pause / resume / stop / speed / restart on the run.
"""

from __future__ import annotations

import json
import queue
import subprocess
import sys
import threading
import time
from multiprocessing import shared_memory
from typing import Any

import numpy as np

from ..errors import RthsError
from ..record import RecordBuffer

VIEW_NICE = 10
"""Scheduling niceness added to the view process: on a busy machine the test runs first."""

HEADER = 2
"""Shared block layout: float64 ``[n, generation, data (capacity × columns)]``."""


class SharedStream:
    """A shared-memory copy of a :class:`RecordBuffer` (the writer's side)."""

    def __init__(self, buffer: RecordBuffer):
        self.source = buffer
        self.capacity, self.ncols = buffer.data.shape
        size = 8 * (HEADER + self.capacity * self.ncols)
        self.shm = shared_memory.SharedMemory(create=True, size=size)
        self.header = np.ndarray((HEADER,), dtype=float, buffer=self.shm.buf)
        self.data = np.ndarray((self.capacity, self.ncols), dtype=float,
                               buffer=self.shm.buf, offset=8 * HEADER)
        self.header[:] = 0.0
        self.copied = 0
        self.closed = False

    def spec(self) -> dict[str, Any]:
        """What the reader needs to attach (picklable)."""
        return {"name": self.shm.name, "columns": self.source.columns,
                "capacity": self.capacity, "meta": self.source.meta}

    def publish(self) -> int:
        """Copy the rows written since the last call; returns the number of valid rows."""
        if self.closed:
            return self.copied
        n = self.source.n
        if n > self.copied:
            # Rows ≥ copied may have been rewritten since (the loop fills z^r at the end):
            # copy from one row back so the last visible row is always current.
            start = max(0, self.copied - 1)
            self.data[start:n] = self.source.data[start:n]
            self.copied = n
            self.header[0] = n
        elif n < self.copied:  # the loop trimmed a stopped test's record
            self.copied = n
            self.header[0] = n
        return n

    def publish_all(self) -> None:
        """Copy every row (after the run: z^r and x_ref are filled in at the end)."""
        if self.closed:
            return
        n = self.source.n
        self.data[:n] = self.source.data[:n]
        self.copied = n
        self.header[0] = n

    def close(self) -> None:
        """Stop publishing and remove the block's name. The mapping itself is released when
        the last array over it is garbage-collected: unmapping it here could pull the memory
        from under a loop thread that is still copying (a crash, not an exception)."""
        self.closed = True
        try:
            self.shm.unlink()
        except FileNotFoundError:
            pass


class SharedRecordBuffer(RecordBuffer):
    """A :class:`RecordBuffer` whose rows and length live in shared memory (reader side).

    ``other_process``: the block was created by another process (the usual case); False when
    reader and writer share a process (tests).
    """

    def __init__(self, spec: dict[str, Any], *, other_process: bool = True):
        self.columns = tuple(spec["columns"])
        self.index = {c: i for i, c in enumerate(self.columns)}
        self.meta = dict(spec["meta"])
        self._shm = shared_memory.SharedMemory(name=spec["name"])
        if other_process:  # the writer owns the block: keep our tracker from unlinking it
            try:
                from multiprocessing import resource_tracker

                resource_tracker.unregister(self._shm._name, "shared_memory")
            except Exception:  # not tracked on this platform
                pass
        cap, nc = int(spec["capacity"]), len(self.columns)
        self._header = np.ndarray((HEADER,), dtype=float, buffer=self._shm.buf)
        self.data = np.ndarray((cap, nc), dtype=float, buffer=self._shm.buf, offset=8 * HEADER)

    @property
    def n(self) -> int:  # type: ignore[override]
        """Rows published so far."""
        return int(self._header[0])

    @n.setter
    def n(self, value: int) -> None:
        self._header[0] = value

    def close(self) -> None:
        """Detach from the shared block."""
        self.data = np.zeros((0, len(self.columns)))
        self._header = np.zeros(HEADER)
        try:
            self._shm.close()
        except BufferError:  # a view is still alive somewhere; the OS frees it at exit
            pass


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, tuple):
        return list(obj)
    return str(obj)


def _encode(*msg: Any) -> str:
    return json.dumps(list(msg), default=_jsonable) + "\n"


def child_main() -> None:
    """Child process (``python -m rths3d.viz.process``): the viser view on the shared stream.

    Reads JSON lines on stdin (``start``, ``status``, ``buffer``, ``error``, ``quit``) and
    writes JSON lines (``port``, ``pause``, ``resume``, ``stop``, ``speed``, ``restart``) on
    the original stdout; anything else printed goes to stderr.
    """
    import os
    import queue
    import sys

    proto = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)  # viser's banner and prints must not mix with the protocol
    try:  # the view yields the CPU to the test when cores are scarce
        os.nice(VIEW_NICE)
    except (AttributeError, OSError):
        pass
    from .app import RunControl, Viewer

    lock = threading.Lock()

    def send(*msg: Any) -> None:
        with lock:
            proto.write(_encode(*msg))
            proto.flush()

    first = json.loads(sys.stdin.readline())
    _, spec, options, ctl = first
    status = {"text": "starting"}
    replies: queue.Queue = queue.Queue()
    pending = threading.Event()

    def restart(transfer: str, params: dict[str, float]) -> RecordBuffer:
        pending.set()
        send("restart", transfer, params)
        reply = replies.get()
        pending.clear()
        if reply[0] == "error":
            raise RuntimeError(reply[1])
        return SharedRecordBuffer(reply[1])

    control = RunControl(
        transfers=tuple(ctl["transfers"]), transfer=ctl["transfer"],
        params={k: tuple(v) for k, v in ctl["params"].items()},
        restart=restart, pause=lambda: send("pause"), resume=lambda: send("resume"),
        stop=lambda: send("stop"), set_speed=lambda s: send("speed", s),
        status=lambda: status["text"], paused=not ctl.get("autostart", True))
    try:
        view = Viewer(SharedRecordBuffer(spec), live=True, control=control, **options)
        if ctl.get("autostart", True):
            view.on_first_client = lambda: send("resume")
        view.start()
    except RthsError as exc:  # a bad option or a busy port: the parent reports it
        send("error", str(exc))
        return
    send("port", view.port)
    try:
        for line in sys.stdin:
            msg = json.loads(line)
            if msg[0] == "quit":
                break
            if msg[0] == "status":
                status["text"] = msg[1]
            elif msg[0] in ("buffer", "error") and pending.is_set():
                replies.put(msg)  # the answer to the page's restart
            elif msg[0] == "buffer":  # a run started from the other side
                view.set_buffer(SharedRecordBuffer(msg[1]))
    except KeyboardInterrupt:
        pass
    finally:
        view.stop()


class ViewProcess:
    """A live view of a :class:`~rths3d.viz.live.LiveRun` served from a child process.

    ``start()`` starts the run and the child and returns once the child's server listens
    (``url``, ``port``). A run that starts paused resumes when the first page connects
    (``autostart``) or, with ``autostart=False``, when the page's *Resume* or *Run /
    restart* (with the transfer system and parameters chosen there) is pressed. Every run
    the LiveRun starts afterwards (a restart from the page, or
    ``run.start()`` from here) is shown automatically.
    """

    def __init__(self, run: Any, *, host: str = "127.0.0.1", port: int = 8080,
                 rate: float = 30.0, autostart: bool = True, **options: Any):
        self.run = run
        self.autostart = autostart
        self.options = dict(options, host=host, port=port, rate=rate)
        self.host = host
        self.port = 0
        self._stream: SharedStream | None = None
        self._old: list[SharedStream] = []
        self._proc: Any = None
        self._inbox: queue.Queue = queue.Queue()
        self._ready = threading.Event()
        self._send_lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()

    @property
    def url(self) -> str:
        """Address of the page."""
        return f"http://{self.host}:{self.port}"

    def _new_stream(self, buffer: RecordBuffer) -> SharedStream:
        """Stream factory, called in the loop's thread when a run begins."""
        stream = SharedStream(buffer)
        stream.publish()
        if self._stream is not None:
            self._old.append(self._stream)
        self._stream = stream
        if self._proc is not None:
            self._send("buffer", stream.spec())
        self._ready.set()
        return stream

    def start(self, timeout: float = 60.0) -> ViewProcess:
        """Start the run, the child process and the relay."""
        from ..scene import transfer_kinds

        self.run.stream_factory = self._new_stream
        self.run.start()
        if not self._ready.wait(timeout):
            raise TimeoutError(f"the run did not reach its first control check in {timeout} s")
        ctl = {"transfers": transfer_kinds(), "transfer": self.run.scene.transfer.kind,
               "params": self.run.key_params(), "autostart": self.autostart}
        proc = subprocess.Popen([sys.executable, "-m", "rths3d.viz.process"],
                                stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                                bufsize=1)
        self._proc = proc
        self._send("start", self._stream.spec(), self.options, ctl)
        reader = threading.Thread(target=self._read_loop, name="rths3d-view-reader",
                                  daemon=True)
        reader.start()
        try:
            msg = self._inbox.get(timeout=timeout)
        except queue.Empty:
            self.stop()
            raise TimeoutError(f"the view process did not start within {timeout} s") from None
        if msg[0] == "error":  # the view refused an option (a busy port, say)
            self.stop()
            raise RthsError(str(msg[1]))
        if msg[0] != "port":
            self.stop()
            raise RuntimeError(f"the view process failed to start: {msg}")
        self.port = int(msg[1])
        self._thread = threading.Thread(target=self._relay, name="rths3d-view-relay",
                                        daemon=True)
        self._thread.start()
        return self

    def _read_loop(self) -> None:
        for line in self._proc.stdout:
            try:
                self._inbox.put(tuple(json.loads(line)))
            except json.JSONDecodeError:
                continue
        self._inbox.put(("exited",))

    def _relay(self) -> None:
        finished_stream: SharedStream | None = None
        last_status = 0.0
        while not self._stop.is_set():
            try:
                msg = self._inbox.get(timeout=0.5)
            except queue.Empty:
                msg = None
            if msg is not None:
                if msg[0] == "exited":
                    return
                self._handle(msg)
            stream = self._stream
            if (self.run.result is not None and not self.run.running
                    and stream is not None and stream is not finished_stream):
                stream.publish_all()  # z^r is filled in when the run ends
                finished_stream = stream
            now = time.monotonic()
            if now - last_status >= 0.5:
                last_status = now
                self._send("status", self.run.status())

    def _handle(self, msg: tuple) -> None:
        kind = msg[0]
        if kind == "pause":
            self.run.pause()
        elif kind == "resume":
            self.run.resume()
        elif kind == "stop":
            self.run.stop()
        elif kind == "speed":
            self.run.set_speed(float(msg[1]))
        elif kind == "restart":
            try:
                self.run.restart(msg[1], msg[2])  # the new stream is sent by _new_stream
            except Exception as exc:  # a bad value from the page: report it there
                self._send("error", str(exc))

    def _send(self, *msg: Any) -> None:
        with self._send_lock:
            try:
                self._proc.stdin.write(_encode(*msg))
                self._proc.stdin.flush()
            except (BrokenPipeError, OSError, ValueError, AttributeError):
                pass

    def wait(self) -> None:
        """Block until interrupted (Ctrl-C) or the view process ends."""
        try:
            while self._proc is not None and self._proc.poll() is None:
                time.sleep(0.2)
        except KeyboardInterrupt:
            pass

    def stop(self) -> None:
        """End the relay and the view process and free the shared memory."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        if self._proc is not None:
            self._send("quit")
            try:
                self._proc.stdin.close()
                self._proc.wait(timeout=10.0)
            except (subprocess.TimeoutExpired, OSError):
                self._proc.terminate()
                self._proc.wait(timeout=5.0)
        self.run.stream_factory = None
        for s in [*self._old, *([self._stream] if self._stream else [])]:
            s.close()
        self._old.clear()
        self._stream = None


if __name__ == "__main__":
    child_main()
