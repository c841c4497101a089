"""The effects library: every physical effect the diagnosis knows, in one place.

To add an effect, subclass :class:`~rths3d.effects.base.Effect` here, give it a ``name``,
``stage``, one :class:`~rths3d.effects.base.Param` (unit, off value, bounds, typical scale),
a ``signature`` sentence and the hook of its stage, and decorate it with ``@register``. The
diagnosis, the ``rths3d effects`` listing, the synthetic measurements and the report pick it
up from :data:`~rths3d.effects.base.REGISTRY`.

Output channels of the bench models (record column names, SI units):
``z_meas.z`` (m, plate displacement), ``f_meas.z`` and ``f_meas.x`` (N, force-torque-sensor
force on the specimen, tared), ``leg_force.<i>`` (N, actuator forces, tared; one leg on the
1-D bench, six on the Stewart platform).

Spec-stage hooks address the model through the names a backend exposes (``bench`` argument):
``leg_joints``, ``leg_actuators``, ``kp``, ``physics_step``, ``fixture_geom``, ``m_fixture``,
``specimen_joint``, ``specimen_geom``, ``m_exp``, ``k_exp``, ``c_exp``, ``wall_geom``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .base import Effect, Param, register
from .blocks import Block, DelayBlock, GainBlock, LagBlock, OffsetBlock, run_blocks

Z = "z_meas.z"
FZ = "f_meas.z"
FX = "f_meas.x"
LEG = "leg_force.0"
LEGS: tuple[str, ...] = tuple(f"leg_force.{i}" for i in range(6))
OUTPUTS: tuple[str, ...] = (Z, FZ, FX, *LEGS)
"""Channels the bench models produce."""

NOISE_SIGMA: dict[str, float] = {Z: 5e-7, FZ: 0.05, FX: 0.05, **{c: 0.5 for c in LEGS}}
"""Standard deviation of sensor noise at ``sensor_noise = 1`` (m or N)."""


def _channels(out: dict[str, np.ndarray], names: tuple[str, ...]) -> list[str]:
    return [c for c in (names or tuple(out)) if c in out]


def _from_rest(block: Block, x: np.ndarray) -> np.ndarray:
    """The block applied to ``x`` as it acts on a bench at rest on x[0]: on the deviation
    from the first sample (a delay holds it, a lag starts on it)."""
    x = np.asarray(x, dtype=float)
    return run_blocks([block], x - x[0]) + x[0]


def delay_signal(x: np.ndarray, dt: float, tau: float) -> np.ndarray:
    """``x(t − τ)`` by linear interpolation; the first sample is held for ``t < τ``
    (the loop's :class:`~rths3d.effects.blocks.DelayBlock`)."""
    return _from_rest(DelayBlock(1, 1, tau, dt), x)


def lowpass_signal(x: np.ndarray, dt: float, tc: float) -> np.ndarray:
    """First-order low-pass of time constant ``tc`` (s), 1/(1 + s·tc), started at rest on x[0]
    (the loop's :class:`~rths3d.effects.blocks.LagBlock`)."""
    return _from_rest(LagBlock(1, 1, tc, dt), x)


# ---------------------------------------------------------------------------- signal effects
@register
class TransportDelay(Effect):
    name = "delay"
    stage = "dynamics"
    param = Param("tau", "s", 0.0, 0.0, 0.05, 2e-3, "pure transport delay of the whole loop")
    description = "Transport delay between command and achieved motion (all outputs shift)."
    signature = "phase lag growing linearly with frequency; residual ∝ velocity"

    def block(self, K: int, n: int, dt: float, value: float) -> Block:
        return DelayBlock(K, n, value, dt)

    def apply_output(self, out, dt, value, rng=None):
        for c in _channels(out, self.channels):
            out[c] = delay_signal(out[c], dt, value)


@register
class ActuatorLag(Effect):
    name = "actuator_lag"
    stage = "dynamics"
    param = Param("tc", "s", 0.0, 0.0, 0.05, 2e-3, "time constant of the actuator bandwidth")
    description = "Limited actuator bandwidth: first-order lag 1/(1 + s·tc) of the motion."
    signature = "magnitude roll-off and a phase lag that saturates at 90°"

    def block(self, K: int, n: int, dt: float, value: float) -> Block:
        return LagBlock(K, n, value, dt)

    def apply_output(self, out, dt, value, rng=None):
        for c in _channels(out, self.channels):
            out[c] = lowpass_signal(out[c], dt, value)


@register
class FtsLowpass(Effect):
    name = "fts_lowpass"
    stage = "sensor_dynamics"
    param = Param("tc", "s", 0.0, 0.0, 0.05, 2e-3, "time constant of the force-sensor filter")
    description = "Force-torque sensor (or its amplifier) low-pass 1/(1 + s·tc)."
    signature = "force lags and rolls off, displacement and leg force unaffected"
    channels = (FZ, FX)

    def block(self, K: int, n: int, dt: float, value: float) -> Block:
        return LagBlock(K, n, value, dt)

    def apply_output(self, out, dt, value, rng=None):
        for c in _channels(out, self.channels):
            out[c] = lowpass_signal(out[c], dt, value)


@register
class FtsGain(Effect):
    name = "fts_gain"
    stage = "sensor"
    param = Param("g", "1", 0.0, -0.5, 0.5, 0.05, "relative gain error of the force sensor")
    description = "Force sensor calibration error: F' = (1 + g)·F."
    signature = "force residual ∝ the force itself; leg force unaffected"
    channels = (FZ,)

    def block(self, K: int, n: int, dt: float, value: float) -> Block:
        return GainBlock(K, n, 1.0 + value)

    def apply_output(self, out, dt, value, rng=None):
        if FZ in out:
            out[FZ] = run_blocks([self.block(1, 1, dt, value)], out[FZ])

    def initial_guess(self, measured, model, command, dt):
        f = model.get(FZ)
        if f is None or FZ not in measured or not np.any(f):
            return None
        return float(np.dot(measured[FZ] - f, f) / np.dot(f, f))


@register
class FtsOffset(Effect):
    name = "fts_offset"
    stage = "sensor"
    param = Param("b", "N", 0.0, -100.0, 100.0, 0.5, "force sensor zero offset (drift, bad tare)")
    description = "Force sensor offset: F' = F + b."
    signature = "constant force residual"
    channels = (FZ,)

    def block(self, K: int, n: int, dt: float, value: float) -> Block:
        return OffsetBlock(K, n, value)

    def apply_output(self, out, dt, value, rng=None):
        if FZ in out:
            out[FZ] = run_blocks([self.block(1, 1, dt, value)], out[FZ])

    def initial_guess(self, measured, model, command, dt):
        if FZ not in measured or FZ not in model:
            return None
        return float(np.mean(measured[FZ] - model[FZ]))


@register
class FtsCrosstalk(Effect):
    name = "fts_crosstalk"
    stage = "sensor"
    param = Param("c", "1", 0.0, -0.3, 0.3, 0.02, "share of F_z read on the F_x channel")
    description = "Force sensor cross-talk: F'_x = F_x + c·F_z."
    signature = "lateral force residual ∝ the vertical force"
    channels = (FX,)

    def apply_output(self, out, dt, value, rng=None):
        if FX in out and FZ in out:
            out[FX] = out[FX] + value * out[FZ]

    def initial_guess(self, measured, model, command, dt):
        f = model.get(FZ)
        if f is None or FX not in measured or not np.any(f):
            return None
        return float(np.dot(measured[FX] - model[FX], f) / np.dot(f, f))


@register
class SensorNoise(Effect):
    name = "sensor_noise"
    stage = "noise"
    param = Param("level", "1", 0.0, 0.0, 100.0, 1.0,
                  "white noise, multiple of the nominal σ (0.5 µm, 0.05 N, 0.5 N leg)")
    description = "White Gaussian sensor noise on every output channel (the noise floor)."
    signature = "white, flat spectrum, uncorrelated with every state"
    candidate = False

    def apply_output(self, out, dt, value, rng=None):
        rng = rng if rng is not None else np.random.default_rng()
        for c in _channels(out, self.channels):
            out[c] = out[c] + value * NOISE_SIGMA.get(c, 0.0) * rng.standard_normal(out[c].size)


@register
class Quantisation(Effect):
    name = "quantisation"
    stage = "adc"
    param = Param("q", "m", 0.0, 0.0, 1e-3, 2e-6,
                  "resolution (one step) of the displacement sensor")
    description = "Displacement sensor resolution: z' = q·round(z/q)."
    signature = "stair steps; displacement residual uniform within ±q/2"
    channels = (Z,)

    def apply_output(self, out, dt, value, rng=None):
        if Z in out:
            out[Z] = value * np.round(out[Z] / value)

    def initial_guess(self, measured, model, command, dt):
        z = measured.get(Z)
        if z is None:
            return None
        d = np.abs(np.diff(z))
        d = d[d > 1e-15]
        if d.size < 10:
            return None
        q = float(np.percentile(d, 1))
        # a quantised signal sits on integer multiples of one step
        if np.median(np.abs(z / q - np.round(z / q))) > 0.05:
            return None
        return q


# ---------------------------------------------------------------------------- command effects
@register
class VelocitySaturation(Effect):
    name = "velocity_saturation"
    stage = "command"
    param = Param("v_max", "m/s", math.inf, 1e-4, 10.0, 0.005,
                  "largest actuator speed; faster commands are rate-limited")
    description = "Actuator velocity saturation: the set-point is rate-limited to ±v_max."
    signature = "clipping of the velocity above a threshold; residual only at high speed"

    def apply_command(self, z_cmd, dt, value):
        step = value * dt
        y = z_cmd.tolist()
        prev = y[0]
        for k in range(1, len(y)):
            d = y[k] - prev
            prev = prev + (step if d > step else -step if d < -step else d)
            y[k] = prev
        return np.asarray(y)

    def probe(self, measured, model, command, dt):
        guess = self.initial_guess(measured, model, command, dt)
        if guess is not None:
            return guess
        v = np.abs(np.gradient(command, dt))
        return float(np.clip(0.8 * np.percentile(v, 99.5), self.param.lo, self.param.hi))

    def initial_guess(self, measured, model, command, dt):
        z = measured.get(Z)
        if z is None:
            return None
        zs = lowpass_signal(z, dt, 5 * dt)
        v_meas = np.percentile(np.abs(np.gradient(zs, dt)), 99.5)
        v_cmd = np.percentile(np.abs(np.gradient(command, dt)), 99.5)
        if v_meas < 0.97 * v_cmd:
            return float(np.clip(v_meas, self.param.lo, self.param.hi))
        return None


@register
class Backlash(Effect):
    name = "backlash"
    stage = "command"
    param = Param("b", "m", 0.0, 0.0, 5e-3, 2e-5, "total play (dead band width) in the drive")
    description = "Backlash (play) in the drive train: the plate follows the motor only after "\
                  "the play b is taken up."
    signature = "dead band and hysteresis at reversals; displacement residual ±b/2, no force jump"

    def apply_command(self, z_cmd, dt, value):
        h = 0.5 * value
        y = z_cmd.tolist()
        prev = y[0]
        for k in range(1, len(y)):
            x = y[k]
            if prev < x - h:
                prev = x - h
            elif prev > x + h:
                prev = x + h
            y[k] = prev
        return np.asarray(y)


# ---------------------------------------------------------------------------- physics effects
@register
class CoulombFriction(Effect):
    name = "coulomb_friction"
    stage = "spec"
    param = Param("f_c", "N", 0.0, 0.0, 2000.0, 20.0, "dry friction force of the legs")
    description = "Coulomb (dry) friction in the legs, MuJoCo joint frictionloss."
    signature = "leg force jumps by 2·F_c at velocity reversals; residual ∝ sign(velocity)"

    def apply_spec(self, spec, value, bench):
        for j in bench.leg_joints:
            spec.joint(j).frictionloss = value
            # a stiff friction constraint, so F_c is reached at small slip velocities
            spec.joint(j).solref_friction = np.array([2.0 * bench.physics_step, 1.0])


@register
class ViscousFriction(Effect):
    name = "viscous_friction"
    stage = "spec"
    param = Param("c_v", "N·s/m", 0.0, 0.0, 1e5, 200.0, "viscous friction coefficient of the legs")
    description = "Viscous friction in the legs, MuJoCo joint damping."
    signature = "leg force residual ∝ velocity; small displacement lag"

    def apply_spec(self, spec, value, bench):
        for j in bench.leg_joints:
            spec.joint(j).damping = np.array([value, 0.0, 0.0])


@register
class FixtureMass(Effect):
    name = "fixture_mass"
    stage = "spec"
    param = Param("m_f", "kg", 0.0, 0.0, 50.0, 0.2,
                  "uncompensated mass between force sensor and specimen")
    description = "Fixture (adapter) mass between FTS and specimen that the model leaves out."
    signature = "force residual ∝ acceleration"

    def apply_spec(self, spec, value, bench):
        spec.geom(bench.fixture_geom).mass = bench.m_fixture + value


@register
class PlatformCompliance(Effect):
    name = "platform_compliance"
    stage = "spec"
    param = Param("c", "m/N", 0.0, 0.0, 1e-4, 2e-7,
                  "series compliance of legs, joints and reaction frame")
    description = "Compliance in series with the servo stiffness: k_p' = k_p / (1 + k_p·c)."
    signature = "displacement residual ∝ force"

    def apply_spec(self, spec, value, bench):
        kp = bench.kp / (1.0 + bench.kp * value)
        for name in bench.leg_actuators:
            act = spec.actuator(name)
            gain = np.array(act.gainprm)
            bias = np.array(act.biasprm)
            gain[0] = kp
            bias[1] = -kp
            act.gainprm = gain
            act.biasprm = bias


@register
class SpecimenStiffness(Effect):
    name = "specimen_stiffness"
    stage = "spec"
    param = Param("dk", "1", 0.0, -0.9, 3.0, 0.1, "relative stiffness error: k' = (1 + dk)·k")
    description = "Specimen stiffness differs from the model."
    signature = "force residual ∝ specimen deformation; resonance shifts"

    def apply_spec(self, spec, value, bench):
        spec.joint(bench.specimen_joint).stiffness = np.array(
            [bench.k_exp * (1.0 + value), 0.0, 0.0])


@register
class SpecimenMass(Effect):
    name = "specimen_mass"
    stage = "spec"
    param = Param("dm", "1", 0.0, -0.9, 5.0, 0.1, "relative mass error: m' = (1 + dm)·m")
    description = "Specimen mass differs from the model (it also sags further on its spring)."
    signature = "force residual ∝ the specimen's absolute acceleration; resonance shifts"

    def apply_spec(self, spec, value, bench):
        spec.geom(bench.specimen_geom).mass = bench.m_exp * (1.0 + value)


@register
class SpecimenDamping(Effect):
    name = "specimen_damping"
    stage = "spec"
    param = Param("dc", "1", 0.0, -1.0, 20.0, 0.5, "relative damping error: c' = (1 + dc)·c")
    description = "Specimen damping differs from the model."
    signature = "force residual ∝ specimen deformation rate, largest near resonance"

    def apply_spec(self, spec, value, bench):
        spec.joint(bench.specimen_joint).damping = np.array(
            [bench.c_exp * (1.0 + value), 0.0, 0.0])


@register
class ContactGap(Effect):
    name = "contact_gap"
    stage = "spec"
    param = Param("dh", "m", 0.0, -0.01, 0.01, 2e-4, "error of the gap to the contact surface")
    description = "The contact surface is dh further away than modelled (contact mismatch)."
    signature = "force residual only in and near contact phases"

    def apply_spec(self, spec, value, bench):
        g = spec.geom(bench.wall_geom)
        pos = np.array(g.pos)
        pos[2] += value
        g.pos = pos


def describe() -> list[dict[str, Any]]:
    """All effects as plain dicts (name, stage, parameter, unit, off, bounds, signature)."""
    from .base import REGISTRY

    rows = []
    for eff in REGISTRY.values():
        p = eff.param
        rows.append({"effect": eff.name, "stage": eff.stage, "param": p.name, "unit": p.unit,
                     "off": p.off, "lo": p.lo, "hi": p.hi, "scale": p.scale,
                     "candidate": eff.candidate, "needs_sim": eff.needs_sim,
                     "description": eff.description, "signature": eff.signature})
    return rows
