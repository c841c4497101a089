"""rths3d as a laboratory: a scene's experimental setup served to a SimApp client.

:class:`Lab` is the scene's transfer system (ideal, delay, LTI, the Stewart platform, …)
carrying its part, for one test, driven by the trial displacements of a remote element
(an OpenSees ``genericClient``, an OpenFresco SimApp client, rths3d's own ``remote``
transfer system): z = T u in, F = Tᵀ F'_m out (T: the scene's ``[network] element_map``),
every executed step checked by the scene's safety limits and written in the usual record
format (``z_cmd``, ``z_meas``, ``f_meas``, the element's trial displacements as ``x_num.*``,
the transfer system's own signals, ``t_remote``: the client's time of the step).

One executed step is one interface step ΔT of the bench: a trial whose displacement differs
from the last one executed is executed at once; a commit after which nothing was executed
executes (holds) the last trial, so that a client using a one-trial-per-step algorithm
(OpenSees' ``Linear``: a repeated trial at the start of each step, the new one at its end)
gets exactly one bench step per analysis step. An iterating algorithm executes every distinct
trial, as a physical bench would.

:class:`LabServer` listens (127.0.0.1 unless told otherwise), accepts one client, closes its
listening socket (a second client is refused), checks the header against the lab, answers
the actions of :mod:`.simapp` and stops the test safely — the bench holds its last position,
the record keeps every executed step with the reason — when the client closes, stays silent
longer than the timeout, sends an action it cannot be, the bench leaves a safety limit or
the user presses Ctrl-C.
"""

from __future__ import annotations

import math
import socket
import threading
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..config import Scene
from ..errors import ConfigError
from ..metadata import record_meta
from ..numerical import LinearSubstructure
from ..record import Record
from ..safety import USER, SafetyMonitor
from ..stepping import post_step
from ..transfer import build_transfer
from . import simapp
from .simapp import Header, PeerError

__all__ = ["Lab", "LabServer", "ServeResult", "element_map"]

LOOPBACK = ("127.0.0.1", "localhost", "::1")


def element_map(scene: Scene) -> np.ndarray:
    """T (n_if, n_el) of the scene's ``[network] element_map`` (default [−I, I])."""
    n = len(scene.dofs)
    m = scene.network.element_map
    if m:
        return np.array(m, dtype=float)
    return np.hstack([-np.eye(n), np.eye(n)])


