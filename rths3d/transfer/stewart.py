"""The MuJoCo Stewart platform as transfer system: the part rides on its FTS, K tests."""

from __future__ import annotations

from collections.abc import Hashable, Mapping, Sequence
from typing import Any, ClassVar

import numpy as np

from ..config import Scene, TransferConfig
from ..experiment import make_part, part_class
from ..platform.model import ActuatorConfig, PlatformConfig, predicted_delay
from ..platform.sim import PlatformBatch, plate_pose
from ..record import DOFS
from .base import RecordSignal, register_transfer, sensor_key, setting
from .commands import compensation_record, compensator_key
from .legs import platform_compensator
from .sensor import sensor_chain

__all__ = ["StewartTransfer", "platform_config"]


def platform_config(scene: Scene, tr: TransferConfig | None = None) -> PlatformConfig:
    """The platform configuration of a scene's leg-servo settings (``transfer.*``)."""
    t = tr or scene.transfer
    return PlatformConfig(actuator=ActuatorConfig(kp=t.kp, kv=t.kv, timeconst=t.timeconst,
                                                  delay=t.delay, velocity_ff=t.velocity_ff),
                          dt=scene.dt, substeps=t.substeps)


@register_transfer
class StewartTransfer:
    """The six-leg platform carrying the part on its FTS (:class:`PlatformBatch`).

    Tests stepped together may differ in their leg-servo settings (kp, kv, velocity
    feed-forward, the lag's time constant) and their part's parameters: each runs its own
    compiled model of one structure. The actuator delay, whether the servo has a lag, the
    physics substeps and the part's kind change the structure (:meth:`batch_key`). Adds the
    record signals ``pose_cmd.*`` and ``pose_meas.*`` (plate pose commanded and achieved,
    relative to home, m and rad). MuJoCo runs from Python: no compiled kernel.
    """

    kind: ClassVar[str] = "stewart"
    leg_compensation: ClassVar[bool] = True
    """It has legs: ``transfer.compensate = "legs"`` compensates each (:mod:`.legs`)."""

    def __init__(self, scenes: Sequence[Scene], nthread: int = 0):
        self.scenes = list(scenes)
        base = self.scenes[0]
        K = len(self.scenes)
        self.K, self.n_if = K, len(base.dofs)
        cfg = platform_config(base)
        self.config = cfg
        g = cfg.geometry
        site = (0.0, 0.0, g.home_height + g.fts_height)
        variants = [(platform_config(s), make_part(s.experiment).payload_xml(),
                     make_part(s.experiment).world_xml(site)) for s in self.scenes]
        one = len(set(variants)) == 1
        self.sim = PlatformBatch(cfg, nsim=K, nthread=nthread or 2, payload_xml=variants[0][1],
                                 world_xml=variants[0][2], variants=None if one else variants)
        self.idx = np.array([DOFS.index(d) for d in base.dofs], dtype=np.int64)
        # per interface DOF, or per leg through the platform's leg hook (transfer.compensate)
        self.compensator, comp_channels = platform_compensator(
            self.scenes, self.sim, self.idx, [predicted_delay(v[0], 1.0) for v in variants])
        self.sensor = sensor_chain(self.scenes, self.n_if)
        self.pose_cmd = self.sim.poses
        self._f = np.zeros((K, self.n_if))
        self.home_height = float(g.home_height)
        self.plate_qpos = self.sim.plate_qpos
        """Live (K, 7) view of the plate's measured free-joint qpos (m, quaternion wxyz)."""
        self.z_meas = np.zeros((K, self.n_if))
        self.f_meas = np.zeros((K, self.n_if))
        self.stopped = np.zeros(K, dtype=bool)
        self.reasons = [""] * K
        self.part_model = "mujoco"
        """The part rides on the platform in MuJoCo (the reference uses the MuJoCo part)."""
        home = np.array([0.0, 0.0, self.home_height, 1.0, 0.0, 0.0, 0.0])
        self.signals = (
            RecordSignal("pose_cmd", DOFS, self.pose_cmd),
            RecordSignal("pose_meas", DOFS, self.plate_qpos,
                         lambda q: plate_pose(q, self.home_height), home),
        )

        def meta_of(s: Scene, c: PlatformConfig) -> dict[str, Any]:
            t = s.transfer
            return {"predicted_delay": predicted_delay(c, 1.0), "kp": t.kp, "kv": t.kv,
                    "timeconst": t.timeconst, "actuator_delay": t.delay,
                    "velocity_ff": t.velocity_ff, "substeps": t.substeps}

        self.metas = [meta_of(s, v[0]) for s, v in zip(self.scenes, variants, strict=True)]
        """Per-test metadata (leg-servo settings and the delay they predict)."""
        self.signals += compensation_record(self.scenes, self.compensator, comp_channels,
                                            self.metas)

    @classmethod
    def build(cls, scenes: Sequence[Scene], *, nthread: int = 0,
              specimen: str = "auto") -> StewartTransfer:
        return cls(scenes, nthread)

    @classmethod
    def batch_key(cls, settings: Mapping[str, Any]) -> Hashable:
        s = settings
        return (compensator_key(s), setting(s, "transfer.delay", 0.0),
                setting(s, "transfer.timeconst", 0.0) > 0, setting(s, "transfer.substeps", 1),
                part_class(s.get("experiment.kind", "contact")).batch_key(s), sensor_key(s))

    @property
    def model(self):
        return self.sim.model

    @property
    def pose_meas(self) -> np.ndarray:
        """Achieved plate poses (K, 6) relative to home (m, rad)."""
        return plate_pose(self.plate_qpos, self.home_height)

    def reset(self) -> None:
        self.sim.ensure_reset()
        self.compensator.reset()
        self.sensor.reset()
        self.pose_cmd[:] = 0.0
        self.z_meas[:] = 0.0
        self.f_meas[:] = 0.0
        self.stopped[:] = False
        self.reasons = [""] * self.K

    def step(self, z: np.ndarray, zdot: np.ndarray) -> None:
        comp = self.compensator
        u = comp.command(z, zdot, self.z_meas)
        sim = self.sim
        if self.sensor.empty:
            sim.step_interface(u, self.idx, self.z_meas, self.f_meas)
        else:
            sim.step_interface(u, self.idx, self.z_meas, self._f)
            self.f_meas[:] = self.sensor(self._f)
        if sim._any_stopped:
            self.stopped[:] = sim.stopped
            self.reasons = list(sim.reasons)
        if comp.any_stopped:  # an adaptive compensator drifted: stop like any limit
            for k in np.flatnonzero(comp.stopped & ~self.stopped):
                self.stopped[k] = True
                self.reasons[k] = comp.reasons[k]

    def compiled(self) -> None:
        """MuJoCo runs from Python: the loop steps this system from Python."""
        return None
