"""The bench: one model of a Stewart-platform test bench for the loop, the replay and the
diagnosis.

A :class:`Bench` is the platform as its controller knows it (``platform``: geometry, leg
servos, interface step, physics substeps and integrator), the part mounted on its six-axis
force-torque sensor (``part``) and the list of physical effects that make the real bench
differ from that nominal model (``effects``, :mod:`rths3d.effects`). It builds

- the *truth*: the MuJoCo model with the spec-stage effects applied and the true geometry
  (anchors and encoder offsets moved by the geometry effects), :meth:`Bench.model`;
- the *nominal* model the controller computes its gravity compensation on,
  :meth:`Bench.nominal_model`;
- the controller's per-leg set-point blocks (delay, lag, rate limit, play), the encoder bias
  of the true geometry, the gravity-compensation scale and the FTS calibration, which
  :func:`platform_batch` hands to :class:`~rths3d.platform.sim.PlatformBatch` for K benches
  stepped together;
- the measured-force chain's extra blocks (``fts_lowpass``) and the measurement noise level.

The vRTHS loop's Stewart transfer system (:mod:`rths3d.transfer.stewart`), the diagnosis'
replay (:mod:`rths3d.bench.replay`) and synthetic measurements all step the bench through
:func:`platform_batch`: one controller, one set of defaults (the scene's ``[transfer]``
table), one timing and zeroing convention (:mod:`rths3d.platform.sim`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from ..config import EffectConfig, ExperimentConfig, Scene
from ..effects.base import REGISTRY, STAGES, Effect, get_effect
from ..experiment import make_part
from ..kernels import Block
from ..platform.calibrate.kinematic import CalibratedGeometry
from ..platform.geometry import DEFAULT_GEOMETRY, StewartGeometry
from ..platform.model import ActuatorConfig, PlatformConfig, build_spec

__all__ = ["Bench", "platform_batch", "platform_config", "setpoint_structure"]


def platform_config(scene: Scene, substeps: int | None = None) -> PlatformConfig:
    """The controller's platform configuration of a scene: the ``[platform]`` table (geometry,
    limits, masses, FTS pose; today's platform by default), the leg servo (``transfer.*`` /
    ``[controller]`` gains, lag, delay) and the controller's conventions (``[controller]``
    hold, sample, feed-forward, gravity compensation); ``substeps`` overrides the scene's
    physics substeps."""
    t, c, p = scene.transfer, scene.controller, scene.platform
    act = ActuatorConfig(kp=t.kp, kv=t.kv, timeconst=t.timeconst, delay=t.delay,
                         velocity_ff=t.velocity_ff and c.feedforward != "none",
                         gravity_comp=c.gravity != "none",
                         gravity_source="measured" if c.gravity == "measured" else "nominal",
                         hold=c.hold, sample=c.sample,
                         feedforward=c.feedforward, lag=c.lag, valve_hz=t.valve_hz,
                         valve_damping=t.valve_damping)
    return PlatformConfig(geometry=p.geometry if p.geometry is not None else DEFAULT_GEOMETRY,
                          actuator=act, dt=scene.dt,
                          substeps=t.substeps if substeps is None else substeps,
                          integrator=t.integrator, fts_pose=p.fts_pose,
                          plate_inertia=p.plate_inertia, plate_com=p.plate_com)


def _on(effects: Iterable[EffectConfig]) -> list[tuple[Effect, EffectConfig]]:
    """Effects that are on, in stage order (then as declared)."""
    out = [(get_effect(e.name), e) for e in effects]
    out = [(eff, e) for eff, e in out if not eff.is_off(e.value)]
    return sorted(out, key=lambda p: (STAGES.index(p[0].stage), p[0].late))


@dataclass(frozen=True)
class Bench:
    """A Stewart-platform bench (see the module docstring). SI units.

    Attributes
    ----------
    platform:
        The platform as the controller knows it (nominal geometry, leg servos, ΔT,
        substeps, integrator).
    part:
        The experimental part on the FTS (:class:`~rths3d.config.ExperimentConfig`).
    effects:
        The physical effects of the real bench (``[[effect]]`` tables of a scene).
    geometry:
        The true geometry when it is known as a whole (e.g. a
        :class:`~rths3d.platform.calibrate.kinematic.CalibratedGeometry` from a calibration);
        ``None``: the nominal one. Geometry effects move it further.
    """

    platform: PlatformConfig = field(default_factory=PlatformConfig)
    part: ExperimentConfig = field(default_factory=ExperimentConfig)
    effects: tuple[EffectConfig, ...] = ()
    geometry: StewartGeometry | None = None

    @classmethod
    def from_scene(cls, scene: Scene, *, substeps: int | None = None,
                   effects: Sequence[EffectConfig] | None = None) -> Bench:
        """The bench of a scene: its leg servos, part and ``[[effect]]`` tables."""
        return cls(platform_config(scene, substeps), scene.experiment,
                   tuple(scene.effects if effects is None else effects))

    def with_effects(self, effects: Iterable[EffectConfig]) -> Bench:
        """The same bench with another list of effects."""
        return dataclasses.replace(self, effects=tuple(effects))

    # ------------------------------------------------------------------ nominal values
    @property
    def kp(self) -> float:
        """Nominal leg position gain (N/m)."""
        return float(self.platform.actuator.kp)

    @property
    def fts_height(self) -> float:
        """Height of the FTS site above the plate frame (m)."""
        return float(self.platform.geometry.fts_height)

    @cached_property
    def fragments(self) -> tuple[str, str, str]:
        """The part's MJCF (payload on the FTS, world parts at the FTS site's home position,
        the top-level sections they need)."""
        g = self.platform.geometry
        pos, _ = self.platform.fts_site()
        site = (float(pos[0]), float(pos[1]), g.home_height + float(pos[2]))
        part = make_part(self.part)
        return part.payload_xml(), part.world_xml(site), part.extra_xml()

    @cached_property
    def payload_body(self) -> str:
        """Name of the part's root body (child of ``fts_body``)."""
        spec = build_spec(self.platform, *self.fragments)
        kids = spec.body("fts_body").bodies
        return kids[0].name if kids else "fts_body"

    @cached_property
    def world_bodies(self) -> tuple[str, ...]:
        """Names of the part's world-fixed bodies (the surface of a part the user wrote as
        an MJCF file)."""
        payload, world, extra = self.fragments
        if not world:
            return ()
        bare = {b.name for b in build_spec(self.platform, payload, None, extra)
                .worldbody.bodies}
        return tuple(b.name for b in build_spec(self.platform, *self.fragments)
                     .worldbody.bodies if b.name not in bare)

    # ------------------------------------------------------------------ the truth
    def active(self, stage: str | None = None) -> list[tuple[Effect, EffectConfig]]:
        """The effects that are on (of one stage)."""
        return [(eff, e) for eff, e in _on(self.effects) if stage is None or eff.stage == stage]

    def true_geometry(self) -> CalibratedGeometry:
        """The true geometry: :attr:`geometry` (or the nominal) with the geometry effects."""
        g0 = self.geometry or self.platform.geometry
        cal = g0 if isinstance(g0, CalibratedGeometry) else CalibratedGeometry.from_nominal(g0)
        base, top, off = cal.base_anchors(), cal.top_anchors(), cal.leg_offsets()
        for eff, e in self.active("geometry"):
            eff.apply_geometry(base, top, off, e.value, e.leg, e.axis)
        return CalibratedGeometry.from_nominal(cal, base, top, off)

    def _true_config(self) -> PlatformConfig:
        if self.geometry is None and not self.active("geometry"):
            return self.platform
        return dataclasses.replace(self.platform, geometry=self.true_geometry())

    def spec(self):  # -> mujoco.MjSpec
        """The true bench's ``MjSpec``: true geometry and the spec-stage effects."""
        spec = build_spec(self._true_config(), *self.fragments)
        for eff, e in self.active("spec"):
            eff.apply_spec(spec, e.value, self, e.leg, e.axis)
        return spec

    def model(self):  # -> mujoco.MjModel
        """The true bench's compiled model."""
        return _compile(self.spec())

    def nominal_model(self):  # -> mujoco.MjModel
        """The model the controller knows (no effects, nominal geometry)."""
        return _nominal(self.platform, self.part)

    def bias(self) -> np.ndarray:
        """Set-point bias (6,) (m) the encoders do not see: nominal minus true home length
        minus the encoder offset, so that a leg commanded to encoder length E reaches the
        geometric length E − δ of the true platform."""
        if self.geometry is None and not self.active("geometry"):
            return np.zeros(6)
        tg = self.true_geometry()
        nom = self.platform.geometry
        # a calibrated nominal geometry (a scene's geometry_file) knows its encoder offsets:
        # only the true offsets beyond them are unseen
        known = nom.leg_offsets() if isinstance(nom, CalibratedGeometry) else 0.0
        return nom.home_leg_lengths() - tg.home_leg_lengths() - (tg.leg_offsets() - known)

    def gravity_scale(self) -> float:
        """The compensated weight relative to the nominal model's."""
        ctl = {"gravity_scale": 1.0}
        for eff, e in self.active("controller"):
            eff.apply_controller(ctl, e.value, e.leg, e.axis)
        return float(ctl["gravity_scale"])

    def fts(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The FTS reading ``C w + b``: (C (6, 6), b (6,)), or None for an ideal sensor."""
        act = self.active("fts")
        if not act:
            return None
        C, b = np.eye(6), np.zeros(6)
        for eff, e in act:
            eff.apply_fts(C, b, e.value, e.axis)
        return C, b

    def noise_level(self) -> float:
        """Measurement noise, in multiples of each channel's nominal σ."""
        return float(sum(e.value for _, e in self.active("noise")))

    def setpoint_values(self) -> dict[str, np.ndarray]:
        """Set-point effects: name → value per leg (6,) (the off value on other legs)."""
        out: dict[str, np.ndarray] = {}
        for eff, e in self.active("setpoint"):
            v = out.setdefault(e.name, np.full(6, eff.param.off))
            if e.leg < 0:
                v[:] = e.value
            else:
                v[e.leg] = e.value
        return out

    def label(self) -> str:
        """Short description: the effects that are on."""
        return ", ".join(f"{e.label}={e.value:.4g}" for _, e in self.active()) or "nominal"


_CACHE: dict[Any, Any] = {}


def _compile(spec):
    from ..errors import ConfigError

    try:
        return spec.compile()
    except ValueError as exc:
        raise ConfigError("bench", None, "", message=f"bench: the model with these effects "
                          f"does not compile: {exc}") from exc


def _nominal(platform: PlatformConfig, part: ExperimentConfig):
    key = (platform, part)
    m = _CACHE.get(key)
    if m is None:
        if len(_CACHE) > 32:
            _CACHE.clear()
        m = _CACHE[key] = Bench(platform, part).model()
    return m


def setpoint_structure(benches: Sequence[Bench]) -> list[str]:
    """The set-point effects any of the benches has, in library order."""
    names: list[str] = []
    for b in benches:
        for n in b.setpoint_values():
            if n not in names:
                names.append(n)
    order = {n: i for i, n in enumerate(REGISTRY)}
    return sorted(names, key=order.__getitem__)


def setpoint_blocks(benches: Sequence[Bench]) -> list[Block]:
    """The per-leg set-point blocks of K benches over K·6 rows (off where a bench lacks
    the effect)."""
    K = len(benches)
    blocks = []
    dt = benches[0].platform.dt
    for name in setpoint_structure(benches):
        eff = get_effect(name)
        vals = np.concatenate([b.setpoint_values().get(name, np.full(6, eff.param.off))
                               for b in benches])
        blocks.append(eff.block(K, vals, dt))
    return blocks


def bench_models(benches: Sequence[Bench]) -> list[Any]:
    """The true model of each bench: compiled once per distinct bench, a copy for each
    other test of the same bench (a batch's tests may edit their own models; a sweep's
    tests often differ only in the numerical substructure and share one bench)."""
    import copy

    built: dict[Any, Any] = {}
    out = []
    for b in benches:
        try:
            m = built.get(b)
        except TypeError:  # a bench with an unhashable part (arrays): compiled on its own
            out.append(b.model())
            continue
        if m is None:
            out.append(built.setdefault(b, b.model()))
        else:
            out.append(copy.copy(m))
    return out


def platform_batch(benches: Sequence[Bench], nthread: int = 2, settle: float = 0.05,
                   models: Sequence[Any] | None = None,
                   replay: bool = False):  # -> PlatformBatch
    """K benches stepped together: one :class:`~rths3d.platform.sim.PlatformBatch` with each
    bench's true model, the nominal model's gravity compensation, the set-point blocks, the
    encoder bias and the FTS calibration. ``models``: the true models when already built;
    ``replay``: an open-loop replay (:class:`~rths3d.platform.sim.PlatformBatch`)."""
    from ..platform.sim import PlatformBatch

    K = len(benches)
    if models is None:
        models = bench_models(benches)
    fts = [b.fts() for b in benches]
    any_fts = any(f is not None for f in fts)
    C = np.stack([f[0] if f is not None else np.eye(6) for f in fts]) if any_fts else None
    bo = np.stack([f[1] if f is not None else np.zeros(6) for f in fts]) if any_fts else None
    return PlatformBatch(benches[0].platform, nsim=K, nthread=nthread, settle=settle,
                         models=list(models), nominal=[b.nominal_model() for b in benches],
                         configs=[b.platform for b in benches],
                         blocks=setpoint_blocks(benches),
                         bias=np.stack([b.bias() for b in benches]),
                         gravity_scale=np.array([b.gravity_scale() for b in benches]),
                         fts_matrix=C, fts_offset=bo, replay=replay)
