"""Transfer systems behind one small protocol, K tests per step.

A transfer system takes the commanded interface displacement z (K, n_if) at t_{n+1} (the
target for the end of the step), moves the experimental part during the step and returns
the achieved z' and the measured restoring force F'_m at t_{n+1}:

    transfer.step(z, zdot)      # then read transfer.z_meas, transfer.f_meas  (K, n_if)

``ActuatorTransfer``: compensation → actuator model (ideal z' = z, pure delay, or 1-D LTI
per DOF) → specimen (numpy ``Specimen1D`` or ``MujocoSpecimen``) → sensor model.
``StewartTransfer``: the MuJoCo Stewart platform with the part on its FTS
(``PlatformSim`` for one test, ``PlatformBatch`` for K).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Protocol

import numpy as np

from ..errors import SafetyStop
from ..record import DOFS
from ..scene import PER_TEST_COMPENSATION, ExperimentConfig, Scene
from .actuators import (
    Compensator,
    DelayLine,
    LTIActuator,
    PerTestDelayLine,
    PerTestLTIActuator,
    SensorModel,
    default_transfer_function,
    default_transport_delay,
    follow_servo_settings,
)


class TransferSystem(Protocol):
    """What the loop drives. ``stopped``/``reasons`` flag tests halted by the bench."""

    name: str
    K: int
    n_if: int
    z_meas: np.ndarray
    f_meas: np.ndarray
    stopped: np.ndarray
    reasons: list[str]

    def reset(self) -> None: ...

    def step(self, z: np.ndarray, zdot: np.ndarray) -> None: ...


class ActuatorTransfer:
    """Compensation, actuator model, specimen and sensor (see module docstring)."""

    def __init__(self, name: str, K: int, n_if: int, actuator, specimen, compensator,
                 sensor, meta: dict | None = None, metas: Sequence[dict] | None = None):
        """``meta``: the transfer system's metadata; ``metas``: one per test where the tests'
        actuators differ (default: ``meta`` for every test)."""
        self.name = name
        self.K, self.n_if = K, n_if
        self.actuator = actuator
        self.specimen = specimen
        self.compensator = compensator
        self.sensor = sensor
        self.z_meas = np.zeros((K, n_if))
        self.z_prev = np.zeros((K, n_if))
        self.f_meas = np.zeros((K, n_if))
        self.f_true = np.zeros((K, n_if))
        self.stopped = np.zeros(K, dtype=bool)
        self.reasons = [""] * K
        self.meta = meta or {}
        self.metas = list(metas) if metas is not None else [self.meta] * K
        """Per-test metadata (actuator model, delays, predicted delay)."""

    def reset(self) -> None:
        for part in (self.actuator, self.specimen, self.compensator, self.sensor):
            if hasattr(part, "reset"):
                part.reset()
        self.z_meas[:] = 0.0
        self.z_prev[:] = 0.0
        self.f_meas[:] = 0.0
        self.stopped[:] = False
        self.reasons = [""] * self.K

    def step(self, z: np.ndarray, zdot: np.ndarray) -> None:
        zc = self.compensator(z, zdot)
        zm = zc if self.actuator is None else self.actuator(zc)
        f = self.specimen.advance(self.z_prev, zm)
        self.f_true[:] = f
        self.f_meas[:] = self.sensor(f)
        self.z_prev[:] = zm
        self.z_meas[:] = zm


class StewartTransfer:
    """The MuJoCo Stewart platform carrying the experimental part (K tests)."""

    def __init__(self, scene: Scene, K: int, nthread: int = 0,
                 scenes: Sequence[Scene] | None = None):
        """``scenes``: one per test when the tests' leg-servo settings (kp, kv, lag time
        constant, velocity feed-forward) or parts' parameters differ (same part kind, actuator
        delay and lag on/off); default: all K tests are ``scene``."""
        from ..experiment.mjcf import payload_xml, world_xml
        from ..platform.model import ActuatorConfig, PlatformConfig, predicted_delay

        tr = scene.transfer
        self.name = "stewart"
        self.K, self.n_if = K, len(scene.dofs)

        def config_of(t):
            return PlatformConfig(
                actuator=ActuatorConfig(kp=t.kp, kv=t.kv, timeconst=t.timeconst,
                                        delay=t.delay, velocity_ff=t.velocity_ff),
                dt=scene.dt, substeps=t.substeps)

        cfg = config_of(tr)
        self.config = cfg
        g = cfg.geometry
        site = (0.0, 0.0, g.home_height + g.fts_height)
        pxml = payload_xml(scene.experiment)
        wxml = world_xml(scene.experiment, site)
        variants = None
        if scenes is not None and K > 1:
            if len(scenes) != K:
                raise ValueError(f"scenes: {len(scenes)} given for K = {K} tests")
            variants = [(config_of(sc.transfer), payload_xml(sc.experiment),
                         world_xml(sc.experiment, site)) for sc in scenes]
            if len(set(variants)) == 1:
                variants = None
        self.idx = [DOFS.index(d) for d in scene.dofs]
        self.compensator = Compensator(K, self.n_if, tr.compensation, tr.comp_time, scene.dt,
                                       tr.poly_order)
        s = scene.sensor
        self.sensor = SensorModel(K, self.n_if, scene.dt, s.kind, s.time_constant, s.noise_std,
                                  s.gain, s.offset, s.delay, sensor_seeds(scene, scenes, K))
        self.single = K == 1
        if self.single:
            from ..platform.sim import PlatformSim

            self.sim = PlatformSim(cfg, pxml, wxml)
        else:
            from ..platform.sim import PlatformBatch

            self.sim = PlatformBatch(cfg, nsim=K, nthread=nthread or 2, payload_xml=pxml,
                                     world_xml=wxml, variants=variants)
        self.pose_cmd = np.zeros((K, 6))
        self.home_height = float(g.home_height)
        # an interface without rotations: IK without rotation, z' and F'_m read directly
        self._translation_only = all(i < 3 for i in self.idx)
        self._idx = np.array(self.idx)
        # z' of a translational DOF: plate position minus home (rotations: see step)
        self._z_off = np.array([0.0, 0.0, self.home_height, 0.0, 0.0, 0.0])[self._idx]
        if self.single:
            self.plate_qpos = self.sim._plate_q[None, :]
        else:
            self.plate_qpos = self.sim.plate_qpos
        """Live (K, 7) view of the plate's measured free-joint qpos (m, quaternion wxyz)."""
        self.z_meas = np.zeros((K, self.n_if))
        self.f_meas = np.zeros((K, self.n_if))
        self.stopped = np.zeros(K, dtype=bool)
        self.reasons = [""] * K
        def meta_of(t, c) -> dict:
            return {"predicted_delay": predicted_delay(c, 1.0), "kp": t.kp, "kv": t.kv,
                    "timeconst": t.timeconst, "actuator_delay": t.delay,
                    "velocity_ff": t.velocity_ff, "substeps": t.substeps}

        self.meta = meta_of(tr, cfg)
        self.metas = [self.meta] * K if variants is None else \
            [meta_of(sc.transfer, v[0]) for sc, v in zip(scenes, variants, strict=True)]
        """Per-test metadata (leg-servo settings and the delay they predict)."""

    @property
    def model(self):
        return self.sim.model

    @property
    def pose_meas(self) -> np.ndarray:
        """Achieved plate poses (K, 6) relative to home (m, rad), from :attr:`plate_qpos`."""
        from ..platform.sim import plate_pose

        return plate_pose(self.plate_qpos, self.home_height)

    def reset(self) -> None:
        self.sim.reset()
        self.compensator.reset()
        self.sensor.reset()
        self.pose_cmd[:] = 0.0
        self.z_meas[:] = 0.0
        self.f_meas[:] = 0.0
        self.stopped[:] = False
        self.reasons = [""] * self.K

    def step(self, z: np.ndarray, zdot: np.ndarray) -> None:
        zc = self.compensator(z, zdot)
        self.pose_cmd[:, self.idx] = zc
        if self.single:
            p = self.pose_cmd[0].tolist()
            self.sim.step(p[0], p[1], p[2], p[3], p[4], p[5])
            self.z_meas[0] = np.asarray(self.sim.pose)[self.idx]
            w = np.asarray(self.sim.interface_wrench)
            f = w[self.idx][None, :]
        else:
            sim = self.sim
            if self._translation_only:
                sim.step(self.pose_cmd, translation_only=True)
                np.subtract(self.plate_qpos[:, self._idx], self._z_off, out=self.z_meas)
                f = sim.interface_force(self._idx)
            else:
                sim.step(self.pose_cmd)
                self.z_meas[:] = sim.pose[:, self._idx]
                f = sim.interface_wrench[:, self._idx]
            if sim.stopped.any():
                self.stopped[:] = sim.stopped
                self.reasons = list(sim.reasons)
        self.f_meas[:] = self.sensor(f)


