"""Discretisation of continuous LTI systems (python-control) and exact FOH responses.

:func:`c2d` is ``control.sample_system`` with sample period ``dt`` (s):

* **ZOH** — input held over each step: ``Φ = e^{A dt}``, ``Γ = ∫₀^dt e^{Aτ} dτ B`` (exact).
* **FOH** — input linear between samples (triangle hold): the causal realisation with state
  ``ξ_k = x_k − Γ₂ u_k`` and direct feedthrough ``C Γ₂ + D`` (MATLAB ``c2d(…,'foh')``).
* **Tustin** — ``s ← (2/dt)(z − 1)/(z + 1)``, MATLAB's ``c2d(…,'tustin')``; with
  ``prewarp`` = ω₀ (rad/s) the map is matched at ω₀: ``s ← (ω₀/tan(ω₀ dt/2))(z − 1)/(z + 1)``.

:func:`lsim_foh` (the exact response to a piecewise-linear input over 10⁵+ samples) and
:func:`recur` (``x_{k+1} = Φ x_k + f_k`` for a whole sequence) run modal recursions through
:func:`scipy.signal.lfilter`, much faster than a loop per sample.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import control
import numpy as np
import scipy.linalg
import scipy.signal

from ..errors import ConfigError
from .systems import ContinuousSS, SSConveniences, proper_polynomials

__all__ = ["DiscreteSS", "c2d", "foh_matrices", "lsim_foh", "recur", "tustin_tf"]

METHODS = ("zoh", "foh", "tustin")


class DiscreteSS(SSConveniences, control.StateSpace):
    """Discrete LTI system ``x[k+1] = A x[k] + B u[k]``, ``y[k] = C x[k] + D u[k]`` (a
    ``control.StateSpace`` with sample period ``dt`` in s); ``method`` records how it was
    obtained. ``Ad``, ``Bd``, ``Cd``, ``Dd`` name the matrices as well.

    ``DiscreteSS(A, B, C, D, dt, method="")``, or ``DiscreteSS(sys, method=...)`` for any
    discrete python-control system.
    """

    def __init__(self, *args: Any, method: str = "", **kwargs: Any):
        if len(args) == 6:  # the positional form DiscreteSS(Ad, Bd, Cd, Dd, dt, method)
            *args, method = args  # type: ignore[assignment]
        if len(args) == 1:
            sys = control.ss(args[0])
            args = (sys.A, sys.B, sys.C, sys.D, sys.dt)
        if len(args) != 5 or not (args[4] is True or float(args[4]) > 0.0):
            raise ConfigError("dt", args[4] if len(args) == 5 else None,
                              "a discrete system needs a sample period > 0 s")
        super().__init__(*args, **kwargs)
        self.method = method

    Ad = property(lambda self: self.A, doc="A (the discrete state matrix)")
    Bd = property(lambda self: self.B, doc="B")
    Cd = property(lambda self: self.C, doc="C")
    Dd = property(lambda self: self.D, doc="D")

    def simulate(self, u: np.ndarray, x0: np.ndarray | None = None) -> np.ndarray:
        """Output sequence (N, p) for inputs ``u`` of shape (N, m) or (N,) (SISO); zero state
        by default (``control.forced_response``)."""
        u2 = np.asarray(u, dtype=float)
        u2 = u2.reshape(-1, 1) if u2.ndim == 1 else u2
        t = self.dt * np.arange(u2.shape[0])
        r = control.forced_response(self, t, u2.T, 0.0 if x0 is None else x0, squeeze=False)
        return np.asarray(r.outputs).T


def _check_dt(dt: float) -> float:
    dt = float(dt)
    if not (dt > 0.0 and np.isfinite(dt)):
        raise ConfigError("dt", dt, "sample period must be > 0 s")
    return dt


def _check_prewarp(prewarp: float | None, method: str, dt: float) -> float | None:
    if prewarp is None:
        return None
    w = float(prewarp)
    if method != "tustin":
        raise ConfigError("prewarp", w, "only Tustin can be prewarped")
    if not (0.0 < w < np.pi / dt):
        raise ConfigError("prewarp", w, f"must be in (0, π/dt = {np.pi / dt:g}) rad/s")
    return w


def c2d(sys: ContinuousSS | control.StateSpace, dt: float, method: str = "zoh",
        prewarp: float | None = None) -> DiscreteSS:
    """Discretise ``sys`` with sample period ``dt`` (s); ``method`` in ``zoh | foh | tustin``;
    ``prewarp`` (rad/s, Tustin only) is the frequency at which the discrete response equals
    the continuous one (``control.sample_system``)."""
    dt = _check_dt(dt)
    method = str(method).lower()
    if method not in METHODS:
        raise ConfigError("method", method, f"must be one of {', '.join(METHODS)}")
    w = _check_prewarp(prewarp, method, dt)
    d = control.sample_system(control.ss(sys), dt, method, prewarp_frequency=w)
    return DiscreteSS(d, method=method)


def tustin_tf(num: Sequence[float], den: Sequence[float], dt: float,
              prewarp: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Tustin discretisation of N(s)/D(s), optionally prewarped at ``prewarp`` rad/s.

    Returns ``(b, a)`` in powers of z⁻¹ normalised so that ``a[0] = 1``, ``b`` as long as
    ``a``: the difference equation ``y[k] = Σ b_i u[k−i] − Σ_{i≥1} a_i y[k−i]``. The same
    map as ``control.sample_system(control.tf(num, den), dt, "tustin", prewarp_frequency=…)``,
    computed by substituting the polynomials (:func:`scipy.signal.bilinear`): python-control
    samples a transfer function through a state-space round trip, which for a 3rd-order
    filter at 4096 Hz already loses 10⁻¹² of the smaller coefficients.
    """
    dt = _check_dt(dt)
    num_, den_ = proper_polynomials(num, den)
    w = _check_prewarp(prewarp, "tustin", dt)
    # s ← 2 fs (z − 1)/(z + 1); prewarped: 2 fs = ω₀ / tan(ω₀ dt / 2)
    fs = 1.0 / dt if w is None else 0.5 * w / np.tan(0.5 * w * dt)
    b, a = scipy.signal.bilinear(num_, den_, fs=fs)
    b = np.atleast_1d(b) / a[0]
    a = np.atleast_1d(a) / a[0]
    if b.size < a.size:
        b = np.concatenate([np.zeros(a.size - b.size), b])
    return b, a


