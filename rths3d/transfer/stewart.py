"""The MuJoCo Stewart platform as transfer system: the bench (:class:`rths3d.bench.Bench`)
carrying the part on its FTS, K tests."""

from __future__ import annotations

from collections.abc import Hashable, Mapping, Sequence
from typing import Any, ClassVar

import numpy as np

from ..bench import Bench, platform_batch
from ..bench.base import platform_config
from ..config import ControllerConfig, Scene
from ..effects import WRENCH, get_effect, noise_sigma
from ..effects.blocks import NoiseBlock
from ..experiment import part_class
from ..platform.model import predicted_delay
from ..platform.sim import plate_pose
from ..record import DOFS
from .base import RecordSignal, effect_labels, register_transfer, sensor_key, setting
from .commands import compensation_record, compensator_key
from .legs import platform_compensator
from .sensor import sensor_chain

__all__ = ["StewartTransfer", "platform_config"]

LEGS = tuple(str(i) for i in range(6))


def _noisy(convert, sigma: np.ndarray, seeds: Sequence[int]):
    """A record-signal conversion followed by seeded white measurement noise (σ per column;
    one generator per test, drawn in row order as blocks are written)."""
    if not np.any(sigma > 0):
        return convert
    gens = [np.random.default_rng(int(s)) for s in seeds]

    def conv(block: np.ndarray) -> np.ndarray:
        out = np.array(convert(block) if convert is not None else block, dtype=float)
        for k, g in enumerate(gens):
            out[:, k, :] += g.standard_normal((out.shape[0], out.shape[2])) * sigma[k]
        return out

    return conv


