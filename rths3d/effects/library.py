"""The effects library: every physical effect a bench model knows, in one place.

To add an effect, subclass :class:`~rths3d.effects.base.Effect` here, give it a ``name``,
``stage``, one :class:`~rths3d.effects.base.Param` (unit, off value, bounds, typical scale),
its target (``per_leg``/``all_legs``, ``axes``), a ``signature`` sentence and the hook of its
stage, and decorate it with ``@register``. Scenes (``[[effect]]``), the vRTHS loop's Stewart
platform, the diagnosis and ``rths3d effects`` pick it up from
:data:`~rths3d.effects.base.REGISTRY`.

Spec-stage hooks address the bench's MuJoCo model by the names of
:mod:`rths3d.platform.model` (``leg{i}_slide``, ``leg{i}``, ``fts_body``, site ``fts``) and of
the part (:mod:`rths3d.experiment`: the joint ``exp_heave``, the surface ``exp_surface``, the
part's root body ``ctx.payload_body``); ``ctx`` (the :class:`~rths3d.bench.Bench`) gives the
nominal values (``kp``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from .base import Effect, Param, ProbeData, register
from .blocks import Block, DelayBlock, LagBlock, PlayBlock, RateLimitBlock

WRENCH = ("fx", "fy", "fz", "tx", "ty", "tz")
"""Components of the six-axis force-torque sensor (N, N·m), in the sensor frame."""

CROSS = tuple(f"{a}.{b}" for a in WRENCH for b in WRENCH if a != b)
"""Cross-talk entries ``row.column`` of the FTS matrix."""

_DOF_SIGMA = {"x": 1e-6, "y": 1e-6, "z": 1e-6, "rx": 5e-6, "ry": 5e-6, "rz": 5e-6}
_WRENCH_SIGMA = {"fx": 0.1, "fy": 0.1, "fz": 0.1, "tx": 0.005, "ty": 0.005, "tz": 0.005}
_F_SIGMA = {"x": 0.1, "y": 0.1, "z": 0.1, "rx": 0.005, "ry": 0.005, "rz": 0.005}


def noise_sigma(column: str) -> float:
    """Standard deviation (SI) of the measurement noise of a record column at
    ``sensor_noise = 1``: pose and interface displacement 1 µm / 5 µrad, leg encoders 1 µm,
    leg forces 0.5 N, FTS and interface force 0.1 N / 0.005 N·m; 0 for other columns."""
    sig, _, lab = column.partition(".")
    if sig in ("pose_meas", "z_meas"):
        return _DOF_SIGMA.get(lab, 0.0)
    if sig == "leg_len":
        return 1e-6
    if sig == "leg_force":
        return 0.5
    if sig == "fts":
        return _WRENCH_SIGMA.get(lab, 0.0)
    if sig == "f_meas":
        return _F_SIGMA.get(lab, 0.0)
    return 0.0


def _legs(leg: int) -> range:
    return range(6) if leg < 0 else range(leg, leg + 1)


# ---------------------------------------------------------------------------- set-point blocks
@register
class TransportDelay(Effect):
    name = "delay"
    stage = "setpoint"
    per_leg = all_legs = True
    lti = True
    param = Param("tau", "s", 0.0, 0.0, 0.05, 2e-3, "transport delay of the leg set-point")
    description = "Transport delay of the leg set-points (communication, servo controller)."
    signature = "phase lag growing linearly with frequency; residual ∝ velocity (of its leg)"

    def block(self, K: int, values: np.ndarray, dt: float) -> Block:
        return DelayBlock(K, len(values) // K, values, dt)


@register
class ActuatorLag(Effect):
    name = "actuator_lag"
    stage = "setpoint"
    per_leg = all_legs = True
    lti = True
    param = Param("tc", "s", 0.0, 0.0, 0.05, 2e-3, "time constant of the actuator bandwidth")
    description = "Limited actuator bandwidth: first-order lag 1/(1 + s·tc) of the set-point."
    signature = "magnitude roll-off and a phase lag that saturates at 90°"

    def block(self, K: int, values: np.ndarray, dt: float) -> Block:
        return LagBlock(K, len(values) // K, values, dt)


@register
class VelocitySaturation(Effect):
    name = "velocity_saturation"
    stage = "setpoint"
    per_leg = all_legs = True
    param = Param("v_max", "m/s", math.inf, 1e-4, 10.0, 0.02,
                  "largest leg speed; faster set-points are rate-limited")
    description = "Leg velocity saturation: the set-point is rate-limited to ±v_max."
    signature = "clipping of the leg velocity above a threshold; residual only at high speed"

    def probe_value(self, probe: ProbeData | None = None) -> float:
        """80 % of the peak set-point speed of its leg(s); below that, the encoders' peak
        speed where they never reach the commanded one (the limit itself shows)."""
        if probe is None:
            return super().probe_value()
        v = np.abs(np.diff(probe.setpoint_lengths(), axis=0)) / probe.dt
        legs = range(6) if probe.leg < 0 else [probe.leg]
        vc = max(float(v[:, i].max()) for i in legs)
        guess = 0.8 * vc
        # over 5 samples, so that the encoders' noise averages
        m = 5
        enc = [f"leg_len.{i}" for i in legs if f"leg_len.{i}" in probe.measured]
        if enc:
            vm = max(float(np.percentile(np.abs(
                probe.measured[c][m:] - probe.measured[c][:-m]) / (m * probe.dt), 99.8))
                     for c in enc)
            if vm < 0.97 * vc:
                guess = vm
        return float(np.clip(guess, self.param.lo, self.param.hi))

    def block(self, K: int, values: np.ndarray, dt: float) -> Block:
        return RateLimitBlock(K, len(values) // K, values, dt)


@register
class Backlash(Effect):
    name = "backlash"
    stage = "setpoint"
    per_leg = all_legs = True
    param = Param("b", "m", 0.0, 0.0, 5e-3, 2e-5, "total play (dead band width) in the drive")
    description = "Play in a leg's drive: the leg follows only after the play is taken up."
    signature = "dead band and hysteresis at reversals; length residual ±b/2, no force jump"

    def block(self, K: int, values: np.ndarray, dt: float) -> Block:
        return PlayBlock(K, len(values) // K, values)


# ---------------------------------------------------------------------------- MuJoCo model
@register
class CoulombFriction(Effect):
    name = "coulomb_friction"
    stage = "spec"
    per_leg = all_legs = True
    param = Param("f_c", "N", 0.0, 0.0, 2000.0, 20.0, "dry friction force of a leg")
    description = "Coulomb (dry) friction in a leg's slide, MuJoCo joint frictionloss."
    signature = "leg force jumps by 2·F_c at the leg's velocity reversals; ∝ sign(velocity)"

    def apply_spec(self, spec, value, ctx, leg, axis):
        for i in _legs(leg):
            j = spec.joint(f"leg{i}_slide")
            j.frictionloss = value
            # a stiff friction constraint, so F_c is reached at small slip velocities; its
            # time constant is two interface steps whatever the physics step, so that runs
            # with different substeps model the same friction
            j.solref_friction = np.array([2.0 * ctx.platform.dt, 1.0])


@register
class ViscousFriction(Effect):
    name = "viscous_friction"
    stage = "spec"
    per_leg = all_legs = True
    param = Param("c_v", "N·s/m", 0.0, 0.0, 1e5, 200.0, "viscous friction of a leg")
    description = "Viscous friction in a leg's slide, MuJoCo joint damping."
    signature = "leg force residual ∝ the leg's velocity; small length lag"

    def apply_spec(self, spec, value, ctx, leg, axis):
        for i in _legs(leg):
            spec.joint(f"leg{i}_slide").damping = np.array([value, 0.0, 0.0])


def _scale_kp(spec: Any, i: int, change: Callable[[float], float]) -> None:
    """Leg i's position gain kp → change(kp), from the gain the spec has now, so that several
    gain effects (a leg's own and the platform's compliance) combine in any order. With the
    servo's lag after the hold (the ``leg{i}_lag`` actuator, force −kp·τ·f: the gain acts on
    the lagged set-point) its gain is scaled alike; with a servo-valve (``leg{i}_valve``,
    force −kp·(s − y)) the valve's stiffness is the gain."""
    valve = spec.actuator(f"leg{i}_valve")
    if valve is not None:  # a servo-valve: the servo's stiffness acts on the valve's output
        bias = np.array(valve.biasprm)
        kp0 = -float(bias[1])
        bias[1] = -change(kp0)
        valve.biasprm = bias
        return
    act = spec.actuator(f"leg{i}")
    gain = np.array(act.gainprm)
    bias = np.array(act.biasprm)
    kp0 = float(gain[0])
    kp = change(kp0)
    gain[0] = kp
    bias[1] = -kp
    act.gainprm = gain
    act.biasprm = bias
    lag = spec.actuator(f"leg{i}_lag")
    if lag is not None:
        lg = np.array(lag.gainprm)
        lg[0] *= kp / kp0
        lag.gainprm = lg


