"""``polynomial``: Lagrange extrapolation of the desired displacement τ_c ahead through the
last order + 1 samples (Horiuchi et al.; OpenFresco's predictor P0–P3)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .base import BaseCompensator, CompensatorConfig, check, comp_kernel, comp_ready, register


@comp_kernel
def polynomial_kernel(p, s, z, zd, zm, u):
    """Shift the history (newest first) and extrapolate: u = Σ_j w_j z_{n−j}; ``p`` rows:
    the weights, ``s`` rows: the history."""
    m = s.shape[1]
    for r in range(z.shape[0]):
        for j in range(m - 1, 0, -1):
            s[r, j] = s[r, j - 1]
        s[r, 0] = z[r]
        acc = p[r, 0] * s[r, 0]
        for j in range(1, m):
            acc += p[r, j] * s[r, j]
        u[r] = acc
    return False


def lagrange_weights(tau: float, dt: float, order: int) -> np.ndarray:
    """Weights w_j of the samples at t_n − j·dt (j = 0…order) for the value at t_n + τ."""
    s = tau / dt
    nodes = -np.arange(order + 1, dtype=float)
    w = np.ones(order + 1)
    for j in range(order + 1):
        for m in range(order + 1):
            if m != j:
                w[j] *= (s - nodes[m]) / (nodes[j] - nodes[m])
    return w


@dataclass(frozen=True)
class PolynomialConfig(CompensatorConfig):
    """``tau``: extrapolation time τ_c (s); ``order``: polynomial order 1…4 (order + 1
    samples)."""

    tau: float = 0.0
    order: int = 2

    def __post_init__(self) -> None:
        check("polynomial.tau", self.tau, math.isfinite(self.tau) and 0.0 <= self.tau <= 0.5,
              "must be in [0, 0.5] s")
        check("polynomial.order", self.order, 1 <= self.order <= 4, "must be in 1…4")


@register
class PolynomialCompensator(BaseCompensator):
    """u_n = Σ_j w_j z_{n−j}, w the Lagrange weights for t_n + τ_c (same operations as the
    transfer system's fixed ``polynomial`` compensation; equal bit for bit)."""

    name = "polynomial"
    rank = 20
    Config = PolynomialConfig

    def __init__(self, config: PolynomialConfig, K: int, n: int, dt: float):
        super().__init__(config, K, n, dt)
        comp_ready(polynomial_kernel)
        self.order = int(config.order)
        self.w = lagrange_weights(config.tau, dt, self.order)
        self._tau = np.full((K, n), float(config.tau))
        self._params = np.ascontiguousarray(np.tile(self.w, (K * n, 1)))
        self.hist = np.zeros((K * n, self.order + 1))
        """The last order + 1 commands per row, newest first."""

    def reset(self) -> None:
        super().reset()
        self.hist[:] = 0.0

    def command(self, z: np.ndarray, zdot: np.ndarray, z_meas: np.ndarray) -> np.ndarray:
        self.calls += 1
        polynomial_kernel(self._params, self.hist, np.ascontiguousarray(z).reshape(-1),
                          np.ascontiguousarray(zdot).reshape(-1), self.u.reshape(-1),
                          self.u.reshape(-1))
        return self.u

    def compiled(self):
        return (polynomial_kernel,), self._params, self.hist

    def coefficients(self) -> dict[str, np.ndarray]:
        return {"tau": self._tau}

    def history(self) -> np.ndarray:
        return self._tau[..., None]


def calibrate(u: np.ndarray, z_meas: np.ndarray, dt: float,
              config: PolynomialConfig | None = None) -> PolynomialConfig:
    """τ_c from a recorded test: the measured delay (:func:`~.base.measured_delay`)."""
    from .base import measured_delay

    config = config or PolynomialConfig()
    return replace(config, tau=min(0.5, max(0.0, measured_delay(u, z_meas, dt))))
