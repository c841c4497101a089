"""Transfer systems made of a chain: compensator → actuator model → part model → sensor.

The ``ideal``, ``delay`` and ``lti`` transfer systems differ only in their actuator chain
(none, a pure delay, a delay and an LTI model); each is one subclass in its own file. Every
stage has a compiled kernel (the 1-D parts' numpy model, the effect blocks, the
compensators), so these systems run in the compiled loop unless the part has only a MuJoCo
model (the multi-DOF part), in which case the loop steps them from Python with the same
kernels.
"""

from __future__ import annotations

import math
from collections.abc import Hashable, Mapping, Sequence
from typing import Any, ClassVar

import numpy as np

from ..compensation import BaseCompensator
from ..config import Scene
from ..experiment import build_part_model, part_class, uses_numpy
from ..kernels import Chain
from .base import CompiledTransfer, RecordSignal, effect_on, sensor_key, setting
from .commands import compensation_record, compensator_key, compensator_of
from .sensor import sensor_chain

__all__ = ["ChainTransfer"]


def _with_effects(scenes: Sequence[Scene], n: int, act: Chain, metas: list[dict[str, Any]]
                  ) -> tuple[Chain, list[dict[str, Any]]]:
    """The actuator chain followed by the bench effects that apply to a 1-D chain: the
    transport ``delay`` and the ``actuator_lag`` of all legs act on every interface DOF (the
    sensor effects are in the sensor chain); the others are listed in each test's metadata
    as ``ignored_effects``."""
    from ..effects import REGISTRY, get_effect

    K = len(scenes)
    blocks = list(act.blocks)
    # the set-point effects a 1-D chain has (transport delay, lag), in the library's order
    for name, eff in REGISTRY.items():
        if not (eff.lti and eff.stage == "setpoint"):
            continue
        vals = [sum(e.value for e in s.effects if e.name == name and e.leg < 0)
                for s in scenes]
        if any(v > 0 for v in vals):
            blocks.append(eff.block(K, np.repeat(vals, n), scenes[0].dt))
    out = []
    for s, m in zip(scenes, metas, strict=True):
        ign = [e.label for e in s.effects if not (get_effect(e.name).lti and e.leg < 0)]
        out.append({**m, "ignored_effects": ign} if ign else m)
    return (Chain(K, n, blocks) if len(blocks) != len(act.blocks) else act), out


class ChainTransfer:
    """Compensation, actuator chain, part model and sensor chain, K tests (see the module
    docstring). Subclasses set :attr:`kind` and implement :meth:`actuator_chain` (and, if
    their actuators change the batch structure, :meth:`actuator_key`)."""

    kind: ClassVar[str] = ""
    signals: tuple[RecordSignal, ...] = ()

    def __init__(self, scenes: Sequence[Scene], compensator: BaseCompensator, actuator: Chain,
                 part: Any, sensor: Chain, metas: Sequence[dict[str, Any]]):
        self.scenes = list(scenes)
        K, n = len(self.scenes), len(self.scenes[0].dofs)
        self.K, self.n_if = K, n
        self.compensator = compensator
        self.actuator = actuator
        self.part = part
        self.sensor = sensor
        self.metas = list(metas)
        self.z_meas = np.zeros((K, n))
        self.z_prev = np.zeros((K, n))
        self.f_meas = np.zeros((K, n))
        self.f_true = np.zeros((K, n))
        self.u = np.zeros((K, n))
        self.stopped = np.zeros(K, dtype=bool)
        self.reasons = [""] * K
        self.part_model = "numpy" if part.compiled() is not None else "mujoco"
        """The part's model, ``numpy`` or ``mujoco`` (the reference uses the same)."""
        self.signals = compensation_record(self.scenes, compensator, self.scenes[0].dofs,
                                           self.metas)
        """``comp.<coefficient>.<dof>``: the compensator's coefficients over time."""

    # ------------------------------------------------------------------ building
    @classmethod
    def actuator_chain(cls, scenes: Sequence[Scene], n: int
                       ) -> tuple[Chain, list[dict[str, Any]]]:
        """The actuator chain of K tests and each test's transfer metadata."""
        raise NotImplementedError

    @classmethod
    def actuator_key(cls, settings: Mapping[str, Any]) -> Hashable:
        """What of the transfer settings must be equal for tests stepped together: the
        actuators' settings (delay, model, servo gains, lag, feed-forward, compensation time)
        are per test; the platform's physics ``substeps`` keeps tests apart, as on the
        platform."""
        return (setting(settings, "transfer.substeps", 1), effect_on(settings, "delay"),
                effect_on(settings, "actuator_lag"))

    @classmethod
    def build(cls, scenes: Sequence[Scene], *, nthread: int = 0,
              specimen: str = "auto") -> ChainTransfer:
        base = scenes[0]
        n = len(base.dofs)
        act, metas = cls.actuator_chain(scenes, n)
        act, metas = _with_effects(scenes, n, act, metas)
        comp = compensator_of(scenes, n, [m.get("predicted_delay", math.nan) for m in metas])
        part = build_part_model([s.experiment for s in scenes], base.dofs, base.dt,
                                model=specimen, nthread=nthread)
        model = "numpy" if part.compiled() is not None else "mujoco"
        metas = [{"specimen": model, **m} for m in metas]
        return cls(scenes, comp, act, part, sensor_chain(scenes, n), metas)

    @classmethod
    def threads_over_tests(cls, scene: Scene, specimen: str) -> bool:
        """Slices on threads when the part steps through its numpy model (the compiled 1-D
        loop, one row per test and DOF); a MuJoCo part has its own thread pool."""
        return uses_numpy(scene.experiment, specimen)

    @classmethod
    def batch_key(cls, settings: Mapping[str, Any]) -> Hashable:
        return (compensator_key(settings), cls.actuator_key(settings),
                part_class(settings.get("experiment.kind", "contact")).batch_key(settings),
                sensor_key(settings))

    # ------------------------------------------------------------------ stepping
    def reset(self) -> None:
        self.compensator.reset()
        self.actuator.reset()
        self.part.reset()
        self.sensor.reset()
        for a in (self.z_meas, self.z_prev, self.f_meas, self.f_true, self.u):
            a[:] = 0.0
        self.stopped[:] = False
        self.reasons = [""] * self.K

    def step(self, z: np.ndarray, zdot: np.ndarray) -> None:
        comp = self.compensator
        u = comp.command(z, zdot, self.z_meas)
        zm = self.actuator(u)
        f = self.part.advance(self.z_prev, zm)
        self.f_true[:] = f
        self.f_meas[:] = self.sensor(f)
        self.z_prev[:] = zm
        self.z_meas[:] = zm
        if comp.any_stopped:  # an adaptive compensator drifted: the bench stops the test
            self.stopped[:] = comp.stopped
            self.reasons = list(comp.reasons)

    def closed_range(self, group: Any) -> None:
        """A chain steps through its 1-D kernel (:meth:`compiled`) or from Python."""
        return None

    def compiled(self) -> CompiledTransfer | None:
        part = self.part.compiled()
        comp = self.compensator.compiled()
        if part is None or comp is None:
            return None
        a, s = self.actuator, self.sensor
        return CompiledTransfer(comp,
                                (a.fns, a.params, a.states), ((part[0],), part[1], part[2]),
                                (s.fns, s.params, s.states),
                                a if a.noise is not None else None,
                                s if s.noise is not None else None)
