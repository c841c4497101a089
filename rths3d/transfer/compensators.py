"""Delay compensation of the command: one class per compensator, registered by name.

A compensator acts on the command the actuators receive, K tests × n channels, once per
step: ``u = compensate(z, ż, z_m)`` with z the numerical substructure's command for the end
of the step, ż its rate and z_m the latest measured displacement. Its per-step physics is a
numba kernel of signature :data:`COMP_SIG`, called by the compiled loop and, through
:meth:`Compensator.__call__`, from Python. ``none`` passes z through.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, ClassVar

import numba
import numpy as np
from numba import types

from ..effects.blocks import F1, F2
from ..errors import ConfigError

__all__ = ["COMP_SIG", "COMPENSATORS", "Compensator", "NoCompensation",
           "PolynomialExtrapolation", "VelocityFeedForward", "compensator_class",
           "compensator_kinds", "register_compensator"]

COMP_SIG = types.void(F2, F2, F1, F1, F1, F1)
"""Kernel signature: (params (R, P), state (R, S), z (R,), ż (R,), z_m (R,), u (R,))."""


def comp_kernel(fn: Any) -> Any:
    """Compile ``fn`` as a compensator kernel (:data:`COMP_SIG`, cached)."""
    return numba.njit(COMP_SIG, cache=True, nogil=True)(fn)


class Compensator:
    """Base class (see the module docstring). Subclasses set :attr:`name` and :attr:`kernel`
    and fill ``params`` (R, P) and ``state0`` (R, S), R = K·n rows."""

    name: ClassVar[str] = ""
    kernel: ClassVar[Any]

    def __init__(self, K: int, n: int, params: np.ndarray, state0: np.ndarray):
        self.K, self.n = int(K), int(n)
        self.params = np.ascontiguousarray(params, dtype=float)
        self.state0 = np.ascontiguousarray(state0, dtype=float)
        self.state = self.state0.copy()
        self.out = np.zeros((self.K, self.n))
        self._zm = np.zeros(self.K * self.n)

    @classmethod
    def from_scenes(cls, scenes: Sequence[Any], n: int) -> Compensator:
        """The compensator of K tests from their transfer settings."""
        raise NotImplementedError

    @classmethod
    def batch_key(cls, settings: dict[str, Any]) -> tuple:
        """What must be equal for tests stepped together, from their flat settings
        (``transfer.*``); the compensation times are per test."""
        return (cls.name,)

    def reset(self) -> None:
        self.state[:] = self.state0

    def coefficients(self) -> dict[str, np.ndarray]:
        """Current coefficients per test and channel ((K, n) arrays), for records."""
        return {}

    def __call__(self, z: np.ndarray, zdot: np.ndarray,
                 z_meas: np.ndarray | None = None) -> np.ndarray:
        zm = self._zm if z_meas is None else np.ascontiguousarray(z_meas).reshape(-1)
        type(self).kernel(self.params, self.state, np.ascontiguousarray(z).reshape(-1),
                          np.ascontiguousarray(zdot).reshape(-1), zm, self.out.reshape(-1))
        return self.out


COMPENSATORS: dict[str, type[Compensator]] = {}


def register_compensator(cls: type[Compensator]) -> type[Compensator]:
    """Class decorator: register ``cls`` under ``cls.name``."""
    COMPENSATORS[cls.name] = cls
    return cls


def compensator_kinds() -> tuple[str, ...]:
    """The registered compensators."""
    return tuple(COMPENSATORS)


def compensator_class(name: str) -> type[Compensator]:
    """The compensator ``name`` or a ConfigError naming the registered ones."""
    try:
        return COMPENSATORS[name]
    except KeyError:
        raise ConfigError("transfer.compensation", name,
                          f"must be one of {', '.join(COMPENSATORS)}") from None


@comp_kernel
def _velocity_kernel(p, s, z, zd, zm, u):
    # u = z + τ_c ż, τ_c per row (0: none)
    for r in range(z.shape[0]):
        u[r] = zd[r] * p[r, 0] + z[r]


@comp_kernel
def _polynomial_kernel(p, s, z, zd, zm, u):
    # Lagrange extrapolation τ_c ahead through the last order+1 commands; state: history,
    # newest first; params: the weights
    m = s.shape[1]
    for r in range(z.shape[0]):
        for j in range(m - 1, 0, -1):
            s[r, j] = s[r, j - 1]
        s[r, 0] = z[r]
        acc = p[r, 0] * s[r, 0]
        for j in range(1, m):
            acc += p[r, j] * s[r, j]
        u[r] = acc


@register_compensator
class NoCompensation(Compensator):
    """u = z."""

    name = "none"
    kernel = _velocity_kernel

    def __init__(self, K: int, n: int):
        super().__init__(K, n, np.zeros((K * n, 1)), np.zeros((K * n, 0)))

    @classmethod
    def from_scenes(cls, scenes: Sequence[Any], n: int) -> Compensator:
        # τ_c = 0 of velocity feed-forward: tests without compensation step with those
        # that have it
        return VelocityFeedForward.from_scenes(scenes, n)

    @classmethod
    def batch_key(cls, settings: dict[str, Any]) -> tuple:
        return VelocityFeedForward.batch_key(settings)


@register_compensator
class VelocityFeedForward(Compensator):
    """u = z + τ_c ż with a compensation time τ_c (s) per test (0: none), so that tests
    with and without it are stepped together."""

    name = "velocity"
    kernel = _velocity_kernel

    def __init__(self, K: int, n: int, tau: float | Sequence[float]):
        t = np.asarray(tau, dtype=float).reshape(-1)
        t = np.full(K, float(t[0])) if t.size == 1 else t
        if t.size != K:
            raise ValueError(f"tau: {t.size} given for K = {K} tests")
        super().__init__(K, n, np.repeat(t, n)[:, None], np.zeros((K * n, 0)))
        self.tau = t

    @classmethod
    def from_scenes(cls, scenes: Sequence[Any], n: int) -> Compensator:
        return cls(len(scenes), n, [s.transfer.comp_time if s.transfer.compensation ==
                                    "velocity" else 0.0 for s in scenes])

    def coefficients(self) -> dict[str, np.ndarray]:
        return {"tau": self.params[:, 0].reshape(self.K, self.n)}


def lagrange_weights(tau: float, dt: float, order: int) -> np.ndarray:
    """Weights extrapolating samples at t_n, t_{n−1}, … to t_n + τ (Lagrange)."""
    s = tau / dt
    nodes = -np.arange(order + 1, dtype=float)
    w = np.ones(order + 1)
    for j in range(order + 1):
        for m in range(order + 1):
            if m != j:
                w[j] *= (s - nodes[m]) / (nodes[j] - nodes[m])
    return w


@register_compensator
class PolynomialExtrapolation(Compensator):
    """u = p(t + τ_c), p the polynomial of ``order`` through the last order+1 commands
    (Lagrange extrapolation; Horiuchi, Nakashima). τ_c per test; one order for all."""

    name = "polynomial"
    kernel = _polynomial_kernel

    def __init__(self, K: int, n: int, tau: float | Sequence[float], dt: float, order: int = 2):
        t = np.asarray(tau, dtype=float).reshape(-1)
        t = np.full(K, float(t[0])) if t.size == 1 else t
        w = np.stack([lagrange_weights(float(x), dt, order) for x in t])
        super().__init__(K, n, np.repeat(w, n, axis=0), np.zeros((K * n, order + 1)))
        self.order = int(order)

    @classmethod
    def from_scenes(cls, scenes: Sequence[Any], n: int) -> Compensator:
        tr = scenes[0].transfer
        return cls(len(scenes), n, [s.transfer.comp_time for s in scenes], scenes[0].dt,
                   tr.poly_order)

    @classmethod
    def batch_key(cls, settings: dict[str, Any]) -> tuple:
        return (cls.name, settings.get("transfer.poly_order", 2))