def foh_matrices(sys: ContinuousSS, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(Φ, Γ₁, Γ₂)`` with ``x_{k+1} = Φ x_k + Γ₁ u_k + Γ₂ (u_{k+1} − u_k)`` for a linear input.

    ``Γ₁`` is the ZOH input matrix; ``Γ₂ = (1/dt) ∫₀^dt e^{A(dt−s)} B s ds`` accounts for the
    slope. Computed from one matrix exponential of the augmented system [[A, B, 0], [0, 0,
    I/dt], [0, 0, 0]]·dt (python-control's FOH has these in its realisation but does not
    return them; :func:`lsim_foh` needs Γ₂ for a nonzero first input).
    """
    dt = _check_dt(dt)
    n, m = sys.nstates, sys.ninputs
    M = np.zeros((n + 2 * m, n + 2 * m))
    M[:n, :n] = sys.A * dt
    M[:n, n:n + m] = sys.B * dt
    M[n:n + m, n + m:] = np.eye(m)
    E = scipy.linalg.expm(M)
    return E[:n, :n], E[:n, n:n + m], E[:n, n + m:]


def lsim_foh(sys: ContinuousSS, u: np.ndarray, dt: float,
             x0: np.ndarray | None = None) -> np.ndarray:
    """Exact response to an input linear between samples (first-order hold).

    ``u`` has shape (N, m) or (N,) on the uniform grid ``t_k = k dt``; returns the outputs
    ``y(t_k)``, shape (N, p). Equals MATLAB ``lsim`` with the ``'foh'`` method and
    ``control.forced_response`` (which steps sample by sample in Python).
    """
    Phi, G1, G2 = foh_matrices(sys, dt)
    u2 = np.asarray(u, dtype=float)
    u2 = u2.reshape(-1, 1) if u2.ndim == 1 else u2
    N = u2.shape[0]
    n = sys.nstates
    X = np.empty((N, n))
    x = np.zeros(n) if x0 is None else np.asarray(x0, dtype=float).copy()
    # forcing of each step, computed for all steps at once
    du = np.zeros_like(u2)
    du[:-1] = u2[1:] - u2[:-1]
    forcing = u2 @ G1.T + du @ G2.T
    X[0] = x
    if N > 1:
        X[1:] = recur(Phi, x, forcing[:-1])
    return X @ sys.C.T + u2 @ sys.D.T


def recur(Phi: np.ndarray, x0: np.ndarray, forcing: np.ndarray) -> np.ndarray:
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
