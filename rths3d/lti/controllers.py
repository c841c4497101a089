"""Discrete controllers: difference equations, PI, lead/lag, built from scene data.

A controller is a :class:`DifferenceEquation`
``y[k] = Σ_{i≥0} b_i u[k−i] − Σ_{i≥1} a_i y[k−i]`` (``a[0] = 1``; powers of z⁻¹), obtained
from a continuous design by Tustin (python-control ``sample_system``; MATLAB
``c2d(..., 'tustin')``, without prewarping unless asked), or given directly. For a PI
controller ``G_C(s) = K_p + K_i/s`` this gives
``y[k] = y[k−1] + (K_p + K_i T_s/2) e[k] − (K_p − K_i T_s/2) e[k−1]``. ``to_tf`` / ``to_ss``
give the python-control objects for analysis, ``scalar`` / ``batch`` the per-step steppers.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from numbers import Real
from typing import Any

import control
import numpy as np
import scipy.signal

from ..errors import ConfigError
from .discretize import DiscreteSS, tustin_tf
from .stepper import ScalarStepper, StateSpaceStepper

__all__ = ["DifferenceEquation", "controller_from_dict", "lead_lag", "pi_controller"]


@dataclass(frozen=True)
class DifferenceEquation:
    """Discrete SISO transfer function ``b(z⁻¹)/a(z⁻¹)`` with sample period ``dt`` (s)."""

    b: tuple[float, ...]
    a: tuple[float, ...]
    dt: float

    def __post_init__(self) -> None:
        if len(self.a) == 0 or self.a[0] == 0.0:
            raise ConfigError("controller.a", list(self.a), "a[0] must be nonzero")
        if len(self.b) == 0:
            raise ConfigError("controller.b", list(self.b), "needs at least one coefficient")
        if not all(np.isfinite(v) for v in (*self.b, *self.a)):
            raise ConfigError("controller", (self.b, self.a), "coefficients must be finite")
        if not (self.dt > 0.0):
            raise ConfigError("controller.dt", self.dt, "must be > 0 s")

    @classmethod
    def from_arrays(cls, b: Sequence[float], a: Sequence[float], dt: float
                    ) -> DifferenceEquation:
        """Normalised so that ``a[0] = 1``."""
        a0 = float(a[0]) if len(a) else 0.0
        if a0 == 0.0:
            raise ConfigError("controller.a", list(a), "a[0] must be nonzero")
        return cls(tuple(float(v) / a0 for v in b), tuple(float(v) / a0 for v in a), float(dt))

    def to_tf(self) -> control.TransferFunction:
        """The discrete transfer function ``b(z⁻¹)/a(z⁻¹)`` as a python-control object."""
        n = max(len(self.a), len(self.b))
        b = np.concatenate([self.b, np.zeros(n - len(self.b))])
        a = np.concatenate([self.a, np.zeros(n - len(self.a))])
        return control.tf(b, a, self.dt)

    def to_ss(self) -> DiscreteSS:
        """A state-space realisation (``control.tf2ss``: controllable canonical form)."""
        return DiscreteSS(control.tf2ss(self.to_tf()), method="difference")

    def scalar(self) -> ScalarStepper:
        """A plain-float stepper: ``step(u: float) -> float`` (K = 1 hot loop)."""
        return ScalarStepper((np.asarray(self.b), np.asarray(self.a)))

    def batch(self, K: int) -> StateSpaceStepper:
        """A stepper for K tests: ``step(u (K, 1)) -> y (K, 1)``."""
        return StateSpaceStepper(self.to_ss(), K)

    def dcgain(self) -> float:
        """``Σb / Σa`` (inf for an integrator)."""
        sa = float(np.sum(self.a))
        return float(np.sum(self.b)) / sa if sa != 0.0 else float("inf")

    def filter(self, u: np.ndarray) -> np.ndarray:
        """Response to the whole sequence ``u`` from rest (vectorised)."""
        return scipy.signal.lfilter(self.b, self.a, np.asarray(u, dtype=float))


def number_field(field: str, value: Any) -> float:
    """``value`` as a float, or ConfigError ``field: value (must be a number)``."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, Real):
        raise ConfigError(field, value, "must be a number")
    return float(value)


def numbers_field(field: str, value: Any) -> tuple[float, ...]:
    """``value`` as a tuple of floats, or ConfigError ``field: value (must be a list of
    numbers)``."""
    if isinstance(value, str | bytes | Mapping) or not isinstance(value, Sequence | np.ndarray):
        raise ConfigError(field, value, "must be a list of numbers")
    if not all(isinstance(v, Real) and not isinstance(v, bool | np.bool_) for v in value):
        raise ConfigError(field, value, "must be a list of numbers")
    return tuple(float(v) for v in value)


def pi_controller(kp: float, ki: float, dt: float) -> DifferenceEquation:
    """Tustin discretisation of ``G_C(s) = K_p + K_i/s`` (K_p dimensionless, K_i in 1/s):
    ``b = (K_p + K_i T/2, −(K_p − K_i T/2))``, ``a = (1, −1)``."""
    for name, v in (("controller.kp", kp), ("controller.ki", ki)):
        if not np.isfinite(v):
            raise ConfigError(name, v, "must be finite")
    b, a = tustin_tf([kp, ki], [1.0, 0.0], dt)
    return DifferenceEquation.from_arrays(b, a, dt)


def lead_lag(num: Sequence[float], den: Sequence[float], dt: float,
             prewarp: float | None = None) -> DifferenceEquation:
    """Tustin discretisation of a continuous compensator ``N(s)/D(s)`` (e.g. a phase lead),
    prewarped at ``prewarp`` rad/s if given (:func:`~.discretize.tustin_tf`)."""
    b, a = tustin_tf(num, den, dt, prewarp)
    return DifferenceEquation.from_arrays(b, a, dt)


def controller_from_dict(spec: Mapping[str, Any], dt: float, field: str = "controller"
                         ) -> DifferenceEquation:
    """Build a controller from scene data.

    Accepted forms (``type`` key):

    * ``{"type": "pi", "kp": 2.0, "ki": 95.0}``
    * ``{"type": "tf", "num": [...], "den": [...]}`` — continuous, discretised by Tustin;
      an optional ``"prewarp": ω₀`` (rad/s) matches it at ω₀
    * ``{"type": "difference", "b": [...], "a": [...]}`` — already discrete at ``dt``
    """
    kind = spec.get("type")
    try:
        if kind == "pi":
            return pi_controller(number_field(f"{field}.kp", spec["kp"]),
                                 number_field(f"{field}.ki", spec["ki"]), dt)
        if kind == "tf":
            w = spec.get("prewarp")
            try:
                return lead_lag(numbers_field(f"{field}.num", spec["num"]),
                                numbers_field(f"{field}.den", spec["den"]), dt,
                                None if w is None else number_field(f"{field}.prewarp", w))
            except ConfigError as exc:
                if exc.field == "prewarp":
                    raise ConfigError(f"{field}.prewarp", exc.value, exc.limit) from None
                raise
        if kind == "difference":
            return DifferenceEquation.from_arrays(numbers_field(f"{field}.b", spec["b"]),
                                                  numbers_field(f"{field}.a", spec["a"]), dt)
    except KeyError as exc:
        raise ConfigError(f"{field}.{exc.args[0]}", None, f"required for type {kind!r}") \
            from exc
    raise ConfigError(f"{field}.type", kind, "must be one of 'pi', 'tf', 'difference'")