def sensor_seeds(scene: Scene, scenes: Sequence[Scene] | None, K: int) -> int | list[int]:
    """The sensor's noise seed: the scene's one, or one per test when tests stepped together
    carry their own (the loop's group key ignores ``sensor.seed``), so that a test's noise
    depends on its seed alone, not on the batch it ran in."""
    if scenes is None or K == 1:
        return scene.sensor.seed
    seeds = [sc.sensor.seed for sc in scenes]
    return seeds[0] if len(set(seeds)) == 1 else seeds


def build_transfer(scene: Scene, K: int, experiments: Sequence[ExperimentConfig] | None = None,
                   nthread: int = 0, specimen: str = "auto", *,
                   scenes: Sequence[Scene] | None = None) -> TransferSystem:
    """The transfer system of ``scene`` for K tests.

    ``experiments``: per-test :class:`~rths3d.scene.ExperimentConfig` (default: the scene's).
    ``scenes``: per-test scenes. On the Stewart platform the leg-servo settings and parts may
    differ test by test (see :class:`StewartTransfer`); on the ``delay`` and ``lti`` paths the
    settings of :data:`~rths3d.scene.ACTUATOR_PER_TEST` and a compensation of ``none`` or
    ``velocity`` may (per-test delay lines, actuator models and compensation times; the
    records' ``transfer_meta`` then hold each test's model and predicted delay).
    ``specimen``: ``numpy`` (the vectorised 1-D model), ``mujoco`` or ``auto`` (numpy for
    1-D parts, MuJoCo for the multi-DOF part).
    """
    tr = scene.transfer
    if tr.kind == "stewart":
        return StewartTransfer(scene, K, nthread, scenes=scenes)
    exps = experiments or [scene.experiment] * K
    n_if = len(scene.dofs)
    kind = scene.experiment.kind
    use_numpy = specimen == "numpy" or (specimen == "auto" and kind != "multidof")
    if use_numpy:
        from ..experiment.specimen import Specimen1D

        if kind == "multidof":
            raise ValueError("the multi-DOF part has no numpy model; use specimen='mujoco'")
        arr = lambda a: np.array([getattr(e, a) for e in exps])  # noqa: E731
        h0 = np.where([e.kind == "contact" for e in exps], arr("h0"), np.inf)
        spec = Specimen1D(K, arr("m"), arr("k"), arr("d"), h0, arr("k_contact"),
                          arr("d_contact"), dt=scene.dt, substeps=exps[0].substeps)
    else:
        from ..experiment.mujoco_specimen import MujocoSpecimen

        spec = MujocoSpecimen(list(exps), scene.dofs, scene.dt, nthread=nthread)
    meta: dict = {"specimen": "numpy" if use_numpy else "mujoco"}
    per_test = scenes if scenes is not None and K > 1 else [scene] * K
    if len(per_test) != K:
        raise ValueError(f"scenes: {len(per_test)} given for K = {K} tests")
    delay_line = lti_act = None
    metas = None
    if tr.kind == "ideal":
        act = None
    elif tr.kind == "delay":
        delays = [s.transfer.delay for s in per_test]
        if len(set(delays)) == 1:
            act = delay_line = DelayLine(K, n_if, tr.delay, scene.dt)
        else:
            act = delay_line = PerTestDelayLine(K, n_if, delays, scene.dt)
            metas = [{**meta, "delay": d} for d in delays]
        meta["delay"] = tr.delay
    else:
        models = [_lti_model(s) for s in per_test]
        keys = [repr(m) for m in models]
        unique = dict(zip(keys, models, strict=True))
        meta_of = {k: {**meta, **_lti_meta(*m, scene.dt)} for k, m in unique.items()}
        meta = meta_of[keys[0]]
        if len(unique) == 1:
            num, den, delay = models[0]
            act = lti_act = LTIActuator(K, n_if, num, den, scene.dt)
            dline = DelayLine(K, n_if, delay, scene.dt) if delay > 0 else None
        else:
            metas = [meta_of[k] for k in keys]
            delays = [m[2] for m in models]
            act = lti_act = PerTestLTIActuator(K, n_if, [m[:2] for m in models], scene.dt)
            dline = PerTestDelayLine(K, n_if, delays, scene.dt) if max(delays) > 0 else None
        if dline is not None:
            delay_line = dline
            lti = act

            def act(u, _d=dline, _l=lti):
                return _l(_d(u))

            act.reset = lambda _d=dline, _l=lti: (_d.reset(), _l.reset())  # type: ignore
    comps = {(s.transfer.compensation, s.transfer.comp_time) for s in per_test}
    if len(comps) == 1:
        comp = Compensator(K, n_if, tr.compensation, tr.comp_time, scene.dt, tr.poly_order)
    else:
        # tests with and without velocity compensation, or with other τ_c (the loop's group key
        # admits only these mixes): one per-test τ_c, 0 where there is none
        kinds = {c for c, _ in comps}
        if not kinds <= set(PER_TEST_COMPENSATION):
            raise ValueError(f"transfer.compensation: tests stepped together mix {sorted(kinds)}")
        taus = [s.transfer.comp_time if s.transfer.compensation == "velocity" else 0.0
                for s in per_test]
        comp = Compensator(K, n_if, "velocity", taus, scene.dt)
    s = scene.sensor
    sensor = SensorModel(K, n_if, scene.dt, s.kind, s.time_constant, s.noise_std, s.gain,
                         s.offset, s.delay, sensor_seeds(scene, scenes, K))
    out = ActuatorTransfer(tr.kind, K, n_if, act, spec, comp, sensor, meta, metas)
    out.delay_line, out.lti = delay_line, lti_act  # the parts, for the single-test kernel
    return out