@register_transfer
class StewartTransfer:
    """The six-leg platform carrying the part on its FTS: one :class:`~rths3d.bench.Bench`
    per test, stepped by :func:`~rths3d.bench.platform_batch` (the diagnosis' replay steps
    the same code).

    Tests stepped together may differ in their leg-servo settings, their part's parameters
    and their effects' values; which set-point, sensor and FTS effects act, the physics
    substeps and the part's kind change the structure (:meth:`batch_key`). Record signals
    (docs/records.md): ``pose_cmd.*`` and ``pose_meas.*`` (plate pose commanded and measured,
    relative to the nominal home, m and rad; absolute, not re-zeroed), ``leg_len.<i>`` (the
    leg encoders, m), ``leg_force.<i>`` (actuator forces tared at rest, N) and ``fts.<fx…tz>``
    (the raw six-axis reading in the sensor frame, zeroed unloaded: it carries the payload's
    weight, N and N·m). With the ``sensor_noise`` effect every measured channel carries
    seeded white noise (``z_meas`` and ``f_meas`` inside the loop). With a linear numerical
    substructure and a fixed compensator the loop runs whole ranges of steps compiled
    (:meth:`closed_range`, :mod:`rths3d.platform.closed`); otherwise from Python.
    """

    kind: ClassVar[str] = "stewart"
    leg_compensation: ClassVar[bool] = True
    """It has legs: ``transfer.compensate = "legs"`` compensates each (:mod:`.legs`)."""
    replays_bench: ClassVar[bool] = True
    """The diagnosis' replay is this system's own bench model."""

    def __init__(self, scenes: Sequence[Scene], nthread: int = 0):
        self.scenes = list(scenes)
        base = self.scenes[0]
        K = len(self.scenes)
        self.K, self.n_if = K, len(base.dofs)
        self.benches = [Bench.from_scene(s) for s in self.scenes]
        self.sim = platform_batch(self.benches, nthread=nthread or 2)
        cfg = self.config = self.benches[0].platform
        self.idx = np.array([DOFS.index(d) for d in base.dofs], dtype=np.int64)
        # per interface DOF, or per leg through the platform's leg hook (transfer.compensate)
        self.compensator, comp_channels = platform_compensator(
            self.scenes, self.sim, self.idx,
            [predicted_delay(b.platform, 1.0) for b in self.benches])
        self.sensor = sensor_chain(self.scenes, self.n_if)
        self.pose_cmd = self.sim.poses
        self._f = np.zeros((K, self.n_if))
        g = cfg.geometry
        self.home_height = float(g.home_height)
        self.plate_qpos = self.sim.plate_qpos
        """Live (K, 7) view of the plate's measured free-joint qpos (m, quaternion wxyz)."""
        self.z_meas = np.zeros((K, self.n_if))
        self.f_meas = np.zeros((K, self.n_if))
        self.stopped = np.zeros(K, dtype=bool)
        self.reasons = [""] * K
        self.part_model = "mujoco"
        """The part rides on the platform in MuJoCo (the reference uses the MuJoCo part)."""
        levels = np.array([b.noise_level() for b in self.benches])
        seeds = [s.sensor.seed for s in self.scenes]
        self._znoise = None
        if np.any(levels > 0):
            zs = np.concatenate([lv * np.array([noise_sigma(f"z_meas.{d}") for d in base.dofs])
                                 for lv in levels])
            self._znoise = NoiseBlock(K, self.n_if, zs, [s + 7919 for s in seeds])

        def sig(name: str, labels: Sequence[str]) -> np.ndarray:
            return levels[:, None] * np.array([noise_sigma(f"{name}.{c}") for c in labels])

        home = np.array([0.0, 0.0, self.home_height, 1.0, 0.0, 0.0, 0.0])
        sim = self.sim
        rest = sim.rest_leg_forces
        self.signals = (
            RecordSignal("pose_cmd", DOFS, self.pose_cmd),
            RecordSignal("pose_meas", DOFS, self.plate_qpos, _noisy(
                lambda q: plate_pose(q, self.home_height), sig("pose_meas", DOFS),
                [s + 1 for s in seeds]), home),
            RecordSignal("leg_len", LEGS, sim.meas_legs_q, _noisy(
                sim.encoder_lengths, sig("leg_len", LEGS),
                [s + 2 for s in seeds]), np.zeros(6)),
            RecordSignal("leg_force", LEGS, sim.meas_legs_f, _noisy(
                lambda f: f - rest[None], sig("leg_force", LEGS), [s + 3 for s in seeds]),
                None),
            RecordSignal("fts", WRENCH, sim.fts_reading, _noisy(
                None, sig("fts", WRENCH), [s + 4 for s in seeds]), None),
        )

        def meta_of(s: Scene, b: Bench) -> dict[str, Any]:
            t = s.transfer
            return {"predicted_delay": predicted_delay(b.platform, 1.0), "kp": t.kp,
                    "kv": t.kv, "timeconst": t.timeconst, "actuator_delay": t.delay,
                    "velocity_ff": t.velocity_ff, "substeps": t.substeps,
                    "integrator": b.platform.integrator, "bench": b.label(),
                    **({"valve_hz": t.valve_hz, "valve_damping": t.valve_damping}
                       if t.valve_hz else {})}

        self.metas = [meta_of(s, b) for s, b in zip(self.scenes, self.benches, strict=True)]
        """Per-test metadata (leg-servo settings, the delay they predict, the effects)."""
        self.signals += compensation_record(self.scenes, self.compensator, comp_channels,
                                            self.metas)

    @classmethod
    def build(cls, scenes: Sequence[Scene], *, nthread: int = 0,
              specimen: str = "auto") -> StewartTransfer:
        return cls(scenes, nthread)

    @classmethod
    def threads_over_tests(cls, scene: Scene, specimen: str) -> bool:
        """No: the platform's MuJoCo batch steps its tests on its own threads."""
        return False

    @classmethod
    def batch_key(cls, settings: Mapping[str, Any]) -> Hashable:
        s = settings
        # per-test values (controller blocks), but numbers: a ConfigError names a bad one
        for key in ("transfer.delay", "transfer.timeconst", "transfer.kp", "transfer.kv"):
            setting(s, key, 0.0)
        effects = sorted({name for name, _, v in effect_labels(s)
                          if not get_effect(name).is_off(v) and
                          (get_effect(name).stage in ("setpoint", "fts", "sensor", "noise")
                           or get_effect(name).structural)})
        # a servo lag after the hold adds actuators to the model (rths3d.platform.model)
        servo_lag = s.get("controller.lag", ControllerConfig.lag) == "servo" and \
            setting(s, "transfer.timeconst", 0.0) > 0
        # and so does a servo-valve
        valve = setting(s, "transfer.valve_hz", 0.0) > 0
        return (compensator_key(s), setting(s, "transfer.substeps", 1), servo_lag, valve,
                s.get("transfer.integrator", "RK4"),
                part_class(s.get("experiment.kind", "contact")).batch_key(s), sensor_key(s),
                tuple(effects))

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
        if self._znoise is not None:
            self._znoise.reset()
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
        if self._znoise is not None:
            self.z_meas[:] = self._znoise(self.z_meas)
        if sim.any_stopped:
            self.stopped[:] = sim.stopped
            self.reasons = list(sim.reasons)
        if comp.any_stopped:  # an adaptive compensator drifted: stop like any limit
            for k in np.flatnonzero(comp.stopped & ~self.stopped):
                self.stopped[k] = True
                self.reasons[k] = comp.reasons[k]

    def compiled(self) -> None:
        """No kernel of the 1-D signature: the loop steps this system through
        :meth:`closed_range` (compiled) or from Python."""
        return None

    closed_loop: ClassVar[bool] = True
    """Whether the loop may step this system in compiled ranges (:meth:`closed_range`);
    False: always the Python driver (the reference)."""

    def closed_range(self, group: Any) -> Any:
        """The compiled closed loop of a loop group (:class:`rths3d.platform.closed.
        ClosedRange`), or None when it cannot run it (an adaptive compensator, per-leg
        compensation, set-point noise: the Python driver steps it)."""
        from ..platform.closed import ClosedRange, closed_ok

        if not self.closed_loop or not closed_ok(self):
            return None
        return ClosedRange(group)
