"""Discretisation of continuous LTI systems: zero-order hold, first-order hold, Tustin.

With sample period ``dt`` (s):

* **ZOH** — input held over each step: ``Φ = e^{A dt}``, ``Γ = ∫₀^dt e^{Aτ} dτ B`` (exact).
* **FOH** — input linear between samples (triangle hold, exact for piecewise-linear input).
  Realised causally with the state ``ξ_k = x_k − Γ₂ u_k`` so the discrete system has a
  direct feedthrough ``C Γ₂ + D``.
* **Tustin** (bilinear, no prewarping) — ``s ← (2/dt)(z − 1)/(z + 1)``, MATLAB's
  ``c2d(..., 'tustin')`` / ``c2dm(..., 'tustin')``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.signal

from ..errors import ConfigError
from .systems import ContinuousSS

__all__ = ["DiscreteSS", "c2d", "foh_matrices", "lsim_foh", "tustin_tf"]

METHODS = ("zoh", "foh", "tustin")


@dataclass(frozen=True, eq=False)
class DiscreteSS:
    """Discrete LTI system ``x[k+1] = Ad x[k] + Bd u[k]``, ``y[k] = Cd x[k] + Dd u[k]``.

    ``dt`` is the sample period in s; ``method`` records how it was obtained.
    """

    Ad: np.ndarray
    Bd: np.ndarray
    Cd: np.ndarray
    Dd: np.ndarray
    dt: float
    method: str = ""

    @property
    def n_states(self) -> int:
        return self.Ad.shape[0]

    @property
    def n_inputs(self) -> int:
        return self.Bd.shape[1]

    @property
    def n_outputs(self) -> int:
        return self.Cd.shape[0]

    def poles(self) -> np.ndarray:
        """Eigenvalues of Ad (dimensionless z-plane)."""
        return np.linalg.eigvals(self.Ad) if self.n_states else np.zeros(0, dtype=complex)

    def dcgain(self) -> np.ndarray:
        """Static gain ``Dd + Cd (I − Ad)⁻¹ Bd``."""
        if not self.n_states:
            return np.array(self.Dd)
        return self.Dd + self.Cd @ np.linalg.solve(np.eye(self.n_states) - self.Ad, self.Bd)

    def simulate(self, u: np.ndarray, x0: np.ndarray | None = None) -> np.ndarray:
        """Output sequence for inputs ``u`` of shape (N, m) or (N,) (SISO); zero state default."""
        u2 = np.asarray(u, dtype=float)
        u2 = u2.reshape(-1, 1) if u2.ndim == 1 else u2
        x = np.zeros(self.n_states) if x0 is None else np.asarray(x0, dtype=float).copy()
        y = np.empty((u2.shape[0], self.n_outputs))
        for k in range(u2.shape[0]):
            y[k] = self.Cd @ x + self.Dd @ u2[k]
            x = self.Ad @ x + self.Bd @ u2[k]
        return y


def _check_dt(dt: float) -> float:
    dt = float(dt)
    if not (dt > 0.0 and np.isfinite(dt)):
        raise ConfigError("dt", dt, "sample period must be > 0 s")
    return dt


def foh_matrices(sys: ContinuousSS, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(Φ, Γ₁, Γ₂)`` with ``x_{k+1} = Φ x_k + Γ₁ u_k + Γ₂ (u_{k+1} − u_k)`` for a linear input.

    ``Γ₁`` is the ZOH input matrix; ``Γ₂ = (1/dt) ∫₀^dt e^{A(dt−s)} B s ds`` accounts for the
    slope. Computed from one matrix exponential of the augmented system [[A, B, 0], [0, 0,
    I/dt], [0, 0, 0]]·dt.
    """
    dt = _check_dt(dt)
    n, m = sys.n_states, sys.n_inputs
    M = np.zeros((n + 2 * m, n + 2 * m))
    M[:n, :n] = sys.A * dt
    M[:n, n:n + m] = sys.B * dt
    M[n:n + m, n + m:] = np.eye(m)
    E = scipy.linalg.expm(M)
    return E[:n, :n], E[:n, n:n + m], E[:n, n + m:]


