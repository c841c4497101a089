"""One simulated platform with float poses and a :class:`~rths3d.errors.SafetyStop` raised at
a limit: :class:`PlatformSim`, a :class:`~rths3d.platform.sim.PlatformBatch` of one test."""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from ..errors import SafetyStop
from .kernels import _quat_to_euler
from .model import PlatformConfig
from .sim import PlatformBatch, StaticState

__all__ = ["PlatformSim"]


class PlatformSim:
    """One simulated platform stepped at the interface rate ΔT = ``config.dt``.

    Parameters
    ----------
    config:
        Platform configuration (geometry, actuators, step).
    payload_xml, world_xml:
        MJCF fragments: the experimental part on the FTS, extra world bodies.
    settle:
        Simulated time (s) held at home during :meth:`reset` so the chain and the payload
        settle before the test starts.

    After ``reset()``, call ``step(x, y, z, rx, ry, rz)`` once per ΔT with the commanded pose
    (m, rad, relative to home): the same compiled kernels as :class:`PlatformBatch` (it is
    one, with K = 1). ``step`` raises :class:`~rths3d.errors.SafetyStop` when a commanded leg
    leaves its stroke or speed limit (before stepping), when a measured leg leaves its
    stroke, speed or force limit, or when MuJoCo reports a bad acceleration (divergence;
    MuJoCo would otherwise silently reset the state). The stop's time ``t`` is the time the
    offending step's command was meant for (``(k + 1)·ΔT`` for step k). A stopped platform
    stays stopped, as a bench would: ``stopped_by`` holds the stop and every later ``step``
    raises it again until :meth:`reset`.
    """

    def __init__(self, config: PlatformConfig | None = None, payload_xml: str | None = None,
                 world_xml: str | None = None, settle: float = 0.05):
        self._b = PlatformBatch(config, 1, 1, payload_xml, world_xml, settle)
        self.config = self._b.config
        self.model = self._b.model
        self.data = self._b.batch.d
        self.ids = self._b.ids
        self.settle = self._b.settle
        self._pose = np.zeros((1, 6))
        self._h = self._b.home_height
        b = self._b
        self._smax, self._vmax, self._fmax = b.half_stroke, b.velocity_limit, b.force_limit
        self.stopped_by: SafetyStop | None = None
        """The SafetyStop that stopped the platform (``step`` raises it again), or None."""
        self._raise_if_stopped()

    @property
    def static(self) -> StaticState:
        """Static equilibrium at home (computed at reset)."""
        return self._b.statics[0]

    def reset(self) -> None:
        """Home pose, static equilibrium with gravity compensation, settle; ``t = 0``."""
        self._b.reset()
        self.stopped_by = None
        self._raise_if_stopped()

    def _raise_if_stopped(self) -> None:
        stop = self._b.stops[0]
        if stop is not None:
            self.stopped_by = stop
            raise stop

    @property
    def t(self) -> float:
        """Simulated test time (s) since reset (interface steps × ΔT)."""
        return self._b.t

    def step(self, x: float, y: float, z: float, rx: float, ry: float, rz: float) -> None:
        """Command the pose (m, rad, relative to home) for one interface step ΔT."""
        if self.stopped_by is not None:
            raise self.stopped_by
        p = self._pose
        p[0, 0], p[0, 1], p[0, 2], p[0, 3], p[0, 4], p[0, 5] = x, y, z, rx, ry, rz
        self._b.step(p)
        if self._b.stopped[0]:
            self._raise_if_stopped()

    def _check_measured(self, q: Sequence[float], v: Sequence[float],
                        f: Sequence[float]) -> None:
        """Raise the SafetyStop for the first leg (then stroke, speed, force) out of limits."""
        self._b.measured_limits(np.array([q], float), np.array([v], float),
                                 np.array([f], float))
        self._raise_if_stopped()

    # ------------------------------------------------------------------ reads
    @property
    def pose(self) -> tuple[float, float, float, float, float, float]:
        """Achieved plate pose relative to home (m, rad), from the plate body's state."""
        px, py, pz, w, qx, qy, qz = self._b.plate_qpos[0].tolist()
        rx, ry, rz = _quat_to_euler(w, qx, qy, qz)
        return px, py, pz - self._h, rx, ry, rz

    @property
    def leg_lengths(self) -> tuple[float, ...]:
        """Achieved leg lengths (m): home length + piston extension."""
        return tuple(self._b.leg_lengths[0].tolist())

    @property
    def leg_commands(self) -> tuple[float, ...]:
        """Leg lengths (m) commanded by the last step (inverse kinematics of the pose)."""
        return tuple(self._b._Lprev[0].tolist())

    @property
    def leg_forces(self) -> tuple[float, ...]:
        """Actuator forces (N), positive pushing the plate away from the base."""
        return tuple(self._b.meas_legs_f[0].tolist())

    @property
    def wrench(self) -> tuple[float, ...]:
        """Raw FTS wrench ``(fx, fy, fz, tx, ty, tz)`` in the ``fts`` site frame (N, N·m).

        The force and torque the plate exerts on the sensor's tool side and everything
        mounted on it (payload weight included), torque about the site origin.
        """
        return tuple(self._b.wrench[0].tolist())

    @property
    def interface_wrench(self) -> tuple[float, ...]:
        """Restoring wrench ``f_meas`` of the experimental part (N, N·m), 6 floats.

        World axes, static preload (payload weight at home) removed: the force the platform
        exerts on the specimen, so a positive value resists a positive displacement
        (docs/architecture.md). Torque about the ``fts`` site origin.
        """
        return tuple(self._b.interface_force(range(6))[0].tolist())

    def equality_gap(self) -> float:
        """Largest distance between a leg tip and its plate anchor (m)."""
        mujoco.mj_kinematics(self.model, self.data)
        x = self.data.site_xpos
        return float(max(np.linalg.norm(x[a] - x[b]) for a, b in
                         zip(self.ids.tip_site, self.ids.anchor_site, strict=True)))
