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

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..compensation import BaseCompensator
from ..config import Scene
from ..platform.kernels import commands_out, leg_channels
from ..platform.sim import PlatformBatch, interface_command
from ..record import DOFS
from .commands import build_compensator

__all__ = ["LEG_CHANNELS", "LegCompensation", "leg_channels", "platform_compensator"]

LEG_CHANNELS: tuple[str, ...] = tuple(f"leg{i}" for i in range(6))
"""Channel names of per-leg compensation (record columns ``comp.<coefficient>.leg<i>``)."""


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
        commands_out(u, self._home, L)

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

    def compiled(self) -> Any:
        """The leg compensator's kernel (:meth:`BaseCompensator.compiled`, K·6 rows): the
        Stewart platform's compiled closed loop steps this hook itself; None when the leg
        compensator has none (the Python driver steps it)."""
        return self.comp.compiled()

    @property
    def adaptive(self) -> bool:
        return self.comp.adaptive

    def events(self, call: int | None = None, tests: slice = slice(None)) -> None:
        self.comp.events(call, tests)

    @property
    def calls(self) -> int:
        """The leg compensator's calls (one per step)."""
        return self.comp.calls

    @calls.setter
    def calls(self, value: int) -> None:
        self.comp.calls = value

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