def c2d(sys: ContinuousSS, dt: float, method: str = "zoh") -> DiscreteSS:
    """Discretise ``sys`` with sample period ``dt`` (s); ``method`` in ``zoh | foh | tustin``."""
    dt = _check_dt(dt)
    method = method.lower()
    A, B, C, D = sys.A, sys.B, sys.C, sys.D
    n, m = sys.n_states, sys.n_inputs
    if method == "zoh":
        M = np.zeros((n + m, n + m))
        M[:n, :n] = A * dt
        M[:n, n:] = B * dt
        E = scipy.linalg.expm(M)
        return DiscreteSS(E[:n, :n], E[:n, n:], np.array(C), np.array(D), dt, "zoh")
    if method == "foh":
        Phi, G1, G2 = foh_matrices(sys, dt)
        Bd = G1 + Phi @ G2 - G2
        return DiscreteSS(Phi, Bd, np.array(C), C @ G2 + D, dt, "foh")
    if method == "tustin":
        ima = np.eye(n) - 0.5 * dt * A
        Ad = np.linalg.solve(ima, np.eye(n) + 0.5 * dt * A)
        Bd = np.linalg.solve(ima, dt * B)
        Cd = np.linalg.solve(ima.T, C.T).T
        Dd = D + 0.5 * C @ Bd
        return DiscreteSS(Ad, Bd, Cd, Dd, dt, "tustin")
    raise ConfigError("method", method, f"must be one of {', '.join(METHODS)}")


def tustin_tf(num: Sequence[float], den: Sequence[float], dt: float
              ) -> tuple[np.ndarray, np.ndarray]:
    """Tustin (bilinear, no prewarp) discretisation of N(s)/D(s).

    Returns ``(b, a)`` in powers of z⁻¹ normalised so that ``a[0] = 1``: the difference
    equation ``y[k] = Σ b_i u[k−i] − Σ_{i≥1} a_i y[k−i]``.
    """
    dt = _check_dt(dt)
    num_ = np.atleast_1d(np.asarray(num, dtype=float))
    den_ = np.trim_zeros(np.atleast_1d(np.asarray(den, dtype=float)), "f")
    if den_.size == 0:
        raise ConfigError("den", list(den), "denominator must not be zero")
    if np.trim_zeros(num_, "f").size > den_.size:
        raise ConfigError("num", list(num), "transfer function must be proper")
    b, a = scipy.signal.bilinear(num_, den_, fs=1.0 / dt)
    b = np.atleast_1d(b) / a[0]
    a = np.atleast_1d(a) / a[0]
    if b.size < a.size:
        b = np.concatenate([np.zeros(a.size - b.size), b])
    return b, a


def lsim_foh(sys: ContinuousSS, u: np.ndarray, dt: float,
             x0: np.ndarray | None = None) -> np.ndarray:
    """Exact response to an input linear between samples (first-order hold).

    ``u`` has shape (N, m) or (N,) on the uniform grid ``t_k = k dt``; returns the outputs
    ``y(t_k)``, shape (N, p). Equivalent to MATLAB ``lsim`` with the ``'foh'`` method.
    """
    Phi, G1, G2 = foh_matrices(sys, dt)
    u2 = np.asarray(u, dtype=float)
    u2 = u2.reshape(-1, 1) if u2.ndim == 1 else u2
    N = u2.shape[0]
    n = sys.n_states
    X = np.empty((N, n))
    x = np.zeros(n) if x0 is None else np.asarray(x0, dtype=float).copy()
    # forcing of each step, computed for all steps at once
    du = np.zeros_like(u2)
    du[:-1] = u2[1:] - u2[:-1]
    forcing = u2 @ G1.T + du @ G2.T
    X[0] = x
    if N > 1:
        X[1:] = _recur(Phi, x, forcing[:-1])
    return X @ sys.C.T + u2 @ sys.D.T


def _recur(Phi: np.ndarray, x0: np.ndarray, forcing: np.ndarray) -> np.ndarray:
    """States x_1 … x_N of ``x_{k+1} = Φ x_k + f_k`` (f of shape (N, n)).

    Uses the eigen-decomposition of Φ so that each mode is a first-order recursion run by
    :func:`scipy.signal.lfilter` (vectorised); falls back to a plain loop when Φ is not well
    diagonalisable.
    """
    n = Phi.shape[0]
    if n == 0:
        return np.zeros((forcing.shape[0], 0))
    lam, V = np.linalg.eig(Phi)
    if np.linalg.cond(V) < 1e8:
        Vi = np.linalg.inv(V)
        q0 = Vi @ x0
        fq = forcing @ Vi.T
        Q = np.empty(fq.shape, dtype=complex)
        for i in range(n):
            # q_{k+1} = λ q_k + f_k  ⇒  q_{k+1} = Σ λ^j f_{k−j} + λ^{k+1} q_0
            zi = np.array([lam[i] * q0[i]])
            Q[:, i], _ = scipy.signal.lfilter([1.0], [1.0, -lam[i]], fq[:, i], zi=zi)
        return (Q @ V.T).real
    out = np.empty(forcing.shape)
    x = x0.copy()
    PhiT = Phi.T
    for k in range(forcing.shape[0]):
        x = x @ PhiT + forcing[k]
        out[k] = x
    return out