@register
class ServoGain(Effect):
    name = "servo_gain"
    stage = "spec"
    per_leg = all_legs = True
    param = Param("dkp", "1", 0.0, -0.8, 2.0, 0.1, "relative error of a leg's position gain")
    description = "A leg's servo position gain differs from the nominal: kp' = (1 + dkp)·kp."
    signature = "leg force and length residual ∝ the leg's load; that leg sags differently"

    def apply_spec(self, spec, value, ctx, leg, axis):
        for i in _legs(leg):
            _scale_kp(spec, i, lambda kp: kp * (1.0 + value))


@register
class PlatformCompliance(Effect):
    name = "platform_compliance"
    stage = "spec"
    param = Param("c", "m/N", 0.0, 0.0, 1e-4, 2e-7,
                  "series compliance of legs, joints and reaction frame")
    description = "Compliance in series with every leg servo: kp' = kp / (1 + kp·c)."
    signature = "displacement residual ∝ force"
    late = True  # in series with each leg's servo as it is (its own gain error included)

    def apply_spec(self, spec, value, ctx, leg, axis):
        for i in range(6):
            _scale_kp(spec, i, lambda kp: kp / (1.0 + kp * value))


@register
class FixtureMass(Effect):
    name = "fixture_mass"
    stage = "spec"
    param = Param("m_f", "kg", 0.0, 0.0, 50.0, 0.2,
                  "uncompensated payload mass between force sensor and part")
    description = "Payload (adapter) mass on the FTS that the model leaves out."
    signature = "force residual ∝ acceleration (and gravity in the untared wrench)"
    structural = True  # an extra body on the plate

    def apply_spec(self, spec, value, ctx, leg, axis):
        import mujoco

        body = spec.body("fts_body")
        body.add_geom(name="effect_fixture", type=mujoco.mjtGeom.mjGEOM_SPHERE,
                      size=[0.01, 0, 0], pos=[0, 0, ctx.fts_height + 0.005], mass=value,
                      contype=0, conaffinity=0)


