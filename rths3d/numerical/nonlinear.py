"""A nonlinear numerical substructure: the template for plugging in your own.

:class:`CubicSpringSubstructure` is a single-DOF mass on a linear spring and damper plus a
cubic (Duffing) spring, ``m ẍ + c ẋ + k x + k₃ x³ = p(t) − F'_m``, integrated with classical
Runge–Kutta over each interface step (load p interpolated linearly; the interface force held,
or interpolated to ``f_next`` for the reference). It implements the
:class:`~rths3d.numerical.NumericalSubstructure` protocol, so ``rths3d.loop.run(scene,
numerical=lambda scenes: CubicSpringSubstructure.from_scenes(scenes, k3=...))`` runs it in
the loop and in the reference. With ``k₃ = 0`` it reproduces the linear substructure.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .excitation import load_history


class CubicSpringSubstructure:
    """K single-DOF Duffing oscillators stepped together (SI: kg, N·s/m, N/m, N/m³).

    ``p``: load history (K, N+1, 1) on the grid t_k = k·ΔT.
    """

    def __init__(self, m, c, k, k3, p: np.ndarray, dt: float, substeps: int = 2):
        p = np.asarray(p, float)
        self.K_tests = p.shape[0]
        b = lambda v: np.broadcast_to(np.asarray(v, float), (self.K_tests,)).copy()  # noqa: E731
        self.m, self.c, self.k, self.k3 = b(m), b(c), b(k), b(k3)
        self.p = p
        self.dt = float(dt)
        self.substeps = int(substeps)
        self.n = 1
        self.n_if = 1
        self.gamma = np.ones((1, 1))
        self.M = self.m[:, None, None].copy()
        self.C = self.c[:, None, None].copy()
        self.Kmat = self.k[:, None, None].copy()
        self.method = "rk4 (cubic spring)"
        self.s = np.zeros((self.K_tests, 2))
        self.P = np.zeros((1, self.K_tests, 2))  # no precomputed load terms (loop zeroes it)
        self.z = np.zeros((self.K_tests, 1))
        self.zdot = np.zeros((self.K_tests, 1))
        self.x = np.zeros((self.K_tests, 1))

    @classmethod
    def from_scenes(cls, scenes: Sequence, k3: float | Sequence[float] = 0.0
                    ) -> CubicSpringSubstructure:
        """Build from one-DOF scenes (their m, c, k and excitation) and cubic stiffness k₃."""
        base = scenes[0]
        t = np.arange(base.n_steps + 1) * base.dt
        p = np.stack([load_history(s.excitation, s.numerical.M, s.numerical.C, s.numerical.K,
                                   t, s.experiment.h0) for s in scenes])
        return cls([s.numerical.M[0][0] for s in scenes], [s.numerical.C[0][0] for s in scenes],
                   [s.numerical.K[0][0] for s in scenes], k3, p, base.dt)

    def reset(self) -> None:
        self.s[:] = 0.0
        self._outputs()

    def halt(self, k: int) -> None:
        """Test k stopped: rest from now on (no load, zero state)."""
        self.p = self.p.copy()
        self.p[k] = 0.0
        self.s[k] = 0.0

    def compiled(self) -> None:
        """Stepped from Python (RK4 of a cubic spring): no compiled kernel."""
        return None

    def get_state(self) -> np.ndarray:
        return self.s.copy()

    def set_state(self, state: np.ndarray) -> None:
        self.s[:] = state
        self._outputs()

    def _outputs(self) -> None:
        self.z[:, 0] = self.s[:, 0]
        self.zdot[:, 0] = self.s[:, 1]
        self.x[:, 0] = self.s[:, 0]

    def _acc(self, x, v, u):
        return (u - self.c * v - self.k * x - self.k3 * x**3) / self.m

    def step(self, n: int, f_n: np.ndarray, f_next: np.ndarray | None = None) -> None:
        """Advance t_n → t_{n+1} (see the protocol); RK4 with ``substeps`` substeps."""
        p0, p1 = self.p[:, n, 0], self.p[:, n + 1, 0]
        g0 = f_n[:, 0]
        g1 = g0 if f_next is None else f_next[:, 0]
        u0, u1 = p0 - g0, p1 - g1
        ns = self.substeps
        h = self.dt / ns
        x, v = self.s[:, 0].copy(), self.s[:, 1].copy()
        for j in range(ns):
            ua = u0 + (u1 - u0) * (j / ns)
            um = u0 + (u1 - u0) * ((j + 0.5) / ns)
            ub = u0 + (u1 - u0) * ((j + 1.0) / ns)
            k1x, k1v = v, self._acc(x, v, ua)
            k2x, k2v = v + 0.5 * h * k1v, self._acc(x + 0.5 * h * k1x, v + 0.5 * h * k1v, um)
            k3x, k3v = v + 0.5 * h * k2v, self._acc(x + 0.5 * h * k2x, v + 0.5 * h * k2v, um)
            k4x, k4v = v + h * k3v, self._acc(x + h * k3x, v + h * k3v, ub)
            x = x + h / 6 * (k1x + 2 * k2x + 2 * k3x + k4x)
            v = v + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
        self.s[:, 0], self.s[:, 1] = x, v
        self._outputs()

    def meta(self, test: int = 0) -> dict:
        return {"M": [[float(self.m[test])]], "C": [[float(self.c[test])]],
                "K": [[float(self.k[test])]], "k3": float(self.k3[test]), "gamma": [[1.0]],
                "integrator": self.method}