def _lti_model(scene: Scene) -> tuple[list[float], list[float], float]:
    """(num, den, pure delay) of the ``lti`` transfer system of ``scene``."""
    tr = scene.transfer
    if tr.num:
        return list(tr.num), list(tr.den), tr.delay
    # the platform's identified heave model with its transport delay (see
    # default_transport_delay): the 1-D analogue of the Stewart platform
    num, den = default_transfer_function()[:2]
    delay = default_transport_delay(scene.dt, tr.delay)
    # and with the scene's leg-servo lags in place of the identification run's
    return follow_servo_settings(num, den, delay, tr.timeconst, tr.velocity_ff, tr.kp, tr.kv,
                                 scene.dt)


def _lti_meta(num, den, delay: float, dt: float) -> dict:
    meta: dict = {"num": list(map(float, num)), "den": list(map(float, den)), "delay": delay}
    try:
        # low-frequency delay of z' behind z: G's group delay, the pure delay, and the
        # half-step lead of holding z_{n+1} over [t_n, t_{n+1}] — which only the dynamic
        # part of G sees: its feedthrough D (the share D/G(0) of the DC gain) reads z_{n+1}
        # at t_{n+1}, without a lead
        act = LTIActuator(1, 1, num, den, dt)
        share = act.Dd / act.dcgain if act.Dd else 0.0
        meta["predicted_delay"] = act.delay_estimate() + delay - (1.0 - share) * 0.5 * dt
    except (ValueError, ZeroDivisionError):
        meta["predicted_delay"] = math.nan
    return meta


__all__ = ["ActuatorTransfer", "SafetyStop", "StewartTransfer", "TransferSystem",
           "build_transfer"]
