"""A compensator as a (K, n) callable, for users who step one piece on its own (beside the
actuator callables of :mod:`.actuators`): ``velocity``, ``polynomial`` or ``none`` from
:mod:`rths3d.compensation`, which the transfer systems build through
:mod:`.commands`."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..compensation import build

__all__ = ["Compensator"]


class Compensator:
    """Delay compensation of a (K, n) command: ``velocity`` z + τ_c ż (τ_c one or per test),
    ``polynomial`` (Lagrange extrapolation of ``order``), ``none``
    (:mod:`rths3d.compensation`)."""

    def __init__(self, K: int, n: int, kind: str, tau: float | Sequence[float], dt: float,
                 order: int = 2):
        if np.ndim(tau) and kind != "velocity":
            raise ValueError(f"per-test tau needs kind 'velocity', not {kind!r}")
        if kind == "polynomial":
            self.comp = build("polynomial", K, n, dt, {"tau": float(tau), "order": order})
        elif kind == "velocity":
            taus = tuple(float(t) for t in np.ravel(tau)) if np.ndim(tau) else float(tau)
            self.comp = build("velocity", K, n, dt, {"tau": taus})
        else:
            self.comp = build("none", K, n, dt)
        self.kind = kind

    def reset(self) -> None:
        self.comp.reset()

    def __call__(self, z: np.ndarray, zdot: np.ndarray) -> np.ndarray:
        return self.comp.command(z, zdot, z)
