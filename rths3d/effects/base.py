"""The effect component: one physical effect of a bench with a parameter, bounds and an "off"
value, and where it acts.

An effect acts at exactly one *stage* of the bench (:class:`rths3d.bench.Bench`), the same in
the vRTHS loop, the diagnosis' replay and synthetic measurements:

``setpoint``
    a per-leg signal block of the platform's controller at the interface rate, between the
    inverse kinematics and the servo (transport delay, lag, rate limit, play, length offset):
    :meth:`Effect.block`; per-test values batch freely.
``spec``
    edits the bench's MuJoCo model (``mujoco.MjSpec``): leg friction, servo gain, masses,
    stiffnesses, compliance, contact geometry, the FTS mounting: :meth:`Effect.apply_spec`.
``geometry``
    moves an anchor of the true platform or offsets a leg encoder (kinematic calibration):
    :meth:`Effect.apply_geometry`; the controller keeps the nominal geometry.
``controller``
    a setting the controller gets wrong (gravity compensation): :meth:`Effect.apply_controller`.
``fts``
    the six-axis sensor's calibration (gain, cross-talk, offset of its 6×6 matrix):
    :meth:`Effect.apply_fts` on the matrix C and offset b of the reading ``C w + b``.
``sensor``
    dynamics of the measured interface force (a low-pass): a signal block on ``f_meas``.
``noise``
    white measurement noise on every recorded channel (the floor, never proposed).

Every effect has a single scalar parameter (SI unit stated in :class:`Param`) whose ``off``
value reproduces the baseline exactly: an effect at its off value is skipped. An effect has a
*target* where it acts on one part: ``leg`` (0–5; ``all_legs`` effects also take −1 for all
six) and/or an ``axis`` from :attr:`Effect.axes`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..errors import ConfigError

STAGES: tuple[str, ...] = ("geometry", "spec", "controller", "setpoint", "fts", "sensor",
                           "noise")
"""The stages in the order they are applied when a bench is built."""

SIM_STAGES = frozenset({"geometry", "spec", "controller", "setpoint"})
"""Stages that change the physics (a replay must re-simulate)."""

LEGS = tuple(range(6))


@dataclass(frozen=True)
class ProbeData:
    """What a probe of a candidate may be sized from (the diagnosis fills it).

    ``leg``: the candidate's leg (−1: all); ``setpoint_lengths``: a callable giving the
    controller's leg set-points (N, 6) (m) of the replayed poses, computed when first asked;
    ``measured``: the record's channels; ``dt``: the interface step (s).
    """

    leg: int
    setpoint_lengths: Any
    measured: Any
    dt: float


@dataclass(frozen=True)
class Param:
    """One effect parameter.

    Attributes
    ----------
    name, unit:
        Parameter name and SI unit (``"s"``, ``"N"``, ``"kg"``, ``"m/N"``, ``"1"``...).
    off:
        Value that switches the effect off (reproduces the baseline exactly).
    lo, hi:
        Bounds accepted for fitting and from the user.
    scale:
        A typical magnitude: the probe step of the screening and the fit's variable scale.
    """

    name: str
    unit: str
    off: float
    lo: float
    hi: float
    scale: float
    doc: str = ""

    def check(self, value: Any, effect: str) -> float:
        """``value`` as a float, or :class:`ConfigError` naming the field and the limits."""
        try:
            v = float(value)
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"{effect}.{self.name}", value, "must be a number") from exc
        if math.isnan(v) or not (self.lo <= v <= self.hi or v == self.off):
            raise ConfigError(f"{effect}.{self.name}", value,
                              f"must be within [{self.lo:g}, {self.hi:g}] {self.unit}")
        return v


class Effect:
    """Base class of a physical effect (subclass per effect; register with :func:`register`).

    Subclasses set the class attributes and implement the hook of their stage.
    """

    name: ClassVar[str] = ""
    stage: ClassVar[str] = ""
    param: ClassVar[Param]
    description: ClassVar[str] = ""
    signature: ClassVar[str] = ""
    """Where the residual shows when this effect is missing (for users and the report)."""
    candidate: ClassVar[bool] = True
    """False for effects the diagnosis never proposes (sensor noise is the floor)."""
    per_leg: ClassVar[bool] = False
    """The effect acts on one leg (``leg`` 0–5) or, with :attr:`all_legs`, on all (−1)."""
    all_legs: ClassVar[bool] = False
    axes: ClassVar[tuple[str, ...]] = ()
    """The axes it may act along (empty: it has no axis)."""
    lti: ClassVar[bool] = False
    """It applies to the 1-D chain transfer systems too (delay, lag, sensor effects)."""
    structural: ClassVar[bool] = False
    """It changes the model's structure (adds a body or geom): benches with and without it
    are not stepped together."""
    late: ClassVar[bool] = False
    """Applied after the other effects of its stage (e.g. a compliance in series with the
    servo acts on the servo's gain as the other effects left it)."""
    calibrated: ClassVar[bool] = False
    """Found together with others by a calibration (the kinematic calibration's anchors, the
    FTS calibration's matrix), not screened one at a time."""
    requires: ClassVar[tuple[str, ...]] = ()
    """What the part must have for the effect to exist on a bench: names of
    :class:`~rths3d.experiment.ExperimentalPart` flags (``has_contact``, ``has_spring``)."""
    followups: ClassVar[tuple[str, ...]] = ()
    """Calibrated effects screened next, on the same leg, when this one leads a screening."""
    floor: ClassVar[bool] = False
    """Measurement noise: the floor every residual is judged against, never part of a
    replayed bench."""

    @property
    def needs_sim(self) -> bool:
        """True if the effect changes the physics (a replay must re-simulate)."""
        return self.stage in SIM_STAGES

    def is_off(self, value: float) -> bool:
        """True if ``value`` is the off value (the effect is then skipped)."""
        off = self.param.off
        return value == off or (math.isinf(off) and math.isinf(value))

    def targets(self) -> list[tuple[int, str]]:
        """Every (leg, axis) the effect can act on (leg −1 / axis "" where it has none)."""
        legs = ([-1] if self.all_legs else []) + list(LEGS) if self.per_leg else [-1]
        axes = list(self.axes) or [""]
        return [(leg, ax) for leg in legs for ax in axes]

    def check_target(self, leg: int, axis: str) -> None:
        """ConfigError naming the field when (leg, axis) does not fit the effect."""
        if self.per_leg:
            ok = leg in LEGS or (self.all_legs and leg == -1)
            if not ok:
                lim = "0…5" + (" or -1 (all legs)" if self.all_legs else "")
                raise ConfigError(f"effect.{self.name}.leg", leg, f"must be {lim}")
        elif leg != -1:
            raise ConfigError(f"effect.{self.name}.leg", leg, "this effect has no leg")
        if self.axes:
            if axis not in self.axes:
                raise ConfigError(f"effect.{self.name}.axis", axis,
                                  f"must be one of {', '.join(self.axes)}")
        elif axis:
            raise ConfigError(f"effect.{self.name}.axis", axis, "this effect has no axis")

    # ------------------------------------------------------------------ hooks
    def block(self, K: int, values: np.ndarray, dt: float) -> Any:
        """The set-point block over K·6 leg rows (``values``: the parameter per row, the off
        value on rows it does not act on), or a sensor block over the f_meas rows."""
        raise NotImplementedError

    def apply_spec(self, spec: Any, value: float, ctx: Any, leg: int, axis: str) -> None:
        """Edit the bench ``MjSpec`` in place; ``ctx`` (the bench) gives nominal values."""
        raise NotImplementedError

    def apply_geometry(self, base: np.ndarray, top: np.ndarray, offsets: np.ndarray,
                       value: float, leg: int, axis: str) -> None:
        """Move anchors (6, 3) / encoder offsets (6,) of the true platform in place (m)."""
        raise NotImplementedError

    def apply_controller(self, ctl: dict[str, Any], value: float, leg: int, axis: str) -> None:
        """Edit the controller's settings (``gravity_scale``) in place."""
        raise NotImplementedError

    def apply_fts(self, C: np.ndarray, b: np.ndarray, value: float, axis: str) -> None:
        """Edit the FTS calibration matrix C (6, 6) and offset b (6,) in place."""
        raise NotImplementedError

    # ------------------------------------------------------------------ fitting help
    def exists_for(self, part: Any) -> bool:
        """Whether the effect can act on a bench with this part (an instance; a class
        answers for the flags it fixes as class attributes, a flag its instances decide —
        the user's MJCF part has a surface if its file has world bodies — counts as
        absent)."""
        return all(getattr(part, flag, False) is True for flag in self.requires)

    def probe_value(self, probe: ProbeData | None = None) -> float:
        """The value used to screen this effect (a typical magnitude); ``probe`` gives the
        replayed test's set-points and measurements to effects whose size depends on them."""
        return float(np.clip(self.param.off + self.param.scale, self.param.lo, self.param.hi))

    def __repr__(self) -> str:
        return f"<effect {self.name} ({self.param.name} [{self.param.unit}])>"


REGISTRY: dict[str, Effect] = {}
"""All registered effects by name (filled by :mod:`rths3d.effects.library`)."""


def register(cls: type[Effect]) -> type[Effect]:
    """Class decorator: add one instance of ``cls`` to :data:`REGISTRY`."""
    if cls.stage not in STAGES:
        raise ValueError(f"effect {cls.name}: unknown stage {cls.stage!r}")
    REGISTRY[cls.name] = cls()
    return cls


def get_effect(name: str) -> Effect:
    """The registered effect ``name`` or :class:`ConfigError` listing the known ones."""
    try:
        return REGISTRY[name]
    except KeyError:
        raise ConfigError("effect", name, "known effects: " + ", ".join(sorted(REGISTRY))) \
            from None


def parse_label(label: str) -> tuple[str, int, str]:
    """``name[.leg<i>][.<axis>]`` → (name, leg, axis), checked against the effect."""
    parts = label.strip().split(".")
    name = parts[0]
    eff = get_effect(name)
    leg, axis = -1, ""
    rest = parts[1:]
    if rest and rest[0].startswith("leg") and rest[0][3:].isdigit():
        leg = int(rest[0][3:])
        rest = rest[1:]
    if rest:
        axis = ".".join(rest)
    if eff.per_leg and leg == -1 and not eff.all_legs:
        raise ConfigError(f"effect.{name}.leg", None, "required: name.leg<i> (i = 0…5)")
    eff.check_target(leg, axis)
    return name, leg, axis


def parse_effect_arg(text: str) -> tuple[str, float | None]:
    """Parse ``LABEL`` or ``LABEL=value`` (value in the parameter's SI unit); LABEL is
    ``name[.leg<i>][.<axis>]``. Returns (label, value or None)."""
    label, sep, raw = text.partition("=")
    name, leg, axis = parse_label(label)
    eff = get_effect(name)
    lab = name + (f".leg{leg}" if leg >= 0 else "") + (f".{axis}" if axis else "")
    if not sep:
        return lab, None
    return lab, eff.param.check(raw.strip(), lab)


def bench_effects(scene: Any) -> dict[str, float]:
    """A scene's effects by label with their values, less the measurement noise (the floor a
    replay is compared against, not part of the bench it replays)."""
    return {e.label: e.value for e in scene.effects if not get_effect(e.name).floor}
