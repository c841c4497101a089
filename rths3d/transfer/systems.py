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
from ..scene import ExperimentConfig, Scene
from .actuators import (
    Compensator,
    DelayLine,
    LTIActuator,
    SensorModel,
    default_transfer_function,
    default_transport_delay,
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
                 sensor, meta: dict | None = None):
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

    def __init__(self, scene: Scene, K: int, nthread: int = 0):
        from ..experiment.mjcf import payload_xml, world_xml
        from ..platform.model import ActuatorConfig, PlatformConfig, predicted_delay

        tr = scene.transfer
        self.name = "stewart"
        self.K, self.n_if = K, len(scene.dofs)
        cfg = PlatformConfig(
            actuator=ActuatorConfig(kp=tr.kp, kv=tr.kv, timeconst=tr.timeconst,
                                    delay=tr.delay, velocity_ff=tr.velocity_ff),
            dt=scene.dt, substeps=tr.substeps)
        self.config = cfg
        g = cfg.geometry
        site = (0.0, 0.0, g.home_height + g.fts_height)
        pxml = payload_xml(scene.experiment)
        wxml = world_xml(scene.experiment, site)
        self.idx = [DOFS.index(d) for d in scene.dofs]
        self.compensator = Compensator(K, self.n_if, tr.compensation, tr.comp_time, scene.dt,
                                       tr.poly_order)
        s = scene.sensor
        self.sensor = SensorModel(K, self.n_if, scene.dt, s.kind, s.time_constant, s.noise_std,
                                  s.gain, s.offset, s.delay, s.seed)
        self.single = K == 1
        if self.single:
            from ..platform.sim import PlatformSim

            self.sim = PlatformSim(cfg, pxml, wxml)
        else:
            from ..platform.sim import PlatformBatch

            self.sim = PlatformBatch(cfg, nsim=K, nthread=nthread or 2, payload_xml=pxml,
                                     world_xml=wxml)
        self.pose_cmd = np.zeros((K, 6))
        self.pose_meas = np.zeros((K, 6))
        self.z_meas = np.zeros((K, self.n_if))
        self.f_meas = np.zeros((K, self.n_if))
        self.stopped = np.zeros(K, dtype=bool)
        self.reasons = [""] * K
        self.meta = {"predicted_delay": predicted_delay(cfg, 1.0), "kp": tr.kp, "kv": tr.kv,
                     "timeconst": tr.timeconst, "actuator_delay": tr.delay,
                     "velocity_ff": tr.velocity_ff, "substeps": tr.substeps}

    @property
    def model(self):
        return self.sim.model

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
            self.pose_meas[0] = self.sim.pose
            w = np.asarray(self.sim.interface_wrench)
            f = w[self.idx][None, :]
        else:
            self.sim.step(self.pose_cmd)
            self.pose_meas[:] = self.sim.pose
            f = self.sim.interface_wrench[:, self.idx]
            if self.sim.stopped.any():
                self.stopped[:] = self.sim.stopped
                self.reasons = list(self.sim.reasons)
        self.z_meas[:] = self.pose_meas[:, self.idx]
        self.f_meas[:] = self.sensor(f)


def build_transfer(scene: Scene, K: int, experiments: Sequence[ExperimentConfig] | None = None,
                   nthread: int = 0, specimen: str = "auto") -> TransferSystem:
    """The transfer system of ``scene`` for K tests.

    ``experiments``: per-test :class:`~rths3d.scene.ExperimentConfig` (default: the scene's).
    ``specimen``: ``numpy`` (the vectorised 1-D model), ``mujoco`` or ``auto`` (numpy for
    1-D parts, MuJoCo for the multi-DOF part).
    """
    tr = scene.transfer
    if tr.kind == "stewart":
        return StewartTransfer(scene, K, nthread)
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
    delay_line = lti_act = None
    if tr.kind == "ideal":
        act = None
    elif tr.kind == "delay":
        act = delay_line = DelayLine(K, n_if, tr.delay, scene.dt)
        meta["delay"] = tr.delay
    else:
        if tr.num:
            num, den = tr.num, tr.den
            delay = tr.delay
        else:
            # the platform's identified heave model with its transport delay (see
            # default_transport_delay): the 1-D analogue of the Stewart platform
            num, den = default_transfer_function()[:2]
            delay = default_transport_delay(scene.dt, tr.delay)
        act = lti_act = LTIActuator(K, n_if, num, den, scene.dt)
        if delay > 0:
            dline = delay_line = DelayLine(K, n_if, delay, scene.dt)
            lti = act

            def act(u, _d=dline, _l=lti):
                return _l(_d(u))

            act.reset = lambda _d=dline, _l=lti: (_d.reset(), _l.reset())  # type: ignore
        meta.update(num=list(map(float, num)), den=list(map(float, den)), delay=delay)
        try:
            # low-frequency delay of z' behind z: G's group delay, the pure delay, and the
            # half-step lead of holding z_{n+1} over [t_n, t_{n+1}]
            meta["predicted_delay"] = LTIActuator(1, 1, num, den, scene.dt).delay_estimate() \
                + delay - 0.5 * scene.dt
        except (ValueError, ZeroDivisionError):
            meta["predicted_delay"] = math.nan
    comp = Compensator(K, n_if, tr.compensation, tr.comp_time, scene.dt, tr.poly_order)
    s = scene.sensor
    sensor = SensorModel(K, n_if, scene.dt, s.kind, s.time_constant, s.noise_std, s.gain,
                         s.offset, s.delay, s.seed)
    out = ActuatorTransfer(tr.kind, K, n_if, act, spec, comp, sensor, meta)
    out.delay_line, out.lti = delay_line, lti_act  # the parts, for the single-test kernel
    return out


__all__ = ["ActuatorTransfer", "SafetyStop", "StewartTransfer", "TransferSystem",
           "build_transfer"]
