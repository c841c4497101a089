"""Per-leg compensation on the Stewart platform (``transfer.compensate = "legs"``).

Decentralised compensation, as a multi-actuator rig is compensated (RoDeAC: one adaptive
compensator per actuator): any registered compensator runs on six channels, one per leg, and
each leg's channel sees only its own signals,

* the desired leg extension s = L − L_home, with L the inverse kinematics of the commanded
  pose (m),
* its rate ṡ = l·v / |l| (m/s), l the leg vector and v = ṫ + ω × R p the velocity of the
  leg's plate anchor under the commanded pose rate (the interface DOFs' ż; ω from the
  fixed-axis angle rates of R = Rz Ry Rx) — exact, no finite difference,
* the measured extension: the leg's slide joint position (m), read before the step (the
  answer to the previous command, the compensators' timing convention).

The compensated extension u replaces the desired one: the platform commands L = L_home + u,
checks its stroke and speed limits on that, and writes the servo set-points as usual. The
step runs in :meth:`rths3d.platform.sim.PlatformBatch.advance` through its ``leg_hook``, in
place of the inverse kinematics before the set-point write (one compiled pass computes the
desired lengths with the platform's own anchors, their rates and the measured extensions);
it allocates nothing.

:class:`LegCompensation` takes the interface compensator's place in the Stewart transfer
system: its ``command`` passes the interface command through (keeping ż for the leg rates)
and its ``stopped``/``reasons``/``coefficients`` are the leg compensator's, so a drifting
per-leg compensator stops its test like any other.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numba import njit

from ..compensation import BaseCompensator
from ..config import Scene
from ..platform.sim import PlatformBatch, interface_command, rotation
from ..record import DOFS
from .commands import build_compensator

__all__ = ["LEG_CHANNELS", "LegCompensation", "leg_channels", "platform_compensator"]

LEG_CHANNELS: tuple[str, ...] = tuple(f"leg{i}" for i in range(6))
"""Channel names of per-leg compensation (record columns ``comp.<coefficient>.leg<i>``)."""


@njit(cache=True, nogil=True)
def leg_channels(poses, rates, b, p, hh, home, q, s_des, s_rate, s_meas):
    """The per-leg channels of K platforms, in one pass: the desired extensions
    s = |l| − L_home with l = t + R p_i − b_i (the platform's inverse kinematics, home height
    ``hh``), their rates ṡ = l·(ṫ + ω × R p_i)/|l| under the pose rates ``rates`` (K, 6)
    (m/s, rad/s of the fixed-axis angles) and the measured extensions (the slide positions
    ``q``), each (K, 6) in m or m/s."""
    for k in range(poses.shape[0]):
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = rotation(
            poses[k, 3], poses[k, 4], poses[k, 5])
        cz, sz = math.cos(poses[k, 5]), math.sin(poses[k, 5])
        # ω = ṙz e_z + ṙy Rz e_y + ṙx Rz Ry e_x (R = Rz Ry Rx; Rz Ry e_x is R's first column)
        ax, ay, az = rates[k, 3], rates[k, 4], rates[k, 5]
        wx = -sz * ay + r00 * ax
        wy = cz * ay + r10 * ax
        wz = az + r20 * ax
        for i in range(6):
            px, py, pz = p[i, 0], p[i, 1], p[i, 2]
            rx = r00 * px + r01 * py + r02 * pz
            ry = r10 * px + r11 * py + r12 * pz
            rz = r20 * px + r21 * py + r22 * pz
            lx = poses[k, 0] + rx - b[i, 0]
            ly = poses[k, 1] + ry - b[i, 1]
            lz = poses[k, 2] + hh + rz - b[i, 2]
            vx = rates[k, 0] + wy * rz - wz * ry
            vy = rates[k, 1] + wz * rx - wx * rz
            vz = rates[k, 2] + wx * ry - wy * rx
            L = math.sqrt(lx * lx + ly * ly + lz * lz)
            s_des[k, i] = L - home[i]
            s_rate[k, i] = (lx * vx + ly * vy + lz * vz) / L
            s_meas[k, i] = q[k, i]


@njit(cache=True, nogil=True)
def _commands_out(u, home, L):
    """The lengths to command, L = L_home + u."""
    for k in range(L.shape[0]):
        for i in range(6):
            L[k, i] = home[i] + u[k, i]


class LegCompensation:
    """A compensator on the six legs of K platforms (see the module docstring).

    Installs itself as ``sim.leg_hook``. As the Stewart transfer system's interface
    compensator, :meth:`command` returns the interface command unchanged.
    """

    def __init__(self, comp: BaseCompensator, sim: PlatformBatch, idx: np.ndarray):
        if comp.n != 6 or comp.K != sim.nsim:
            raise ValueError(f"a per-leg compensator needs K = {sim.nsim} tests × 6 channels, "
                             f"got {comp.K} × {comp.n}")
        self.comp = comp
        self.name = comp.name
        self.K, self.n = comp.K, 6
        self.sim = sim
        self.idx = np.asarray(idx, dtype=np.int64)
        self.rates = np.zeros((self.K, 6))
        """Commanded pose rates (K, 6): the interface DOFs' ż, zero for the others."""
        self.s_des = np.zeros((self.K, 6))
        self.s_rate = np.zeros((self.K, 6))
        self.s_meas = np.zeros((self.K, 6))
        # the platform's own kinematic arrays and its live slide positions, so that the leg
        # channels use exactly the geometry of its inverse kinematics
        self._b, self._p = sim.ik_base_anchors, sim.ik_top_anchors
        self._hh, self._home = sim.home_height, sim.home_lengths
        self._q = sim.live_legs_q
        sim.leg_hook = self

    # -- the platform's hook (every step, allocation-free) ---------------------------------
    def __call__(self, L: np.ndarray) -> None:
        """Write the lengths to command (K, 6) into ``L``, from the commanded poses."""
        leg_channels(self.sim.poses, self.rates, self._b, self._p, self._hh, self._home,
                     self._q, self.s_des, self.s_rate, self.s_meas)
        u = self.comp.command(self.s_des, self.s_rate, self.s_meas)
        _commands_out(u, self._home, L)

    # -- the interface compensator's face ----------------------------------------------------
    def command(self, z: np.ndarray, zdot: np.ndarray, z_meas: np.ndarray) -> np.ndarray:
        interface_command(zdot, self.idx, self.rates)  # ż into the pose-rate columns
        return z

    def reset(self) -> None:
        self.comp.reset()
        self.rates[:] = 0.0

    @property
    def stopped(self) -> np.ndarray:
        return self.comp.stopped

    @property
    def any_stopped(self) -> bool:
        return self.comp.any_stopped

    @property
    def reasons(self) -> list[str]:
        """The leg compensator's stop reasons, naming the leg."""
        return [r.replace("(channel ", "(leg ") for r in self.comp.reasons]

    @property
    def stops(self) -> list[Any]:
        return self.comp.stops

    @property
    def t0(self) -> float:
        return self.comp.t0

    @t0.setter
    def t0(self, value: float) -> None:
        self.comp.t0 = value

    @property
    def prior_keys(self) -> tuple[str, ...]:
        return self.comp.prior_keys

    def coefficients(self) -> dict[str, np.ndarray]:
        return self.comp.coefficients()

    def history(self) -> np.ndarray | None:
        return self.comp.history()

    def history_coefficients(self, states: np.ndarray) -> dict[str, np.ndarray]:
        return self.comp.history_coefficients(states)

    def compiled(self) -> None:
        return None

    def __repr__(self) -> str:
        return f"LegCompensation({self.comp!r})"


def platform_compensator(scenes: Sequence[Scene], sim: PlatformBatch, idx: np.ndarray,
                         delays: Sequence[float]) -> tuple[Any, tuple[str, ...]]:
    """The Stewart transfer system's compensator of K tests and its channel names: per
    interface DOF (``transfer.compensate = "interface"``), or per leg (``"legs"``, a
    :class:`LegCompensation` installed on ``sim``; without compensation the platform keeps
    its plain path). ``delays``: each test's predicted delay (s), for ``comp_init``."""
    tr = scenes[0].transfer
    if tr.compensate == "legs" and tr.compensation != "none":
        comp = build_compensator(scenes, 6, delays)
        return LegCompensation(comp, sim, idx), LEG_CHANNELS
    return build_compensator(scenes, len(idx), delays), tuple(DOFS[i] for i in idx)
