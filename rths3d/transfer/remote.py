"""The remote transfer system: the bench is another process or machine speaking SimApp.

rths3d keeps the numerical substructure and sends each step's command z (and its rate ż)
to a remote site — ``rths3d serve`` on another scene, an OpenFresco SimApp site server, or
an OpenSees ``adapter`` element (``[network] site``) — which moves its part and answers
with the achieved z' and the measured F'_m (docs/network.md). One connection per test,
opened when the loop starts (a site that is not there: one error line), closed with DIE
when the loop ends in any way. A site that closes, stays silent longer than ``[network]
timeout`` or answers what cannot be an answer stops the test safely: the last measured
values are held, the reason goes to the record.

Per step, in the ``lab`` dialect: setTrialResponse ``[3, z, ż]``, commitState ``[5]``
(the site executes the step exactly once), getDaqResponse ``[6]`` → ``[z', F'_m]``; in the
``adapter`` dialect: ``[3, z, ż]``, getForce ``[10]`` → ``[z', F'_m]``. Header:
sizeCtrl = (n, n, 0, 0, 0), sizeDaq = (n, 0, 0, n, 0), dataSize = max(2n + 1, n²) (24
bytes a message for one DOF); a step's requests go out in one write.
Steps from Python (no compiled kernel); the bench's physics is the site's.
"""

from __future__ import annotations

import math
import time
import weakref
from collections.abc import Hashable, Mapping, Sequence
from typing import Any, ClassVar

import numpy as np

from ..config import Scene
from ..errors import ConfigError
from .base import RecordSignal, register_transfer

__all__ = ["RemoteTransfer"]


@register_transfer
class RemoteTransfer:
    """A remote SimApp site as the transfer system of one test (module docstring)."""

    kind: ClassVar[str] = "remote"
    signals: tuple[RecordSignal, ...] = ()

    def __init__(self, scenes: Sequence[Scene]):
        if len(scenes) != 1:
            raise ConfigError("transfer.kind", "remote", f"one test at a time ({len(scenes)} "
                              "asked): a remote site serves one connection")
        self.scene = scenes[0]
        net = self.scene.network
        self.K, self.n_if = 1, len(self.scene.dofs)
        n = self.n_if
        self.z_meas = np.zeros((1, n))
        self.f_meas = np.zeros((1, n))
        self.stopped = np.zeros(1, dtype=bool)
        self.reasons = [""]
        self.part_model = "numpy"
        self.site = net.site
        self.metas = [{"site": net.site, "host": net.host, "port": net.port,
                       "timeout": net.timeout, "predicted_delay": 0.0}]
        from ..network.simapp import Header

        ds = max(2 * n + 1, n * n)
        self.header = Header((n, n, 0, 0, 0), (n, 0, 0, n, 0), ds)
        # a step's requests sent in one write: trial, commit, getDaqResponse (lab) or
        # trial, getForce (adapter)
        self._out = np.zeros((3 if net.site == "lab" else 2, ds))
        self._out[1:, 0] = (5.0, 6.0) if net.site == "lab" else (10.0,)
        self._out_bytes = memoryview(self._out).cast("B")
        self.chan: Any = None
        self.n = 0
        self._finalizer: Any = None

    @classmethod
    def build(cls, scenes: Sequence[Scene], *, nthread: int = 0,
              specimen: str = "auto") -> RemoteTransfer:
        return cls(scenes)

    @classmethod
    def batch_key(cls, settings: Mapping[str, Any]) -> Hashable:
        return ("remote",)

    @classmethod
    def threads_over_tests(cls, scene: Scene, specimen: str) -> bool:
        return False

    # ------------------------------------------------------------------ connection
    def reset(self) -> None:
        """Connect to the site (a new connection for every run of the loop)."""
        from ..network.simapp import PeerError, close_socket, connect

        self.close()
        net = self.scene.network
        self.z_meas[:] = 0.0
        self.f_meas[:] = 0.0
        self.stopped[:] = False
        self.reasons = [""]
        self.n = 0
        deadline = time.monotonic() + net.first_timeout
        while True:  # a site that is starting (an adapter not yet listening): retry
            try:
                chan = connect(net.host, net.port, self.header, net.first_timeout,
                               connect_timeout=min(5.0, net.first_timeout))
                break
            except PeerError as exc:
                if "refused" not in str(exc).lower() or time.monotonic() > deadline:
                    raise ConfigError("network.port", net.port, f"{exc}") from None
                time.sleep(0.05)
        self.chan = chan
        self._finalizer = weakref.finalize(self, close_socket, chan.sock)
        self._step_msgs = ((3, 5, 6) if self.site == "lab" else (3, 10))

    def close(self) -> None:
        """Send DIE and close the connection (idempotent); the loop calls it at its end."""
        chan, self.chan = self.chan, None
        if chan is None:
            return
        from ..network.simapp import DIE, PeerError

        try:
            chan.send_buf[:] = 0.0
            chan.send_buf[0] = DIE
            chan.send()
        except PeerError:
            pass
        chan.close()
        if self._finalizer is not None:
            self._finalizer.detach()
            self._finalizer = None

    # ------------------------------------------------------------------ stepping
    def step(self, z: np.ndarray, zdot: np.ndarray) -> None:
        """One step at the site: z (1, n_if) out, z' and F'_m back (held once stopped)."""
        chan = self.chan
        if chan is None or self.stopped[0]:
            return
        from ..network.simapp import PeerError

        n = self.n_if
        out = self._out
        try:
            out[0, 0] = 3.0
            out[0, 1:1 + n] = z[0]
            out[0, 1 + n:1 + 2 * n] = zdot[0]
            chan.send(self._out_bytes)
            r = chan.recv()
            if not (math.isfinite(r[0]) and np.all(np.isfinite(r[:2 * n]))):
                raise PeerError("malformed", "the site answered a value that is not finite")
            self.z_meas[0] = r[:n]
            self.f_meas[0] = r[n:2 * n]
            if self.n == 0:
                chan.set_timeout(self.scene.network.timeout)
            self.n += 1
        except PeerError as exc:
            what = {"closed": "closed the connection", "timeout": "stopped answering",
                    "malformed": "answered a malformed message"}.get(exc.kind, "failed")
            self.stopped[0] = True
            self.reasons[0] = (f"stopped at t = {self.n * self.scene.dt:.3f} s: the remote "
                               f"site {what} ({exc})")
            chan.close()
            self.chan = None

    def compiled(self) -> None:
        """No compiled kernel: the loop steps it from Python."""
        return None

    def closed_range(self, group: Any) -> None:
        return None
