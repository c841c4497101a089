"""The SimApp protocol of OpenSees' ``genericClient``/``adapter`` elements and OpenFresco's
SimApp servers, as rths3d speaks it (docs/network.md).

Framing (OpenSees ``TCP_Socket``): the client connects and sends a header of 11 int32 —
``sizeCtrl[5]`` (disp, vel, accel, force, time), ``sizeDaq[5]`` (the same order) and
``dataSize``; from then on every message, both ways, is exactly ``dataSize`` float64 in the
machine's byte order (little-endian on x86 and ARM), no header nor checksum. A request
carries its action in element 0 and its data from element 1 (a trial response: disp, vel,
accel, force, time, each of its ``sizeCtrl`` length); a reply carries its data from element 0
(matrices column-major). Actions 3 (setTrialResponse), 4 (execute), 5 (commitState) and the
ones that end the connection get no reply.

The protocol has no timeouts nor errors of its own; here a peer that stays silent longer than
the channel's timeout, closes, or sends what cannot be a message raises :class:`PeerError`,
and the side that catches it stops its test safely. Both sides set ``TCP_NODELAY`` and
re-arm ``TCP_QUICKACK`` after every receive: with Nagle's algorithm and delayed ACKs a
loopback step takes tens of milliseconds instead of a fraction of one.
"""

from __future__ import annotations

import math
import socket
import struct
import time
from dataclasses import dataclass

import numpy as np

from ..errors import RthsError

__all__ = ["ACTION_NAMES", "COMMIT", "DIE", "EXECUTE", "GET_ACCEL", "GET_DAMP", "GET_DAQ",
           "GET_DISP", "GET_FORCE", "GET_INITIAL_STIFF", "GET_MASS", "GET_TANGENT_STIFF",
           "GET_TIME", "GET_VEL", "HEADER_BYTES", "OPEN", "SETUP", "SET_TRIAL", "SHUTDOWN",
           "Channel", "Header", "PeerError", "connect", "tune"]

OPEN, SETUP, SET_TRIAL, EXECUTE, COMMIT, GET_DAQ = 1, 2, 3, 4, 5, 6
GET_DISP, GET_VEL, GET_ACCEL, GET_FORCE, GET_TIME = 7, 8, 9, 10, 11
GET_INITIAL_STIFF, GET_TANGENT_STIFF, GET_DAMP, GET_MASS = 12, 13, 14, 15
SHUTDOWN, DIE = 98, 99

ACTION_NAMES: dict[int, str] = {
    OPEN: "open", SETUP: "setup", SET_TRIAL: "setTrialResponse", EXECUTE: "execute",
    COMMIT: "commitState", GET_DAQ: "getDaqResponse", GET_DISP: "getDisp", GET_VEL: "getVel",
    GET_ACCEL: "getAccel", GET_FORCE: "getForce", GET_TIME: "getTime",
    GET_INITIAL_STIFF: "getInitialStiff", GET_TANGENT_STIFF: "getTangentStiff",
    GET_DAMP: "getDamp", GET_MASS: "getMass", SHUTDOWN: "shutdown", DIE: "DIE"}
"""Every action id of the protocol and its name in OpenFresco's sources."""

HEADER = struct.Struct("=11i")
HEADER_BYTES = HEADER.size  # 44
MAX_SIZE = 1 << 16
"""Largest vector length or ``dataSize`` accepted in a header (a bigger one is taken for
garbage, not allocated)."""


class PeerError(RthsError):
    """The peer broke the protocol: ``kind`` is ``closed`` (it closed or reset the
    connection), ``timeout`` (silent for longer than the timeout) or ``malformed`` (a header
    or message that cannot be one)."""

    def __init__(self, kind: str, message: str):
        self.kind = kind
        super().__init__(message)


@dataclass(frozen=True)
class Header:
    """The connection header: ``ctrl`` and ``daq`` sizes (disp, vel, accel, force, time) and
    the message length ``data_size`` (float64 values)."""

    ctrl: tuple[int, int, int, int, int]
    daq: tuple[int, int, int, int, int]
    data_size: int

    def pack(self) -> bytes:
        return HEADER.pack(*self.ctrl, *self.daq, self.data_size)

    @classmethod
    def unpack(cls, raw: bytes) -> Header:
        """The header of 44 bytes; :class:`PeerError` ``malformed`` for negative or huge
        sizes."""
        v = HEADER.unpack(raw)
        if any(x < 0 or x > MAX_SIZE for x in v):
            raise PeerError("malformed", f"malformed header {list(v)}: every size must be in "
                            f"0…{MAX_SIZE}")
        return cls(tuple(v[:5]), tuple(v[5:10]), v[10])  # type: ignore[arg-type]

    @property
    def trial_size(self) -> int:
        """Values of a setTrialResponse message: the action and the ctrl vectors."""
        return 1 + sum(self.ctrl)

    def as_list(self) -> list[int]:
        return [*self.ctrl, *self.daq, self.data_size]


def tune(sock: socket.socket) -> None:
    """No Nagle delay; quick ACKs (re-armed after every receive by :class:`Channel`)."""
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    if hasattr(socket, "TCP_QUICKACK"):
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_QUICKACK, 1)