class Lab:
    """The served experimental setup of ``scene`` (see the module docstring)."""

    def __init__(self, scene: Scene, *, nthread: int = 0):
        self.scene = scene
        self.T = element_map(scene)
        self.n_if, self.n_el = self.T.shape
        self.T_pinv = np.linalg.pinv(self.T)
        self.transfer = build_transfer(scene, 1, nthread=nthread)
        self.transfer.reset()
        self.monitor = SafetyMonitor([scene])
        self.monitor.reset()
        self.N, self.dt = scene.n_steps, scene.dt
        dofs = scene.dofs
        cols = ["t"] + [f"{s}.{d}" for s in ("z_cmd", "z_meas", "f_meas") for d in dofs]
        cols += [f"x_num.{i}" for i in range(self.n_el)]
        for sig in self.transfer.signals:
            cols += sig.columns
        cols += ["t_remote"]
        self.cols = cols
        ci = {c: i for i, c in enumerate(cols)}
        self.c_tr = ci["t_remote"]
        self.data = np.zeros((self.N + 1, 1, len(cols)))
        self.data[:, 0, 0] = np.arange(self.N + 1) * self.dt
        self.hist = []
        for sig in self.transfer.signals:
            h = np.zeros((self.N + 1,) + sig.source.shape)
            if sig.initial is not None:
                h[:] = sig.initial
            self.hist.append(h)
        self._sigs = list(zip(self.transfer.signals, self.hist, strict=True))
        m = self.monitor
        self._mon = (m.lim_z, m.lim_v, m.lim_x, m.lim_f, m.g_win, m.g_fac, m.g_n, m.g_floor,
                     m.g_pk, m.g_prev, m.g_base, m.g_cnt, m.active, m.code, m.dof, m.value,
                     m.row)
        self._rec = (self.data, ci[f"z_cmd.{dofs[0]}"], ci[f"z_meas.{dofs[0]}"],
                     ci[f"f_meas.{dofs[0]}"], ci["x_num.0"])
        # the trial (element DOFs) and the bench's last step, preallocated
        self.u = np.zeros((1, self.n_el))
        self.v = np.zeros((1, self.n_el))
        self.a = np.zeros((1, self.n_el))
        self.t_remote = 0.0
        self.u_exec = np.zeros(self.n_el)
        self.u_meas = np.zeros(self.n_el)
        self.f_el = np.zeros(self.n_el)
        self.z = np.zeros((1, self.n_if))
        self.zdot = np.zeros((1, self.n_if))
        self._dz = np.zeros(self.n_if)
        k_exp = np.atleast_2d(np.asarray(self.transfer_part_stiffness(), dtype=float))
        self.k_el = self.T.T @ k_exp @ self.T
        self.n = 0
        self.trials = 0
        self.commits = 0
        self._executed = False
        self.external = ""

    def transfer_part_stiffness(self) -> Any:
        """k_EXP of the scene's part (N/m, N·m/rad): the element's tangent stiffness."""
        from ..experiment import make_part

        return make_part(self.scene.experiment).interface_matrices()[0]

    @property
    def active(self) -> bool:
        return bool(self.monitor.active[0])

    @property
    def time(self) -> float:
        """Bench time (s): executed steps × ΔT."""
        return self.n * self.dt

    # ------------------------------------------------------------------ stepping
    def trial(self, msg: np.ndarray, header: Header) -> None:
        """Take a setTrialResponse message (action, disp, vel, accel, force, time) and
        execute it when its displacement is new."""
        nd, nv, na, nf, nt = header.ctrl
        o = 1
        self.u[0, :] = msg[o:o + nd]
        o += nd
        if nv:
            self.v[0, :] = msg[o:o + nv]
        o += nv
        if na:
            self.a[0, :] = msg[o:o + na]
        o += na + nf
        if nt:
            self.t_remote = float(msg[o])
        self.trials += 1
        if not np.array_equal(self.u[0], self.u_exec):
            self.execute()

    def commit(self) -> None:
        """The client committed its step: hold the last trial if nothing was executed."""
        self.commits += 1
        if not self._executed:
            self.execute()
        self._executed = False

    def execute(self) -> bool:
        """One bench step ΔT to the trial displacement; False once the test is stopped."""
        if not self.monitor.active[0]:
            return False
        n = self.n
        if n >= self.N:
            self.stop(f"the record is full: the scene's duration {self.scene.duration:g} s "
                      f"({self.N} steps) is over", n)
            return False
        np.dot(self.T, self.u[0], out=self.z[0])
        np.dot(self.T, self.v[0], out=self.zdot[0])
        if self.monitor.command(n, self.z, self.zdot, self.u):
            return False
        tr = self.transfer
        tr.step(self.z, self.zdot)
        if tr.stopped[0]:
            self.monitor.stop(0, tr.reasons[0], n)
            return False
        for sig, h in self._sigs:
            h[n + 1] = sig.source
        self.data[n + 1, 0, self.c_tr] = self.t_remote
        if post_step(self._rec, n, self.z, tr.z_meas, tr.f_meas, self.u, self._mon):
            return False
        self.n = n + 1
        self._executed = True
        self.u_exec[:] = self.u[0]
        np.dot(self.T.T, tr.f_meas[0], out=self.f_el)
        np.subtract(tr.z_meas[0], self.z[0], out=self._dz)
        np.dot(self.T_pinv, self._dz, out=self.u_meas)
        self.u_meas += self.u_exec
        return True

    def stop(self, reason: str, row: int | None = None, code: int | None = None) -> None:
        """Stop the test from outside (the peer, the user): the bench holds its position,
        the record keeps the executed steps."""
        if self.monitor.active[0]:
            self.external = reason
            if code is None:
                self.monitor.stop(0, reason, self.n if row is None else row)
            else:
                self.monitor.stop(0, reason, self.n if row is None else row, code)

    # ------------------------------------------------------------------ replies
    def reply(self, action: int, out: np.ndarray, header: Header) -> None:
        """Write the reply to a getter ``action`` into ``out`` (from element 0)."""
        out[:] = 0.0
        ne = self.n_el
        if action == simapp.GET_FORCE:
            out[:ne] = self.f_el
        elif action == simapp.GET_DISP:
            out[:ne] = self.u_meas
        elif action == simapp.GET_VEL:
            out[:ne] = self.v[0]
        elif action == simapp.GET_ACCEL:
            out[:ne] = self.a[0]
        elif action == simapp.GET_TIME:
            out[0] = self.time
        elif action in (simapp.GET_INITIAL_STIFF, simapp.GET_TANGENT_STIFF):
            out[:ne * ne] = self.k_el.ravel(order="F")
        elif action == simapp.GET_DAQ:
            o = 0
            for size, src in zip(header.daq, (self.u_meas, self.v[0], self.a[0], self.f_el,
                                              None), strict=True):
                if size:
                    if src is None:
                        out[o] = self.time
                    else:
                        out[o:o + size] = src
                o += size
        # getDamp, getMass: zeros (the part's inertia and damping are in the measured force)

    # ------------------------------------------------------------------ record
    def record(self, extra_meta: dict[str, Any] | None = None) -> Record:
        """The record of the executed steps (a stopped test: up to its last safe row)."""
        mon = self.monitor
        rows = self.n + 1 if mon.active[0] else min(self.n, int(mon.row[0])) + 1
        for sig, h in self._sigs:
            c = self.cols.index(sig.columns[0])
            block = h[:rows] if sig.convert is None else sig.convert(h[:rows])
            self.data[:rows, :, c:c + len(sig.labels)] = block
        meta = record_meta(self.scene, LinearSubstructure.from_scenes([self.scene]), 0,
                           self.transfer.metas[0])
        meta["loop"] = "served"
        meta["numerical_remote"] = True
        if not mon.active[0]:
            meta["status"] = "stopped"
            meta["reason"] = mon.reason(0)
        elif self.n < self.N:
            meta["status"] = "ok"
        meta.update(extra_meta or {})
        d = self.data[:rows, 0, :].copy()
        return Record(d[:, 0], {c: d[:, i] for i, c in enumerate(self.cols) if i}, meta)


