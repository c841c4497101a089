"""``none``: the command is the desired displacement, u = z."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import BaseCompensator, CompensatorConfig, register


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
