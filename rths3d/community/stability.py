"""Stability of the benchmark loop as a linear discrete-time system.

Without quantisation and noise, one loop step (SPEC §7) is linear in the 18 loop states
``[z (6), p (5), x_{k−1}, v_{k−1}, f_{k−1}, u1_{k−1}, y_pl,k−1, e_{k−1}, y_pi,k−1]``. The loop
is asymptotically stable iff the spectral radius of that step matrix is below 1; quantisation
only adds bounded noise of 2⁻¹⁹ m.
"""

from __future__ import annotations

import numpy as np

from ..lti import affine_step_matrices
from .config import BenchmarkConfig
from .plant import PlantParams
from .simulate import _controller_coeffs, _prepare

__all__ = ["loop_matrix", "spectral_radius"]


def loop_matrix(cfg: BenchmarkConfig, plant: PlantParams | None = None) -> np.ndarray:
    """The 18×18 matrix of one homogeneous loop step (no ground motion, no converters)."""
    plant = plant or cfg.plant
    _, Phi_n, _, gf, Phi_p, gy, gx = _prepare(cfg, plant)
    lb0, lb1, la1, pb0, pb1, pg = _controller_coeffs(cfg)
    h = cfg.dt
    ke, ce, me = plant.k_e, plant.c_e, plant.m_e
    delay = cfg.force_delay

    def step(s: np.ndarray, _u: np.ndarray) -> np.ndarray:
        z, p = s[:6], s[6:11]
        xprev, vprev, fdel, u1p, yplp, ep, ypip = s[11:18]
        x = p[3]
        v = (x - xprev) / h
        a = (v - vprev) / h
        fm = ke * x + ce * v + me * a
        u1 = z[0]
        ypl = lb0 * u1 + lb1 * u1p - la1 * yplp
        e = ypl - x
        ypi = pg * ypip + pb0 * e + pb1 * ep
        zn = Phi_n @ z + gf * (fdel if delay else fm)
        pn = Phi_p @ p + gy * ypi + gx * xprev
        return np.concatenate([zn, pn, [x, v, fm, u1, ypl, e, ypi]])

    Phi, _ = affine_step_matrices(step, 18, 1)
    return Phi


def spectral_radius(cfg: BenchmarkConfig, plant: PlantParams | None = None) -> float:
    """Largest |eigenvalue| of :func:`loop_matrix` (< 1: stable)."""
    return float(np.max(np.abs(np.linalg.eigvals(loop_matrix(cfg, plant)))))
