"""``lead``: a fixed phase-lead (lead–lag) filter on the command, u = G_T(s) z, discretised
by Tustin — the outer compensation of the RTHS benchmark's sample controller (Silva et al.
2020, Eq. 24: G_T = 50.8 (s + 168.6)/(s + 8570), DC gain 1), and of many fixed RTHS
controllers."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError
from .base import (
    BaseCompensator,
    CompensatorConfig,
    check,
    comp_kernel,
    comp_ready,
    register,
)


@dataclass(frozen=True)
class LeadConfig(CompensatorConfig):
    """``num``, ``den``: the continuous filter N(s)/D(s) (proper), coefficients in descending
    powers of s. Default: the benchmark's G_T = (50.8316 s + 8570.40)/(s + 8570.40)."""

    num: tuple[float, ...] = (50.83163360273612, 8570.397339444286)
    den: tuple[float, ...] = (1.0, 8570.397339444286)

    def __post_init__(self) -> None:
        ok = (len(self.num) >= 1 and len(self.den) >= 1
              and all(math.isfinite(v) for v in (*self.num, *self.den)))
        check("lead.num", list(self.num), ok, "must be finite coefficients")
        den = np.trim_zeros(np.asarray(self.den, float), "f")
        num = np.trim_zeros(np.asarray(self.num, float), "f")
        check("lead.den", list(self.den), den.size >= max(num.size, 1),
              "must be proper (deg den ≥ deg num, den ≠ 0)")


@comp_kernel
def lead_kernel(p, s, z, zd, zm, u):
    """Direct form I per row, y = Σ b_i x_{−i} − Σ_{i≥1} a_i y_{−i} (a_0 = 1): ``p`` row
    (b_0 … b_m, a_0 … a_m), ``s`` row (x_{−1} … x_{−m}, y_{−1} … y_{−m})."""
    m = p.shape[1] // 2 - 1
    for r in range(z.shape[0]):
        x = z[r]
        y = p[r, 0] * x
        for i in range(1, m + 1):
            y = y + p[r, i] * s[r, i - 1]
        for i in range(1, m + 1):
            y = y - p[r, m + 1 + i] * s[r, m + i - 1]
        for i in range(m - 1, 0, -1):
            s[r, i] = s[r, i - 1]
            s[r, m + i] = s[r, m + i - 1]
        if m > 0:
            s[r, 0] = x
            s[r, m] = y
        u[r] = y
    return False


@register
class LeadCompensator(BaseCompensator):
    """u = G_T(q) z with G_T discretised by Tustin at dt (``rths3d.lti.lead_lag``)."""

    name = "lead"
    rank = 30
    Config = LeadConfig

    def __init__(self, config: LeadConfig, K: int, n: int, dt: float):
        super().__init__(config, K, n, dt)
        from ..lti import lead_lag

        try:
            de = lead_lag(config.num, config.den, dt)
        except ConfigError as exc:
            raise ConfigError(f"lead.{exc.field}", exc.value, exc.limit) from None
        m = max(len(de.a), len(de.b))
        self.b = np.zeros(m)
        self.a = np.zeros(m)
        self.b[:len(de.b)] = de.b
        self.a[:len(de.a)] = de.a
        comp_ready(lead_kernel)
        # the coefficients per row and the delay lines (x then y), the kernel's own arrays
        self._params = np.tile(np.concatenate([self.b, self.a]), (K * n, 1))
        self._state = np.zeros((K * n, 2 * max(m - 1, 1)))

    def reset(self) -> None:
        super().reset()
        self._state[:] = 0.0

    def command(self, z: np.ndarray, zdot: np.ndarray, z_meas: np.ndarray) -> np.ndarray:
        flat = self.u.reshape(-1)
        lead_kernel(self._params, self._state, np.ascontiguousarray(z).reshape(-1), flat,
                    flat, flat)
        self.calls += 1
        return self.u

    def compiled(self):
        return (lead_kernel,), self._params, self._state

    def dcgain(self) -> float:
        return float(np.sum(self.b) / np.sum(self.a))