@dataclass
class ServeResult:
    """A served test: its record, status, reason, the client's header, the bench steps and
    the wall time (s) from the first message to the last."""

    record: Record
    status: str
    reason: str
    header: list[int]
    steps: int
    wall: float
    messages: int
    out: str | None = None
    meta: dict[str, Any] = field(default_factory=dict)


class LabServer:
    """Listen for one SimApp client and serve ``scene``'s lab to it (module docstring).

    Binding happens here: a port in use or a host that is not this machine's raises
    :class:`~rths3d.errors.ConfigError` naming the option. ``port`` 0: any free port
    (:attr:`port` says which).
    """

    def __init__(self, scene: Scene, *, host: str | None = None, port: int | None = None,
                 timeout: float | None = None, first_timeout: float | None = None,
                 nthread: int = 0):
        net = scene.network
        self.scene = scene
        self.host = net.host if host is None else host
        self.timeout = net.timeout if timeout is None else float(timeout)
        self.first_timeout = net.first_timeout if first_timeout is None else \
            float(first_timeout)
        if not self.timeout > 0:
            raise ConfigError("--timeout", self.timeout, "must be > 0 s")
        want = net.port if port is None else int(port)
        if not 0 <= want <= 65535:
            raise ConfigError("--port", want, "must be in 0…65535 (0: any free port)")
        self.lab = Lab(scene, nthread=nthread)
        fam = socket.AF_INET6 if ":" in self.host else socket.AF_INET
        sock = socket.socket(fam, socket.SOCK_STREAM)
        try:
            sock.bind((self.host, want))
            sock.listen(1)
        except OSError as exc:
            sock.close()
            what = "is in use" if exc.errno == 98 else f"cannot be bound ({exc.strerror})"
            raise ConfigError("--port", want, f"{self.host}:{want} {what}") from None
        self.listener: socket.socket | None = sock
        self.port = sock.getsockname()[1]
        self._stop = threading.Event()

    @property
    def public(self) -> bool:
        """Whether the server listens beyond this machine (a warning is due)."""
        return self.host not in LOOPBACK

    def stop(self) -> None:
        """Ask a running :meth:`serve` to stop (from another thread)."""
        self._stop.set()

    def close(self) -> None:
        """Close the listening socket (idempotent)."""
        if self.listener is not None:
            self.listener.close()
            self.listener = None

    def _accept(self, accept_timeout: float | None) -> socket.socket:
        assert self.listener is not None
        self.listener.settimeout(0.1)
        t0 = time.monotonic()
        while True:
            if self._stop.is_set():
                raise KeyboardInterrupt
            try:
                conn, _ = self.listener.accept()
                return conn
            except TimeoutError:
                if accept_timeout is not None and time.monotonic() - t0 > accept_timeout:
                    raise PeerError("timeout", f"no client connected within "
                                    f"{accept_timeout:g} s") from None

    def _header(self, conn: socket.socket) -> Header:
        raw = bytearray(simapp.HEADER_BYTES)
        conn.settimeout(simapp.wait_slice(self.first_timeout))
        simapp.recv_bytes(conn, memoryview(raw), len(raw), self.first_timeout)
        h = Header.unpack(bytes(raw))
        ne = self.lab.n_el
        nd, nv, na, _nf, nt = h.ctrl
        bad = ""
        if nd != ne:
            bad = (f"sizeCtrl disp = {nd}: must equal the {ne} element DOFs of the scene's "
                   "network.element_map")
        elif nv not in (0, ne) or na not in (0, ne) or nt not in (0, 1):
            bad = f"sizeCtrl = {list(h.ctrl)}: vel and accel must be 0 or {ne}, time 0 or 1"
        elif any(s not in (0, ne) for s in h.daq[:4]) or h.daq[4] not in (0, 1):
            bad = f"sizeDaq = {list(h.daq)}: each must be 0 or {ne} (time 0 or 1)"
        else:
            need = max(h.trial_size, sum(h.daq), ne * ne, 1)
            if h.data_size < need:
                bad = (f"dataSize = {h.data_size}: must be >= {need} (1 + sizeCtrl, sizeDaq "
                       f"and the {ne}×{ne} matrices)")
        if bad:
            raise PeerError("malformed", f"header {h.as_list()}: {bad}")
        return h

    def serve(self, accept_timeout: float | None = None) -> ServeResult:
        """Accept one client and serve it to the end of its test; the result with its record.

        A bad header (sizes that do not fit the lab, a short ``dataSize``) raises
        :class:`~rths3d.network.simapp.PeerError` after closing the connection: no test
        ran. Everything after the header ends in a record (``status`` ``stopped`` with the
        reason for a fault or Ctrl-C)."""
        lab = self.lab
        conn: socket.socket | None = None
        chan: simapp.Channel | None = None
        header: Header | None = None
        msgs = 0
        t_first = t_last = 0.0
        try:
            conn = self._accept(accept_timeout)
            self.close()  # one client per test: the next one is refused
            simapp.tune(conn)
            header = self._header(conn)
            chan = simapp.Channel(conn, header.data_size, self.first_timeout)
            recv, send, out = chan.recv, chan.send, chan.send_buf
            reply, trial = lab.reply, lab.trial
            replies = _REPLIES
            while True:
                msg = recv()
                if msgs == 0:
                    t_first = time.perf_counter()
                    chan.set_timeout(self.timeout)
                msgs += 1
                a = simapp.action_of(msg[0])
                if a == simapp.SET_TRIAL:
                    trial(msg, header)
                elif a in replies:
                    reply(a, out, header)
                    send()
                elif a == simapp.COMMIT:
                    lab.commit()
                elif a == simapp.EXECUTE:
                    lab.execute()
                elif a in (simapp.DIE, simapp.SHUTDOWN):
                    break
                elif a in (simapp.OPEN, simapp.SETUP):
                    pass
                else:
                    raise PeerError("malformed", f"action {float(msg[0])!r} is not one of "
                                    "the protocol's")
                if not lab.active:
                    break
                if self._stop.is_set():
                    raise KeyboardInterrupt
            t_last = time.perf_counter()
        except PeerError as exc:
            t_last = time.perf_counter()
            if header is None:
                raise
            lab.stop(f"stopped at t = {lab.time:.3f} s: the client {_what(exc)}")
        except KeyboardInterrupt:
            t_last = time.perf_counter()
            lab.stop(f"stopped by the user at t = {lab.time:.3f} s", code=USER)
        finally:
            if chan is not None:
                chan.close()
            elif conn is not None:
                simapp.close_socket(conn)
            self.close()
        net = {"host": self.host, "port": self.port, "timeout": self.timeout,
               "header": header.as_list() if header else [], "messages": msgs,
               "trials": lab.trials, "commits": lab.commits,
               "element_map": lab.T.tolist()}
        wall = max(t_last - t_first, 0.0)
        rec = lab.record({"network": net, "rtf": lab.time / wall if wall > 0 else math.inf})
        return ServeResult(rec, rec.meta["status"], rec.meta["reason"], net["header"], lab.n,
                           wall, msgs, meta=net)


_REPLIES = frozenset({simapp.GET_DAQ, simapp.GET_DISP, simapp.GET_VEL, simapp.GET_ACCEL,
                      simapp.GET_FORCE, simapp.GET_TIME, simapp.GET_INITIAL_STIFF,
                      simapp.GET_TANGENT_STIFF, simapp.GET_DAMP, simapp.GET_MASS})


def _what(exc: PeerError) -> str:
    """The client's fault in a stop sentence."""
    return {"closed": "closed the connection", "timeout": "stopped answering",
            "malformed": "sent a malformed message"}.get(exc.kind, "failed") + f" ({exc})"
