"""The Stewart-platform model of a bench for diagnosis (heave replay, six legs).

The platform of :mod:`rths3d.platform` (``build_spec``: six position-servo legs on universal
joints, plate on a free joint, force-torque sensor ``fts``) carries the specimen of paper
Fig. 4 (a fixture, then a mass ``m_exp`` on a spring ``k_exp`` / damper ``c_exp``) with a
world-fixed contact surface ``h0`` above it. The measured command ``z_cmd.z`` is replayed
open-loop as a heave pose: inverse kinematics → leg set-points + gravity compensation
(nominal model) + velocity feed-forward, interpolated between samples, through
``mujoco.rollout``. Outputs: ``z_meas.z``, ``f_meas.z``, ``f_meas.x`` and
``leg_force.0`` … ``leg_force.5`` (tared), plus ``contact`` (N).

The same effects as on the 1-D bench apply: friction and compliance act on all six legs.
"""

from __future__ import annotations

import math

import numpy as np

from ..effects.library import FX, FZ, Z
from ..errors import RthsError, SafetyStop
from .bench import BenchConfig, BenchModel, EffectValues, split_effects


class StewartBenchModel(BenchModel):
    """Open-loop heave replay through the MuJoCo Stewart platform with effects.

    Parameters
    ----------
    cfg:
        Specimen, fixture and contact parameters (``m_fts`` is the fixture on the sensor,
        ``m_exp``, ``k_exp``, ``c_exp``, ``h0``, ``k_contact``); the plate and servo values of
        :class:`BenchConfig` are not used — those come from ``platform``.
    platform:
        :class:`rths3d.platform.model.PlatformConfig` (default: the package default, with
        ``dt`` set to the record's sample interval).
    """

    def __init__(self, cfg: BenchConfig | None = None, dt: float = 1e-3, platform=None):
        import dataclasses

        import mujoco

        from ..platform.model import PlatformConfig

        self.cfg = cfg or BenchConfig()
        self.dt = float(dt)
        pc = platform or PlatformConfig()
        if abs(pc.dt - self.dt) > 1e-12:
            pc = dataclasses.replace(pc, dt=self.dt)
        self.platform = pc
        self.substeps = int(pc.substeps)
        self._mujoco = mujoco
        self._cache = {}
        self._data = None
        self.nsim = 0
        a = pc.actuator
        self.leg_joints = tuple(f"leg{i}_slide" for i in range(6))
        self.leg_actuators = tuple(f"leg{i}" for i in range(6))
        self.kp = float(a.kp)
        self.physics_step = float(pc.timestep)
        self.fixture_geom = "fixture_geom"
        self.m_fixture = self.cfg.m_fts
        self.specimen_joint = "spec_z"
        self.specimen_geom = "mass_geom"
        self.m_exp = self.cfg.m_exp
        self.k_exp = self.cfg.k_exp
        self.c_exp = self.cfg.c_exp
        self.wall_geom = "wall"
        self.channels = (Z, FZ, FX, *(f"leg_force.{i}" for i in range(6)))
        g = pc.geometry
        self._home_h = float(g.home_height)
        self._home_L = np.asarray(g.home_leg_lengths(), dtype=float)
        self._ff = (a.kv / a.kp) if a.velocity_ff else 0.0
        nominal = self.model({})
        self._offsets = self._static(nominal).offsets if a.gravity_comp else np.zeros(6)
        # displacement is measured from the settled nominal home pose, as a bench zeroes it
        self._home_h += float(self.simulate(np.zeros(4), {})[Z][0])
        self._cache.clear()
        self.nsim = 0

    # ------------------------------------------------------------------ model building
    def _fragments(self) -> tuple[str, str]:
        c = self.cfg
        sag = c.m_exp * 9.81 / c.k_exp
        payload = f"""
          <body name="fixture">
            <geom name="fixture_geom" type="cylinder" size="0.03 0.005" pos="0 0 0.005"
                  mass="{c.m_fts}"/>
            <body name="mass" pos="0 0 {0.05 + sag}">
              <joint name="spec_z" type="slide" axis="0 0 1" stiffness="{c.k_exp}"
                     damping="{c.c_exp}"/>
              <geom name="mass_geom" type="sphere" size="0.02" mass="{c.m_exp}"
                    contype="1" conaffinity="0"/>
              <site name="touch" type="sphere" size="0.0205"/>
            </body>
          </body>"""
        g = self.platform.geometry
        wall_z = g.home_height + g.fts_height + 0.05 + 0.02 + c.h0 + 0.005
        world = f"""
    <geom name="wall" type="box" size="0.1 0.1 0.005" pos="0 0 {wall_z}" contype="0"
          conaffinity="1" solref="{-c.k_contact} {-2.0 * math.sqrt(c.k_contact)}"
          solimp="0.99 0.99 0.001"/>"""
        return payload, world

    def spec(self, effects: EffectValues | None = None):
        """The platform + specimen ``MjSpec`` with the spec-stage effects and the sensors the
        diagnosis reads (plate position, six actuator forces, contact)."""
        import mujoco

        from ..platform.model import build_spec

        payload, world = self._fragments()
        spec = build_spec(self.platform, payload, world)
        spec.add_sensor(name="plate_pos", type=mujoco.mjtSensor.mjSENS_FRAMEPOS,
                        objtype=mujoco.mjtObj.mjOBJ_BODY, objname="plate")
        for i in range(6):
            spec.add_sensor(name=f"leg{i}_f", type=mujoco.mjtSensor.mjSENS_ACTUATORFRC,
                            objtype=mujoco.mjtObj.mjOBJ_ACTUATOR, objname=f"leg{i}")
        spec.add_sensor(name="contact", type=mujoco.mjtSensor.mjSENS_TOUCH,
                        objtype=mujoco.mjtObj.mjOBJ_SITE, objname="touch")
        for eff, value in split_effects(effects or {})["spec"]:
            eff.apply_spec(spec, value, self)
        return spec

    def _static(self, model):
        from ..platform.sim import static_state

        data = self._mujoco.MjData(model)
        data.qpos[model.jnt_qposadr[model.joint("spec_z").id]] = _specimen_sag(model)
        return static_state(self.platform, model, data)

    def _initial_state(self, model, u0=None) -> np.ndarray:
        mj = self._mujoco
        data = mj.MjData(model)
        jq = model.jnt_qposadr[model.joint("spec_z").id]
        data.qpos[jq] = _specimen_sag(model)
        acts = [model.actuator(n).id for n in self.leg_actuators]
        for i, a in enumerate(acts):
            data.ctrl[a] = self._offsets[i]
            adr = model.actuator_actadr[a]
            if adr >= 0:
                data.act[adr] = self._offsets[i]
            if model.actuator_history[a, 0] > 0:
                n = int(model.actuator_history[a, 0])
                mj.mj_initCtrlHistory(model, data, int(a), None,
                                      np.full((n, 1), self._offsets[i]))
        # settle at home: the chain and the specimen come to rest before the test
        mj.mj_step(model, data, int(round(0.1 / model.opt.timestep)))
        data.time = 0.0
        state = np.empty(mj.mj_stateSize(model, mj.mjtState.mjSTATE_FULLPHYSICS))
        mj.mj_getState(model, data, state, mj.mjtState.mjSTATE_FULLPHYSICS)
        return state

    # ------------------------------------------------------------------ simulation
    def _prepare(self, z_cmd: np.ndarray, effects: EffectValues | None):
        from ..platform.kinematics import inverse_kinematics

        model = self.model(effects)
        u = self.command_chain(z_cmd, effects)
        poses = np.zeros((u.size, 6))
        poses[:, 2] = u
        legs = inverse_kinematics(self.platform.geometry, poses) - self._home_L
        ctrl = legs + self._ff * np.gradient(legs, self.dt, axis=0) + self._offsets
        ns = self.substeps
        t_sub = np.arange(u.size * ns) / ns
        grid = np.arange(u.size)
        control = np.column_stack([np.interp(t_sub, grid, ctrl[:, i]) for i in range(6)])
        full = np.zeros((control.shape[0], model.nu))
        full[:, [model.actuator(n).id for n in self.leg_actuators]] = control
        return model, full, self._initial_state(model)

    def _finish(self, model, sens: np.ndarray) -> dict[str, np.ndarray]:
        s = sens[:: self.substeps]
        self.nsim += 1
        adr = {n: int(model.sensor_adr[model.sensor(n).id]) for n in
               ("fts_force", "plate_pos", "leg0_f", "contact")}
        w_fts = float(model.body_subtreemass[model.body("fts_body").id]) * 9.81
        legs0 = self._static(model).leg_forces
        out = {Z: s[:, adr["plate_pos"] + 2] - self._home_h,
               FX: s[:, adr["fts_force"]].copy(),
               FZ: s[:, adr["fts_force"] + 2] - w_fts}
        for i in range(6):
            out[f"leg_force.{i}"] = s[:, adr["leg0_f"] + i] - legs0[i]
        out["contact"] = s[:, adr["contact"]].copy()
        if np.any(~np.isfinite(s)) or np.max(np.abs(out[Z])) > 1.0:
            bad = int(np.argmax(~np.isfinite(s).all(axis=1) | (np.abs(out[Z]) > 1.0)))
            raise SafetyStop("Stewart replay divergence", float(np.nanmax(np.abs(out[Z]))), 1.0,
                             bad * self.dt, unit="m")
        return out

    def as_meta(self) -> dict:
        meta = super().as_meta()
        meta["model"] = "stewart"
        return meta


def _specimen_sag(model) -> float:
    """Static deflection of the specimen spring under the specimen's weight (m, negative)."""
    k = float(model.jnt_stiffness[model.joint("spec_z").id])
    return -float(model.body_mass[model.body("mass").id]) * 9.81 / k


def make_model(cfg: BenchConfig | None, dt: float, kind: str = "bench") -> BenchModel:
    """The bench model named ``kind``: ``"bench"`` (1-D heave bench) or ``"stewart"``."""
    if kind == "stewart":
        return StewartBenchModel(cfg, dt)
    if kind == "bench":
        return BenchModel(cfg, dt)
    raise RthsError(f"bench model {kind!r}: use 'bench' or 'stewart'")