@register
class PayloadCom(Effect):
    name = "payload_com"
    stage = "spec"
    axes = ("x", "y")
    param = Param("d", "m", 0.0, -0.05, 0.05, 0.005,
                  "offset of the part (and its centre of mass) on the FTS")
    description = "The part sits off the sensor axis: its weight and inertia add torques."
    signature = "FTS torque residual ∝ weight and acceleration; tilt-dependent"

    def apply_spec(self, spec, value, ctx, leg, axis):
        body = spec.body(ctx.payload_body)
        pos = np.array(body.pos)
        pos["xy".index(axis)] += value
        body.pos = pos


@register
class FtsMount(Effect):
    name = "fts_mount"
    stage = "spec"
    axes = ("x", "y", "z")
    param = Param("d", "m", 0.0, -0.05, 0.05, 0.005,
                  "mounting offset of the FTS reference point")
    description = "The sensor's reference point is off its nominal place on the plate."
    signature = "torque residual ∝ force × offset; forces unaffected"

    def apply_spec(self, spec, value, ctx, leg, axis):
        site = spec.site("fts")
        pos = np.array(site.pos)
        pos["xyz".index(axis)] += value
        site.pos = pos


def _payload_joint(spec: Any) -> Any:
    return spec.joint("exp_heave")


@register
class SpecimenStiffness(Effect):
    name = "specimen_stiffness"
    stage = "spec"
    requires = ("has_spring",)
    param = Param("dk", "1", 0.0, -0.9, 3.0, 0.1, "relative stiffness error: k' = (1 + dk)·k")
    description = "The part's stiffness differs from the model."
    signature = "force residual ∝ the part's deformation; resonance shifts"

    def apply_spec(self, spec, value, ctx, leg, axis):
        j = _payload_joint(spec)
        st = np.array(j.stiffness)
        j.stiffness = np.array([st[0] * (1.0 + value), 0.0, 0.0])


