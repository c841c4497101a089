"""Stepping LTI systems in a loop: K tests at once, a plain-float fast path, and RK4.

The steppers take python-control state-space objects (:class:`~.discretize.DiscreteSS`,
:class:`~.systems.ContinuousSS` or any ``control.StateSpace``) designed once, and run them
per step:

* :class:`StateSpaceStepper` — a discrete system stepped for K tests together, states of
  shape (K, n), all work arrays preallocated (``step`` allocates nothing).
* :class:`ScalarStepper` — the same for K = 1 and a SISO system with plain Python floats
  (no small-array numpy in the hot loop).
* :class:`RK4Stepper` — a continuous system advanced by classical 4th-order Runge–Kutta with
  ``substeps`` steps per call (multi-rate: e.g. a plant at 4 kHz inside a 1 kHz loop), input
  either held over the call or linearly interpolated between the call's two samples. Because
  the system is linear, RK4 with these inputs is an exact affine map, which is precomputed.
* :func:`affine_step_matrices` — extracts ``[Φ | Γ]`` of any affine step function, so custom
  stage rules (e.g. Simulink derivative blocks) run as one matrix product per step.
"""

from __future__ import annotations

from collections.abc import Callable

import control
import numpy as np

from ..errors import ConfigError
from .systems import tf_coefficients

__all__ = ["RK4Stepper", "ScalarStepper", "StateSpaceStepper", "affine_step_matrices",
           "rk4_step"]


class StateSpaceStepper:
    """Step a discrete system (``control.StateSpace``) for ``K`` tests together.

    ``step(u)`` takes inputs of shape (K, m) and returns the outputs ``y[k]`` (K, p) — a view
    of an internal buffer that the next call overwrites — then advances the states.
    """

    def __init__(self, sys: control.StateSpace, K: int = 1):
        if int(K) < 1:
            raise ConfigError("K", K, "number of tests must be ≥ 1")
        self.sys = sys
        self.K = int(K)
        n, m, p = sys.nstates, sys.ninputs, sys.noutputs
        self._AdT = np.ascontiguousarray(sys.A.T)
        self._BdT = np.ascontiguousarray(sys.B.T)
        self._CdT = np.ascontiguousarray(sys.C.T)
        self._DdT = np.ascontiguousarray(sys.D.T)
        self.x = np.zeros((self.K, n))
        self._xn = np.zeros((self.K, n))
        self._tmp_n = np.zeros((self.K, n))
        self.y = np.zeros((self.K, p))
        self._tmp_p = np.zeros((self.K, p))
        self._m = m

    def reset(self) -> None:
        """Zero all states."""
        self.x[:] = 0.0

    def step(self, u: np.ndarray) -> np.ndarray:
        """Outputs for inputs ``u`` (K, m), then ``x ← Ad x + Bd u``."""
        np.matmul(self.x, self._CdT, out=self.y)
        np.matmul(u, self._DdT, out=self._tmp_p)
        self.y += self._tmp_p
        np.matmul(self.x, self._AdT, out=self._xn)
        np.matmul(u, self._BdT, out=self._tmp_n)
        self._xn += self._tmp_n
        self.x, self._xn = self._xn, self.x
        return self.y


class ScalarStepper:
    """A SISO discrete system stepped with plain floats (K = 1 fast path).

    Uses the direct-form-II-transposed difference equation of the system's transfer
    function; ``step(u: float) -> float``.
    """

    def __init__(self, sys: control.StateSpace | tuple[np.ndarray, np.ndarray]):
        if isinstance(sys, control.StateSpace):
            b, a = tf_coefficients(sys)
        else:
            b, a = (np.atleast_1d(np.asarray(v, float)) for v in sys)
        if a.size == 0 or a[0] == 0.0:
            raise ConfigError("a", list(a), "a[0] must be nonzero")
        n = max(a.size, b.size)
        b = np.concatenate([b, np.zeros(n - b.size)]) / a[0]
        a = np.concatenate([a, np.zeros(n - a.size)]) / a[0]
        self.b = [float(v) for v in b]
        self.a = [float(v) for v in a]
        self._z = [0.0] * (n - 1)
        self._n = n - 1

    def reset(self) -> None:
        for i in range(self._n):
            self._z[i] = 0.0

    def step(self, u: float) -> float:
        b, a, z, n = self.b, self.a, self._z, self._n
        if n == 0:
            return b[0] * u
        y = b[0] * u + z[0]
        for i in range(n - 1):
            z[i] = b[i + 1] * u - a[i + 1] * y + z[i + 1]
        z[n - 1] = b[n] * u - a[n] * y
        return y


def rk4_step(f: Callable[[float, np.ndarray], np.ndarray], t: float, x: np.ndarray,
             h: float) -> np.ndarray:
    """One classical RK4 step of ``ẋ = f(t, x)`` from t to t + h (reference implementation)."""
    k1 = f(t, x)
    k2 = f(t + 0.5 * h, x + 0.5 * h * k1)
    k3 = f(t + 0.5 * h, x + 0.5 * h * k2)
    k4 = f(t + h, x + h * k3)
    return x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


