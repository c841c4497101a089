"""``none``: the command is the desired displacement, u = z."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import BaseCompensator, CompensatorConfig, comp_kernel, comp_ready, register


@comp_kernel
def copy_kernel(p, s, z, zd, zm, u):
    """u = z."""
    for r in range(z.shape[0]):
        u[r] = z[r]
    return False


@dataclass(frozen=True)
class NoneConfig(CompensatorConfig):
    """No parameters."""


@register
class NoCompensation(BaseCompensator):
    """u = z (a copy in the compensator's buffer)."""

    name = "none"
    rank = 0
    Config = NoneConfig

    def command(self, z: np.ndarray, zdot: np.ndarray, z_meas: np.ndarray) -> np.ndarray:
        np.copyto(self.u, z)
        self.calls += 1
        return self.u

    def compiled(self):
        R = self.K * self.n
        return (comp_ready(copy_kernel),), np.zeros((R, 0)), np.zeros((R, 0))
