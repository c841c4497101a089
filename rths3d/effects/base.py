"""The effect component: one physical effect with parameters, bounds and an "off" value.

An effect acts at exactly one *stage* of the model of a bench:

``command``
    edits the commanded interface displacement before it reaches the actuators
    (velocity saturation, backlash); needs a re-simulation.
``spec``
    edits the MuJoCo model (``mujoco.MjSpec``) of the bench (friction, masses, stiffnesses,
    compliance, contact geometry); needs a re-simulation.
``dynamics``, ``sensor_dynamics``, ``sensor``, ``noise``, ``adc``
    act on the replayed output signals only (transport delay, actuator lag, force-sensor
    low-pass, gain / offset / cross-talk, noise, quantisation), applied in that order,
    without re-simulating.

Every effect has a single scalar parameter (SI unit stated in :class:`Param`) whose ``off``
value reproduces the baseline model *exactly*: an effect at its off value is skipped.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..errors import ConfigError

STAGES: tuple[str, ...] = ("command", "spec", "dynamics", "sensor_dynamics", "sensor", "noise",
                           "adc")
"""Order in which effect stages act on the model (first to last)."""

SIM_STAGES = frozenset({"command", "spec"})
"""Stages that change the physics and therefore need a re-simulation."""


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

    def check(self, value: float, effect: str) -> float:
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

    Subclasses set the class attributes and implement the hook of their stage:
    :meth:`apply_command`, :meth:`apply_spec` or :meth:`apply_output`.
    """

    name: ClassVar[str] = ""
    stage: ClassVar[str] = ""
    param: ClassVar[Param]
    description: ClassVar[str] = ""
    signature: ClassVar[str] = ""
    """Where the residual shows when this effect is missing (for users and the report)."""
    candidate: ClassVar[bool] = True
    """False for effects the diagnosis never proposes (sensor noise is the floor, not a fault)."""
    channels: ClassVar[tuple[str, ...]] = ()
    """Output channels an output-stage effect acts on (empty: all)."""

    @property
    def needs_sim(self) -> bool:
        """True if the effect changes the physics (command or spec stage)."""
        return self.stage in SIM_STAGES

    def is_off(self, value: float) -> bool:
        """True if ``value`` is the off value (the effect is then skipped)."""
        off = self.param.off
        return value == off or (math.isinf(off) and math.isinf(value))

    # ------------------------------------------------------------------ hooks
    def apply_command(self, z_cmd: np.ndarray, dt: float, value: float) -> np.ndarray:
        """Commanded displacement (m) after the effect (command stage)."""
        raise NotImplementedError

    def apply_spec(self, spec: Any, value: float, bench: Any) -> None:
        """Edit the bench ``MjSpec`` in place (spec stage); ``bench`` gives nominal values."""
        raise NotImplementedError

    def apply_output(self, out: dict[str, np.ndarray], dt: float, value: float,
                     rng: np.random.Generator | None = None) -> None:
        """Edit the output signals in place (output stages)."""
        raise NotImplementedError

    def block(self, K: int, n: int, dt: float, value: float) -> Any:
        """The per-step :class:`~rths3d.effects.blocks.Block` of a signal effect at ``value``
        (K tests × n channels, step ``dt``): what the loop's chains apply and what
        :meth:`apply_output` runs over a replay. None for effects of other stages."""
        return None

    # ------------------------------------------------------------------ fitting help
    def initial_guess(self, measured: dict[str, np.ndarray], model: dict[str, np.ndarray],
                      command: np.ndarray, dt: float) -> float | None:
        """A signature-based start value for the fit (None: use ``param.off + param.scale``)."""
        return None

    def probe(self, measured: dict[str, np.ndarray], model: dict[str, np.ndarray],
              command: np.ndarray, dt: float) -> float:
        """The parameter value used to screen this effect (a typical magnitude)."""
        guess = self.initial_guess(measured, model, command, dt)
        if guess is not None and not self.is_off(guess):
            return float(np.clip(guess, self.param.lo, self.param.hi))
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


def parse_effect_arg(text: str) -> tuple[str, float | None]:
    """Parse ``EFFECT`` or ``EFFECT=value`` (value in the parameter's SI unit)."""
    name, sep, raw = text.partition("=")
    eff = get_effect(name.strip())
    if not sep:
        return eff.name, None
    return eff.name, eff.param.check(raw.strip(), eff.name)