class Channel:
    """Fixed-size float64 messages over a connected socket, in preallocated buffers.

    ``send_buf``/``recv_buf``: the (data_size,) arrays of the next message out and the last
    one in. ``timeout`` (s): longest silence of the peer before :class:`PeerError`
    ``timeout`` (None: wait for ever). No allocation per message.
    """

    def __init__(self, sock: socket.socket, data_size: int, timeout: float | None):
        self.sock = sock
        self.data_size = int(data_size)
        self.send_buf = np.zeros(self.data_size)
        self.recv_buf = np.zeros(self.data_size)
        self._send = memoryview(self.send_buf).cast("B")
        self._recv = memoryview(self.recv_buf).cast("B")
        self._nbytes = 8 * self.data_size
        self._quick = getattr(socket, "TCP_QUICKACK", None)
        self.timeout = timeout
        sock.settimeout(wait_slice(timeout))

    def set_timeout(self, timeout: float | None) -> None:
        if timeout != self.timeout:
            self.timeout = timeout
            self.sock.settimeout(wait_slice(timeout))

    def recv(self) -> np.ndarray:
        """The next message (``recv_buf``); :class:`PeerError` if the peer closes or stays
        silent longer than the timeout."""
        recv_bytes(self.sock, self._recv, self._nbytes, self.timeout, self._quick)
        return self.recv_buf

    def send(self, data: memoryview | None = None) -> None:
        """Send ``send_buf`` (or ``data``: whole messages, e.g. a preallocated block of
        several)."""
        send_bytes(self.sock, self._send if data is None else data, self.timeout)

    def close(self) -> None:
        close_socket(self.sock)


WAIT_SLICE = 0.1
"""s: the longest a socket wait blocks before it returns to Python (and waits again, up to
its timeout). A signal the kernel delivers to another thread of the process (a library's
worker thread) does not interrupt the main thread's wait; Python acts on it (Ctrl-C: stop
safely, keep the record) when the wait returns — within this slice, not at the timeout.
A message that arrives within the slice costs nothing more."""


def wait_slice(timeout: float | None) -> float:
    """The socket timeout for a wait of at most ``timeout`` s (None: for ever) in slices."""
    return WAIT_SLICE if timeout is None else min(float(timeout), WAIT_SLICE)


def recv_bytes(sock: socket.socket, view: memoryview, nbytes: int, timeout: float | None,
               quick: int | None = None) -> None:
    """Fill ``view[:nbytes]`` from ``sock`` (its timeout: :func:`wait_slice`), waiting at
    most ``timeout`` s (None: for ever) for the peer; :class:`PeerError` ``closed`` or
    ``timeout``."""
    got = 0
    t0 = None
    try:
        while got < nbytes:
            try:
                n = sock.recv_into(view[got:nbytes], nbytes - got)
            except TimeoutError:
                t0 = time.monotonic() - (sock.gettimeout() or 0.0) if t0 is None else t0
                if timeout is None or time.monotonic() - t0 < timeout:
                    continue
                raise
            if n == 0:
                raise PeerError("closed", "the peer closed the connection" + (
                    f" after {got} of {nbytes} bytes of a message" if got else ""))
            got += n
            t0 = None
            if quick is not None:
                sock.setsockopt(socket.IPPROTO_TCP, quick, 1)
    except TimeoutError:
        raise PeerError("timeout", f"the peer was silent for {timeout:g} s" + (
            f" ({got} of {nbytes} bytes of a message received)" if got else "")) from None
    except OSError as exc:
        if isinstance(exc, PeerError):
            raise
        raise PeerError("closed", f"the connection failed ({exc.strerror or exc})") from None


def send_bytes(sock: socket.socket, data: memoryview, timeout: float | None) -> None:
    """Send all of ``data`` on ``sock`` (its timeout: :func:`wait_slice`), waiting at most
    ``timeout`` s (None: for ever) for the peer to take it; :class:`PeerError`."""
    sent, n = 0, len(data)
    t0 = None
    try:
        while sent < n:
            try:
                sent += sock.send(data[sent:] if sent else data)
                t0 = None
            except TimeoutError:
                t0 = time.monotonic() - (sock.gettimeout() or 0.0) if t0 is None else t0
                if timeout is None or time.monotonic() - t0 < timeout:
                    continue
                raise
    except TimeoutError:
        raise PeerError("timeout", f"the peer took no data for {timeout:g} s") from None
    except OSError as exc:
        raise PeerError("closed", f"the peer closed the connection ({exc.strerror or exc})"
                        ) from None


def close_socket(sock: socket.socket | None) -> None:
    """Shut down and close ``sock``, ignoring a peer already gone."""
    if sock is None:
        return
    try:
        sock.shutdown(socket.SHUT_RDWR)
    except OSError:
        pass
    sock.close()


def connect(host: str, port: int, header: Header, timeout: float | None,
            connect_timeout: float = 5.0) -> Channel:
    """Connect to a SimApp server and send ``header``; the channel of its messages.

    A server that refuses (nothing listening, busy) or does not accept within
    ``connect_timeout`` s raises :class:`PeerError` ``closed``/``timeout``."""
    try:
        sock = socket.create_connection((host, int(port)), timeout=connect_timeout)
    except TimeoutError:
        raise PeerError("timeout", f"no SimApp server answered at {host}:{port} within "
                        f"{connect_timeout:g} s") from None
    except OSError as exc:
        raise PeerError("closed", f"no SimApp server at {host}:{port} "
                        f"({exc.strerror or exc})") from None
    try:
        tune(sock)
        sock.sendall(header.pack())
    except OSError as exc:
        close_socket(sock)
        raise PeerError("closed", f"the server at {host}:{port} closed the connection "
                        f"({exc.strerror or exc})") from None
    return Channel(sock, header.data_size, timeout)


def action_of(value: float) -> int:
    """The action id in element 0 of a request, or -1 when it is not one (not an integer,
    not finite)."""
    if not math.isfinite(value) or value != int(value):
        return -1
    return int(value)