@register
class SpecimenMass(Effect):
    name = "specimen_mass"
    stage = "spec"
    param = Param("dm", "1", 0.0, -0.9, 5.0, 0.1, "relative mass error: m' = (1 + dm)·m")
    description = "The part's mass differs from the model (it also sags further)."
    signature = "force residual ∝ the part's absolute acceleration; resonance shifts"

    def apply_spec(self, spec, value, ctx, leg, axis):
        body = spec.body(ctx.payload_body)
        if body.explicitinertial:
            body.mass = body.mass * (1.0 + value)
            body.inertia = np.array(body.inertia) * (1.0 + value)
        else:
            for g in body.geoms:
                g.mass = g.mass * (1.0 + value)


@register
class SpecimenDamping(Effect):
    name = "specimen_damping"
    stage = "spec"
    requires = ("has_spring",)
    param = Param("dc", "N·s/m", 0.0, -1e3, 1e4, 2.0, "damping of the part added to the model's")
    description = "The part's damping differs from the model: d' = d + dc."
    signature = "force residual ∝ the part's deformation rate, largest near resonance"

    def apply_spec(self, spec, value, ctx, leg, axis):
        j = _payload_joint(spec)
        d = np.array(j.damping)
        j.damping = np.array([max(d[0] + value, 0.0), 0.0, 0.0])


@register
class ContactGap(Effect):
    name = "contact_gap"
    stage = "spec"
    requires = ("has_contact",)
    param = Param("dh", "m", 0.0, -0.01, 0.01, 2e-4, "error of the gap to the contact surface")
    description = "The contact surface is dh further away than modelled."
    signature = "force residual only in and near contact phases"

    def apply_spec(self, spec, value, ctx, leg, axis):
        g = spec.geom("exp_surface")
        if g is not None:
            pos = np.array(g.pos)
            pos[2] += value
            g.pos = pos
            return
        # a part of the user's own (an MJCF file): its world-fixed bodies are the surface
        for name in ctx.world_bodies:
            body = spec.body(name)
            pos = np.array(body.pos)
            pos[2] += value
            body.pos = pos


# ---------------------------------------------------------------------------- geometry
@register
class BaseAnchor(Effect):
    name = "base_anchor"
    stage = "geometry"
    calibrated = True
    per_leg = True
    axes = ("x", "y", "z")
    param = Param("d", "m", 0.0, -0.02, 0.02, 1e-3, "base anchor position error")
    description = "A base anchor sits off its drawn position (kinematic calibration)."
    signature = "absolute pose error that depends on the pose; leg lengths consistent"

    def apply_geometry(self, base, top, offsets, value, leg, axis):
        base[leg, "xyz".index(axis)] += value


@register
class TopAnchor(Effect):
    name = "top_anchor"
    stage = "geometry"
    calibrated = True
    per_leg = True
    axes = ("x", "y", "z")
    param = Param("d", "m", 0.0, -0.02, 0.02, 1e-3, "platform anchor position error")
    description = "A platform anchor sits off its drawn position (kinematic calibration)."
    signature = "absolute pose error that depends on the pose; leg lengths consistent"

    def apply_geometry(self, base, top, offsets, value, leg, axis):
        top[leg, "xyz".index(axis)] += value


@register
class LegOffset(Effect):
    name = "leg_offset"
    stage = "geometry"
    per_leg = True
    followups = ("base_anchor", "top_anchor")  # an anchor's error also reads along its leg
    param = Param("d", "m", 0.0, -0.02, 0.02, 2e-4,
                  "encoder offset: the encoder reads the geometric length plus d")
    description = "A leg's encoder zero is off: the leg is d shorter than the encoder says."
    signature = "constant pose offset along that leg's direction; its length reads biased"

    def apply_geometry(self, base, top, offsets, value, leg, axis):
        offsets[leg] += value