def affine_step_matrices(step: Callable[[np.ndarray, np.ndarray], np.ndarray], n: int,
                         m: int, check: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """``(Φ, Γ)`` with ``step(x, u) = Φ x + Γ u`` for an affine (linear, zero offset) step.

    Evaluates ``step`` on unit vectors. With ``check`` the linearity is verified on a random
    point and a ``ValueError`` is raised if the step is not linear.
    """
    Phi = np.empty((n, n))
    Gam = np.empty((n, m))
    zx, zu = np.zeros(n), np.zeros(m)
    offset = np.asarray(step(zx, zu), dtype=float)
    if np.any(offset != 0.0):
        raise ValueError("step has a constant offset; it must be linear in (x, u)")
    for i in range(n):
        e = np.zeros(n)
        e[i] = 1.0
        Phi[:, i] = step(e, zu)
    for j in range(m):
        e = np.zeros(m)
        e[j] = 1.0
        Gam[:, j] = step(zx, e)
    if check:
        rng = np.random.default_rng(0)
        x, u = rng.standard_normal(n), rng.standard_normal(m)
        direct = np.asarray(step(x, u), dtype=float)
        lin = Phi @ x + Gam @ u
        scale = 1.0 + np.max(np.abs(direct))
        if np.max(np.abs(direct - lin)) > 1e-9 * scale:
            raise ValueError("step is not linear in (x, u)")
    return Phi, Gam


class RK4Stepper:
    """Advance a continuous system (``control.StateSpace``) by RK4 over one period ``dt`` per
    call, for K tests.

    Parameters
    ----------
    sys:
        The continuous system.
    dt:
        Call period in s (e.g. the interface period).
    substeps:
        RK4 steps per call (h = dt / substeps), for multi-rate stepping.
    input:
        ``"hold"`` — u constant over the call (ZOH);
        ``"linear"`` — u interpolated linearly from ``u0`` at t to ``u1`` at t + dt.
    K:
        Number of tests stepped together.

    ``step(u0, u1=None)`` advances the states (K, n) in place and returns the outputs at the
    end of the call, ``y = C x + D u_end`` (a reused buffer).
    """

    def __init__(self, sys: control.StateSpace, dt: float, substeps: int = 1, input: str = "hold",
                 K: int = 1):
        if not (float(dt) > 0.0):
            raise ConfigError("dt", dt, "must be > 0 s")
        if int(substeps) < 1:
            raise ConfigError("substeps", substeps, "must be ≥ 1")
        if input not in ("hold", "linear"):
            raise ConfigError("input", input, "must be 'hold' or 'linear'")
        if int(K) < 1:
            raise ConfigError("K", K, "number of tests must be ≥ 1")
        self.sys, self.dt, self.substeps, self.input, self.K = (
            sys, float(dt), int(substeps), input, int(K))
        n, m = sys.nstates, sys.ninputs
        h = self.dt / self.substeps
        A, B = sys.A, sys.B

        def one_call(x: np.ndarray, uu: np.ndarray) -> np.ndarray:
            u0, u1 = uu[:m], uu[m:]
            for s in range(self.substeps):
                t0 = s * h

                def u_at(t: float) -> np.ndarray:
                    if input == "hold":
                        return u0
                    return u0 + (u1 - u0) * (t / self.dt)

                x = rk4_step(lambda t, z: A @ z + B @ u_at(t), t0, x, h)
            return x

        Phi, Gam = affine_step_matrices(one_call, n, 2 * m)
        self.Phi = Phi
        self.G0 = Gam[:, :m]
        self.G1 = Gam[:, m:]
        self._PhiT = np.ascontiguousarray(Phi.T)
        self._G0T = np.ascontiguousarray(self.G0.T)
        self._G1T = np.ascontiguousarray(self.G1.T)
        self._CT = np.ascontiguousarray(sys.C.T)
        self._DT = np.ascontiguousarray(sys.D.T)
        self.x = np.zeros((self.K, n))
        self._xn = np.zeros((self.K, n))
        self._tmp = np.zeros((self.K, n))
        self.y = np.zeros((self.K, sys.noutputs))
        self._tmp_p = np.zeros((self.K, sys.noutputs))

    def reset(self) -> None:
        self.x[:] = 0.0

    def step(self, u0: np.ndarray, u1: np.ndarray | None = None) -> np.ndarray:
        """Advance one call period; ``u1`` (input at the end) is needed for ``"linear"``."""
        np.matmul(self.x, self._PhiT, out=self._xn)
        np.matmul(u0, self._G0T, out=self._tmp)
        self._xn += self._tmp
        u_end = u0
        if self.input == "linear":
            if u1 is None:
                raise ConfigError("u1", None, "linear input interpolation needs u1")
            np.matmul(u1, self._G1T, out=self._tmp)
            self._xn += self._tmp
            u_end = u1
        self.x, self._xn = self._xn, self.x
        np.matmul(self.x, self._CT, out=self.y)
        np.matmul(u_end, self._DT, out=self._tmp_p)
        self.y += self._tmp_p
        return self.y
