"""``lead``: a fixed phase-lead (lead–lag) filter on the command, u = G_T(s) z, discretised
by Tustin — the outer compensation of the RTHS benchmark's sample controller (Silva et al.
2020, Eq. 24: G_T = 50.8 (s + 168.6)/(s + 8570), DC gain 1), and of many fixed RTHS
controllers."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..errors import ConfigError
from .base import BaseCompensator, CompensatorConfig, check, register


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


@njit(cache=True, nogil=True)
def _df1(b, a, xh, yh, z, u):
    """Direct form I, y = Σ b_i x_{−i} − Σ_{i≥1} a_i y_{−i}, per channel (a[0] = 1)."""
    K, n = z.shape
    m = b.size - 1
    for k in range(K):
        for j in range(n):
            x = z[k, j]
            y = b[0] * x
            for i in range(1, m + 1):
                y = y + b[i] * xh[k, j, i - 1]
            for i in range(1, m + 1):
                y = y - a[i] * yh[k, j, i - 1]
            for i in range(m - 1, 0, -1):
                xh[k, j, i] = xh[k, j, i - 1]
                yh[k, j, i] = yh[k, j, i - 1]
            if m > 0:
                xh[k, j, 0] = x
                yh[k, j, 0] = y
            u[k, j] = y


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
        self.xh = np.zeros((K, n, max(m - 1, 1)))
        self.yh = np.zeros((K, n, max(m - 1, 1)))

    def reset(self) -> None:
        super().reset()
        self.xh[:] = 0.0
        self.yh[:] = 0.0

    def command(self, z: np.ndarray, zdot: np.ndarray, z_meas: np.ndarray) -> np.ndarray:
        _df1(self.b, self.a, self.xh, self.yh, z, self.u)
        self.calls += 1
        return self.u

    def dcgain(self) -> float:
        return float(np.sum(self.b) / np.sum(self.a))