# ---------------------------------------------------------------------------- controller
@register
class GravityComp(Effect):
    name = "gravity_comp"
    stage = "controller"
    param = Param("dg", "1", 0.0, -1.0, 1.0, 0.05,
                  "relative error of the compensated weight")
    description = "Gravity compensation of the wrong weight: offsets scaled by (1 + dg)."
    signature = "static sag at rest (zeroed away); leg forces unchanged in motion"

    def apply_controller(self, ctl, value, leg, axis):
        ctl["gravity_scale"] *= 1.0 + value


# ---------------------------------------------------------------------------- FTS
@register
class FtsGain(Effect):
    name = "fts_gain"
    stage = "fts"
    calibrated = True
    axes = WRENCH
    param = Param("g", "1", 0.0, -0.5, 0.5, 0.02, "relative gain error of one FTS channel")
    description = "FTS calibration: one channel reads (1 + g) times the true component."
    signature = "residual of that channel ∝ the channel itself (untared: incl. the weight)"

    def apply_fts(self, C, b, value, axis):
        i = WRENCH.index(axis)
        C[i, i] *= 1.0 + value


@register
class FtsCrosstalk(Effect):
    name = "fts_crosstalk"
    stage = "fts"
    calibrated = True
    axes = CROSS
    param = Param("c", "1", 0.0, -0.3, 0.3, 0.01,
                  "share of one component read on another channel (row.column)")
    description = "FTS cross-talk: channel ``row`` reads c times component ``column`` too."
    signature = "residual of one channel ∝ another component"

    def apply_fts(self, C, b, value, axis):
        r, c = axis.split(".")
        C[WRENCH.index(r), WRENCH.index(c)] += value


@register
class FtsOffset(Effect):
    name = "fts_offset"
    stage = "fts"
    calibrated = True
    axes = WRENCH
    param = Param("b", "N", 0.0, -100.0, 100.0, 0.5,
                  "zero offset of one FTS channel (N or N·m)")
    description = "FTS zero offset (drift since it was zeroed unloaded); tared away in f_meas."
    signature = "constant residual of that raw channel"

    def apply_fts(self, C, b, value, axis):
        b[WRENCH.index(axis)] += value


# ---------------------------------------------------------------------------- sensor signals
@register
class FtsLowpass(Effect):
    name = "fts_lowpass"
    stage = "sensor"
    lti = True
    param = Param("tc", "s", 0.0, 0.0, 0.05, 2e-3, "time constant of the force-sensor filter")
    description = "Force sensor (or amplifier) low-pass 1/(1 + s·tc) of the interface force."
    signature = "measured force lags and rolls off; displacement and leg force unaffected"

    def block(self, K: int, values: np.ndarray, dt: float) -> Block:
        return LagBlock(K, len(values) // K, values, dt)


@register
class SensorNoise(Effect):
    name = "sensor_noise"
    stage = "noise"
    floor = True
    candidate = False
    lti = True
    param = Param("level", "1", 0.0, 0.0, 100.0, 1.0,
                  "white noise, multiple of the nominal σ of each channel "
                  "(1 µm, 5 µrad, 0.1 N, 0.005 N·m, 0.5 N per leg)")
    description = "White Gaussian measurement noise on every recorded channel (the floor)."
    signature = "white, flat spectrum, uncorrelated with every state"


def describe() -> list[dict[str, Any]]:
    """All effects as plain dicts (name, stage, parameter, unit, off, bounds, target,
    signature)."""
    from .base import REGISTRY

    rows = []
    for eff in REGISTRY.values():
        p = eff.param
        target = ("leg (0–5" + (", -1 all" if eff.all_legs else "") + ")") if eff.per_leg \
            else ""
        if eff.axes:
            ax = ", ".join(eff.axes) if len(eff.axes) <= 6 else "row.column of fx … tz"
            target = (target + "; " if target else "") + f"axis ({ax})"
        rows.append({"effect": eff.name, "stage": eff.stage, "param": p.name, "unit": p.unit,
                     "off": p.off, "lo": p.lo, "hi": p.hi, "scale": p.scale,
                     "target": target, "per_leg": eff.per_leg, "axes": list(eff.axes),
                     "candidate": eff.candidate, "needs_sim": eff.needs_sim, "lti": eff.lti,
                     "description": eff.description, "signature": eff.signature})
    return rows
