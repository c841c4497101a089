"""The model of a bench for diagnosis: transfer system + force sensor + specimen in MuJoCo.

Heave (z) model of the loop of paper Fig. 4 mirrored onto the platform: a top plate of mass
``m_plate`` on a slide joint, driven by a position servo (``kp``, ``kv``; MuJoCo ``position``
actuator) with velocity feed-forward (``kv/kp``·ż) and gravity compensation; above it the
force-torque sensor (site ``fts`` on the welded body ``ft_body`` of mass ``m_fts``), and the
experimental part: a mass ``m_exp`` on a spring ``k_exp`` / damper ``c_exp`` with a
world-fixed contact surface ``h0`` above the mass at equilibrium.

:class:`BenchModel` replays measured commands open-loop (``mujoco.rollout``) with any set of
effects from :mod:`rths3d.effects` and returns the output channels of
:data:`rths3d.effects.OUTPUTS` plus ``contact`` (N, contact force on the specimen).
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from ..effects.base import STAGES, get_effect
from ..effects.library import FX, FZ, LEG, Z
from ..errors import ConfigError, RthsError

G = 9.81
"""Gravitational acceleration (m/s²)."""


@dataclass(frozen=True)
class BenchConfig:
    """Nominal parameters of the bench model (SI units).

    Attributes: ``m_plate`` (kg) moving mass of plate and legs; ``kp`` (N/m), ``kv`` (N·s/m)
    servo gains; ``m_fts`` (kg) sensor top and known adapter; ``m_exp`` (kg), ``k_exp`` (N/m),
    ``c_exp`` (N·s/m) specimen; ``h0`` (m) gap to the contact surface; ``k_contact`` (1/s²)
    mass-normalised contact stiffness; ``timestep`` (s) physics step; ``substeps`` per sample.
    """

    m_plate: float = 5.0
    kp: float = 2.0e6
    kv: float = 5.0e3
    m_fts: float = 0.5
    m_exp: float = 2.0
    k_exp: float = 1.2e4
    c_exp: float = 15.0
    h0: float = 3.0e-3
    k_contact: float = 1.0e5
    timestep: float = 5e-4
    substeps: int = 2

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name == "h0":
                ok = v >= 0
            else:
                ok = v > 0
            if not (isinstance(v, int | float) and math.isfinite(v) and ok):
                raise ConfigError(f"bench.{f.name}", v, "must be a finite number > 0"
                                  if f.name != "h0" else "must be ≥ 0 m")

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any], source: str = "bench") -> BenchConfig:
        """Build from a mapping; unknown keys are an error naming the key."""
        names = {f.name for f in fields(cls)}
        for k in data:
            if k not in names:
                raise ConfigError(f"{source}.{k}", data[k],
                                  "unknown bench parameter; known: " + ", ".join(sorted(names)))
        return cls(**{k: (int(v) if k == "substeps" else float(v)) for k, v in data.items()})


MODEL_KINDS: tuple[str, ...] = ("bench", "stewart")
"""Bench model backends: the 1-D heave bench and the six-leg Stewart platform."""


def resolve_scene(scene: str | Path | None, meta: Mapping[str, Any] | None = None
                  ) -> tuple[BenchConfig, str]:
    """Bench parameters and model kind for ``--scene``: ``"bench"`` or ``"stewart"`` (the
    record's ``meta['bench']`` parameters if present, else the defaults), a TOML file with
    a ``[bench]`` table (optional key ``model = "bench" | "stewart"``), or a vRTHS scene
    (name or TOML path, see :func:`from_loop_scene`)."""
    name = "" if scene is None else str(scene)
    path = Path(name)
    is_bench_toml = False
    if name.endswith(".toml") and path.exists():
        try:
            is_bench_toml = "bench" in tomllib.loads(path.read_text())
        except tomllib.TOMLDecodeError as exc:
            raise ConfigError("scene", name, f"not valid TOML: {exc}") from None
    if name not in ("", "bench", "default", "stewart") and not is_bench_toml:
        return from_loop_scene(name)
    if name in ("", "bench", "default", "stewart"):
        table = dict(meta["bench"]) if meta and isinstance(meta.get("bench"), Mapping) else {}
        kind = name if name in MODEL_KINDS else str(table.get("model", "bench"))
        table.pop("model", None)
        source = "meta.bench"
    else:
        path = Path(name)
        if not path.exists():
            raise ConfigError("scene", name, "use 'bench', 'stewart' or a TOML file with a "
                              "[bench] table")
        try:
            data = tomllib.loads(path.read_text())
        except tomllib.TOMLDecodeError as exc:
            raise ConfigError("scene", name, f"not valid TOML: {exc}") from None
        table = data.get("bench")
        if not isinstance(table, Mapping):
            raise ConfigError(f"{path.name}: bench", None, "a [bench] table is required")
        table = dict(table)
        kind = str(table.pop("model", "bench"))
        source = f"{path.name}: bench"
    if kind not in MODEL_KINDS:
        raise ConfigError(f"{source}.model", kind, "must be one of " + ", ".join(MODEL_KINDS))
    return BenchConfig.from_mapping(table, source), kind


def from_loop_scene(scene: str | Path) -> tuple[BenchConfig, str]:
    """Bench parameters from a vRTHS scene (``rths3d.scene``, a name in ``scenes/`` or a TOML
    path) with a single-DOF ``contact`` experiment: specimen ``m``, ``k``, ``d``, ``h0``,
    ``k_contact`` (N/m, converted to the mass-normalised 1/s² of the bench) and the servo
    ``kp``, ``kv`` of its transfer system; a ``stewart`` transfer selects the Stewart model."""
    from ..scene import load_scene

    sc = load_scene(scene)
    exp = sc.experiment
    if exp.kind != "contact":
        raise ConfigError(f"{sc.name}: experiment.kind", exp.kind,
                          "the diagnosis models a 'contact' specimen (heave)")
    tr = sc.transfer
    cfg = BenchConfig(m_exp=exp.m, k_exp=exp.k, c_exp=max(exp.d, 1e-6), h0=exp.h0,
                      k_contact=exp.k_contact / exp.m, kp=tr.kp, kv=tr.kv)
    return cfg, "stewart" if tr.kind == "stewart" else "bench"


def load_bench(scene: str | Path | None, meta: Mapping[str, Any] | None = None) -> BenchConfig:
    """The bench parameters of :func:`resolve_scene` (without the model kind)."""
    return resolve_scene(scene, meta)[0]


def bench_mjcf(cfg: BenchConfig) -> str:
    """MJCF text of the nominal bench (all effects off).

    Semi-implicit Euler on purpose: with ``implicitfast`` the sampled sensor force of a 2 Hz
    heave came out 8 % above m·z̈ (the sensor sees the explicit acceleration while the state
    advances implicitly in the large servo damping); with Euler it is within 0.5 %."""
    sag = cfg.m_exp * G / cfg.k_exp
    wall_z = 0.06 + 0.02 + cfg.h0 + 0.005  # mass centre at rest + sphere radius + gap + half wall
    return f"""
<mujoco model="rths3d_bench">
  <option timestep="{cfg.timestep}" integrator="Euler" gravity="0 0 {-G}"/>
  <worldbody>
    <body name="plate">
      <joint name="plate_z" type="slide" axis="0 0 1" solreffriction="0.001 1"/>
      <geom name="plate_geom" type="box" size="0.1 0.1 0.01" mass="{cfg.m_plate}"
            contype="0" conaffinity="0"/>
      <body name="ft_body" pos="0 0 0.02">
        <geom name="ft_geom" type="cylinder" size="0.03 0.01" mass="{cfg.m_fts}"
              contype="0" conaffinity="0"/>
        <site name="fts" size="0.005"/>
        <body name="mass" pos="0 0 {0.04 + sag}">
          <joint name="spec_z" type="slide" axis="0 0 1" stiffness="{cfg.k_exp}"
                 damping="{cfg.c_exp}"/>
          <geom name="mass_geom" type="sphere" size="0.02" mass="{cfg.m_exp}"
                contype="1" conaffinity="0"/>
          <site name="touch" type="sphere" size="0.0205"/>
        </body>
      </body>
    </body>
    <geom name="wall" type="box" size="0.1 0.1 0.005" pos="0 0 {wall_z}" contype="0"
          conaffinity="1" solref="{-cfg.k_contact} {-2.0 * math.sqrt(cfg.k_contact)}"
          solimp="0.99 0.99 0.001"/>
  </worldbody>
  <actuator>
    <position name="leg" joint="plate_z" kp="{cfg.kp}" kv="{cfg.kv}" ctrlrange="-1 1"/>
  </actuator>
  <sensor>
    <jointpos name="z" joint="plate_z"/>
    <force name="fts_f" site="fts"/>
    <actuatorfrc name="leg_f" actuator="leg"/>
    <touch name="contact" site="touch"/>
  </sensor>
</mujoco>
"""


EffectValues = Mapping[str, float]
"""Effect name → parameter value (SI unit of the effect's parameter)."""


def split_effects(effects: EffectValues) -> dict[str, list[tuple[Any, float]]]:
    """Effects that are on, grouped by stage in library order."""
    by_stage: dict[str, list[tuple[Any, float]]] = {s: [] for s in STAGES}
    for name, value in effects.items():
        eff = get_effect(name)
        if not eff.is_off(value):
            by_stage[eff.stage].append((eff, float(value)))
    # command effects act in a fixed physical order: rate limit in the controller, then play
    by_stage["command"].sort(key=lambda ev: ev[0].name != "velocity_saturation")
    return by_stage


class BenchModel:
    """Open-loop replay of commands through the bench with effects.

    ``simulate(z_cmd, effects)`` runs the physics (command and spec stages);
    ``outputs(sim, effects)`` applies the signal stages to a simulation result without
    re-simulating; ``replay`` does both. Simulations are cached by their physics effects.
    """

    def __init__(self, cfg: BenchConfig | None = None, dt: float = 1e-3):
        import mujoco

        self.cfg = cfg or BenchConfig()
        self.dt = float(dt)
        n_sub = self.dt / self.cfg.timestep
        if abs(n_sub - round(n_sub)) > 1e-6 or round(n_sub) < 1:
            raise ConfigError("record dt", dt, f"must be a multiple of the physics step "
                              f"{self.cfg.timestep:g} s")
        self.substeps = int(round(n_sub))
        self._mujoco = mujoco
        self._xml = bench_mjcf(self.cfg)
        self._cache: dict[tuple, dict[str, np.ndarray]] = {}
        self._data = None
        self.nsim = 0
        """Number of physics simulations run (for benchmarks and tests)."""
        # element names and nominal values the spec-stage effects address
        self.channels: tuple[str, ...] = (Z, FZ, FX, LEG)
        """Output channels this model produces."""
        self.leg_joints = ("plate_z",)
        self.leg_actuators = ("leg",)
        self.kp = self.cfg.kp
        self.physics_step = self.cfg.timestep
        self.fixture_geom = "ft_geom"
        self.m_fixture = self.cfg.m_fts
        self.specimen_joint = "spec_z"
        self.specimen_geom = "mass_geom"
        self.m_exp = self.cfg.m_exp
        self.k_exp = self.cfg.k_exp
        self.c_exp = self.cfg.c_exp
        self.wall_geom = "wall"

    # ------------------------------------------------------------------ model building
    def spec(self, effects: EffectValues | None = None):
        """The bench ``MjSpec`` with the spec-stage effects applied."""
        spec = self._mujoco.MjSpec.from_string(self._xml)
        for eff, value in split_effects(effects or {})["spec"]:
            eff.apply_spec(spec, value, self)
        return spec

    def model(self, effects: EffectValues | None = None):
        """Compiled ``MjModel`` with the spec-stage effects applied."""
        return self.spec(effects).compile()

    def command_chain(self, z_cmd: np.ndarray, effects: EffectValues | None = None) -> np.ndarray:
        """Set-point after the command-stage effects (m)."""
        z = np.asarray(z_cmd, dtype=float)
        for eff, value in split_effects(effects or {})["command"]:
            z = eff.apply_command(z, self.dt, value)
        return z

    def _initial_state(self, model, u0: float) -> np.ndarray:
        mj = self._mujoco
        data = mj.MjData(model)
        kp = float(model.actuator_gainprm[0, 0])
        w_total = float(model.body_subtreemass[model.body("plate").id]) * G
        data.qpos[0] = u0 - w_total / kp
        k = float(model.jnt_stiffness[1])
        data.qpos[1] = -float(model.body_mass[model.body("mass").id]) * G / k
        mj.mj_forward(model, data)
        state = np.empty(mj.mj_stateSize(model, mj.mjtState.mjSTATE_FULLPHYSICS))
        mj.mj_getState(model, data, state, mj.mjtState.mjSTATE_FULLPHYSICS)
        return state

    # ------------------------------------------------------------------ simulation
    def physics_key(self, effects: EffectValues | None) -> tuple:
        by = split_effects(effects or {})
        return tuple((e.name, v) for s in ("command", "spec") for e, v in by[s])

    def _key(self, z_cmd: np.ndarray, effects: EffectValues | None) -> tuple:
        return self.physics_key(effects) + (hash(z_cmd.tobytes()), len(z_cmd))

    def _prepare(self, z_cmd: np.ndarray, effects: EffectValues | None):
        model = self.model(effects)
        cfg = self.cfg
        u = self.command_chain(z_cmd, effects)
        # velocity feed-forward removes the kv/kp lag; gravity compensation the static sag;
        # both use the nominal model (what the bench controller knows)
        w_nom = (cfg.m_plate + cfg.m_fts + cfg.m_exp) * G
        ctrl = u + (cfg.kv / cfg.kp) * np.gradient(u, self.dt) + w_nom / cfg.kp
        # first-order hold between samples, as a servo interpolating its set-points: a
        # staircase would excite the plate at every sample and bias the sampled forces
        ns = self.substeps
        t_sub = np.arange(ctrl.size * ns) / ns
        control = np.interp(t_sub, np.arange(ctrl.size), ctrl)[:, None]
        state0 = self._initial_state(model, float(u[0]) + w_nom / cfg.kp)
        return model, control, state0

    def _finish(self, model, sens: np.ndarray) -> dict[str, np.ndarray]:
        s = sens[:: self.substeps]
        self.nsim += 1
        w_fts = float(model.body_subtreemass[model.body("ft_body").id]) * G
        w_all = float(model.body_subtreemass[model.body("plate").id]) * G
        out = {
            Z: s[:, 0].copy(),
            FX: s[:, 1].copy(),
            FZ: s[:, 3] - w_fts,
            LEG: s[:, 4] - w_all,
            "contact": s[:, 5].copy(),
        }
        if np.any(~np.isfinite(s)) or np.max(np.abs(out[Z])) > 1.0:
            from ..errors import SafetyStop

            bad = int(np.argmax(~np.isfinite(s).all(axis=1) | (np.abs(s[:, 0]) > 1.0)))
            raise SafetyStop("bench replay divergence", float(np.nanmax(np.abs(s[:, 0]))), 1.0,
                             bad * self.dt, unit="m")
        return out

    def _store(self, key: tuple, out: dict[str, np.ndarray]) -> None:
        if len(self._cache) > 256:
            self._cache.clear()
        self._cache[key] = out

    def simulate(self, z_cmd: np.ndarray, effects: EffectValues | None = None
                 ) -> dict[str, np.ndarray]:
        """Replay ``z_cmd`` (m, sampled at ``dt``) through the physics; raw outputs (tared)."""
        z_cmd = np.ascontiguousarray(z_cmd, dtype=float)
        key = self._key(z_cmd, effects)
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        from mujoco import rollout

        model, control, state0 = self._prepare(z_cmd, effects)
        if self._data is None:
            self._data = self._mujoco.MjData(model)
        _, sens = rollout.rollout(model, self._data, state0[None, :], control[None])
        out = self._finish(model, sens[0])
        self._store(key, out)
        return out

    def simulate_many(self, z_cmd: np.ndarray, effect_sets: list[EffectValues],
                      nthread: int = 2) -> list[dict[str, np.ndarray] | Exception]:
        """Simulate several effect sets at once: one batched ``mujoco.rollout`` call on
        ``nthread`` threads (per-simulation models, controls and initial states). Results are
        cached like :meth:`simulate`; a diverged simulation gives its SafetyStop in place."""
        from mujoco import rollout

        z_cmd = np.ascontiguousarray(z_cmd, dtype=float)
        keys = [self._key(z_cmd, e) for e in effect_sets]
        todo = [i for i, k in enumerate(keys) if k not in self._cache]
        todo = list({keys[i]: i for i in todo}.values())
        if len(todo) == 1:
            self.simulate(z_cmd, effect_sets[todo[0]])
        elif todo:
            prep = [self._prepare(z_cmd, effect_sets[i]) for i in todo]
            models = [p[0] for p in prep]
            datas = [self._mujoco.MjData(models[0]) for _ in range(max(1, nthread))]
            _, sens = rollout.rollout(models, datas, np.stack([p[2] for p in prep]),
                                      np.stack([p[1] for p in prep]))
            for j, i in enumerate(todo):
                try:
                    self._store(keys[i], self._finish(models[j], sens[j]))
                except RthsError:
                    pass  # re-simulated alone below, which raises it in place
        results: list[dict[str, np.ndarray] | Exception] = []
        for i, k in enumerate(keys):
            if k in self._cache:
                results.append(self._cache[k])
            else:
                try:
                    results.append(self.simulate(z_cmd, effect_sets[i]))
                except RthsError as exc:
                    results.append(exc)
        return results

    def outputs(self, sim: Mapping[str, np.ndarray], effects: EffectValues | None = None,
                rng: np.random.Generator | None = None) -> dict[str, np.ndarray]:
        """Apply the signal-stage effects (no re-simulation) to a simulation result."""
        out = {k: np.array(v, dtype=float) for k, v in sim.items()}
        by = split_effects(effects or {})
        for stage in STAGES[2:]:
            for eff, value in by[stage]:
                eff.apply_output(out, self.dt, value, rng)
        return out

    def replay(self, z_cmd: np.ndarray, effects: EffectValues | None = None,
               rng: np.random.Generator | None = None) -> dict[str, np.ndarray]:
        """Simulate and apply all effects: the model's version of every output channel."""
        return self.outputs(self.simulate(z_cmd, effects), effects, rng)

    def as_meta(self) -> dict[str, Any]:
        """The nominal parameters, for record metadata (``meta['bench']``)."""
        return asdict(self.cfg)
