"""``velocity``: velocity feed-forward u = z + τ_c ż (Horiuchi; Nakashima)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .base import (
    BaseCompensator,
    CompensatorConfig,
    channel_values,
    check,
    comp_kernel,
    comp_ready,
    register,
)


@comp_kernel
def velocity_kernel(p, s, z, zd, zm, u):
    """u = ż τ_c + z per row (τ_c = 0: u = z)."""
    for r in range(z.shape[0]):
        u[r] = zd[r] * p[r, 0] + z[r]
    return False


@dataclass(frozen=True)
class VelocityConfig(CompensatorConfig):
    """``tau``: compensation time τ_c (s), ≈ the transfer system's delay; one value, or one
    per test (K values, so that tests with different τ_c — 0 for none — step together)."""

    tau: float | tuple[float, ...] = 0.0

    def __post_init__(self) -> None:
        vals = self.tau if isinstance(self.tau, tuple) else (self.tau,)
        check("velocity.tau", self.tau, all(math.isfinite(v) and 0.0 <= v <= 0.5 for v in vals),
              "must be in [0, 0.5] s")


@register
class VelocityCompensator(BaseCompensator):
    """u = z + τ_c ż, the same operations as the transfer system's fixed ``velocity``
    compensation (results equal bit for bit)."""

    name = "velocity"
    rank = 10
    Config = VelocityConfig

    def __init__(self, config: VelocityConfig, K: int, n: int, dt: float):
        super().__init__(config, K, n, dt)
        comp_ready(velocity_kernel)
        self.tau = channel_values("velocity.tau", config.tau, K, n, per="test")
        self._params = np.array(self.tau.reshape(-1, 1))  # writable (a kernel argument)
        self._state = np.zeros((K * n, 0))

    def command(self, z: np.ndarray, zdot: np.ndarray, z_meas: np.ndarray) -> np.ndarray:
        velocity_kernel(self._params, self._state, np.ascontiguousarray(z).reshape(-1),
                        np.ascontiguousarray(zdot).reshape(-1), self.u.reshape(-1),
                        self.u.reshape(-1))
        self.calls += 1
        return self.u

    def compiled(self):
        return (velocity_kernel,), self._params, self._state

    def coefficients(self) -> dict[str, np.ndarray]:
        return {"tau": self.tau}

    def history(self) -> np.ndarray:
        return self.tau[..., None]


def calibrate(u: np.ndarray, z_meas: np.ndarray, dt: float,
              config: VelocityConfig | None = None) -> VelocityConfig:
    """τ_c from a recorded test: the measured delay (:func:`~.base.measured_delay`)."""
    from .base import measured_delay

    config = config or VelocityConfig()
    return replace(config, tau=min(0.5, max(0.0, measured_delay(u, z_meas, dt))))
