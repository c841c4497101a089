"""Linear multi-DOF numerical substructure and its integrators, batched over K tests.

Equation of motion (SI): ``M ẍ + C ẋ + K x = p(t) − Γ F'_m``, interface command
``z = Γᵀ x``. Every integrator is written as the linear recurrence

    s_{n+1} = A_d s_n + G_1 u_n + G_2 (u_{n+1} − u_n),        x_n = C_x s_n, ẋ_n = C_v s_n

``exact``: s = [x; ẋ], exact discretisation of the state space (A_d = e^{AΔT}); the known
load p is interpolated linearly over a step (first-order hold, exact for piecewise-linear
p) and the interface force is held (zero-order hold) in the partitioned loop, or linearly
interpolated in the reference. Unconditionally stable, no numerical damping.
``central_difference``: s = [x_n; x_{n−1}], explicit, stable for ω_max ΔT < 2 (checked here,
and by the scene with the experimental part's spring added).
``newmark``: s = [x; ẋ; ẍ], Newmark's average acceleration with the load at t_{n+1} (the
step of an OpenSees model, :mod:`rths3d.numerical.opensees`, written out for M, C, K).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np
import scipy.linalg

from ..errors import ConfigError
from ._kernels import linear_step as _linear_step
from ._kernels import load_terms_1dof
from .excitation import excitation_signal, load_history
from .modal import fastest_eigenfrequency

if TYPE_CHECKING:
    from ..config import Scene


@dataclass(frozen=True)
class Discretisation:
    """Matrices of the recurrence (see module docstring) for one substructure."""

    Ad: np.ndarray
    G1: np.ndarray
    G2: np.ndarray
    Cx: np.ndarray
    Cv: np.ndarray
    s0_from_a0: bool = False


def discretise(M: np.ndarray, C: np.ndarray, K: np.ndarray, dt: float,
               method: str = "exact") -> Discretisation:
    """Discretise ``M ẍ + C ẋ + K x = u`` with step ``dt`` (s) by ``method``."""
    M, C, K = (np.atleast_2d(np.asarray(a, float)) for a in (M, C, K))
    n = M.shape[0]
    Minv = np.linalg.inv(M)
    eye, zero = np.eye(n), np.zeros((n, n))
    if method == "exact":
        A = np.block([[zero, eye], [-Minv @ K, -Minv @ C]])
        B = np.vstack([zero, Minv])
        S = 2 * n
        aug = np.zeros((S + 2 * n, S + 2 * n))
        aug[:S, :S] = A * dt
        aug[:S, S:S + n] = B * dt
        aug[S:S + n, S + n:] = np.eye(n)
        E = scipy.linalg.expm(aug)
        return Discretisation(E[:S, :S], E[:S, S:S + n], E[:S, S + n:],
                              np.hstack([eye, zero]), np.hstack([zero, eye]))
    if method == "central_difference":
        w = fastest_eigenfrequency(M, K)
        if w * dt >= 2.0:
            raise ConfigError("numerical.integrator", "central_difference",
                              f"unstable: ω_max·ΔT = {w * dt:.3g} must be < 2 "
                              f"(ω_max = {w:.4g} rad/s, ΔT = {dt:g} s); use 'exact'")
        L = np.linalg.inv(M / dt**2 + C / (2 * dt))
        Ad = np.block([[L @ (2 * M / dt**2 - K), -L @ (M / dt**2 - C / (2 * dt))],
                       [eye, zero]])
        G1 = np.vstack([L, zero])
        return Discretisation(Ad, G1, np.zeros_like(G1), np.hstack([eye, zero]),
                              np.hstack([eye / dt, -eye / dt]), s0_from_a0=True)
    if method == "newmark":
        return _newmark(M, C, K, dt)
    raise ConfigError("numerical.integrator", method,
                      "must be 'exact', 'central_difference' or 'newmark'")


def _newmark(M: np.ndarray, C: np.ndarray, K: np.ndarray, dt: float, gamma: float = 0.5,
             beta: float = 0.25) -> Discretisation:
    """Newmark's average acceleration (γ ½, β ¼) on s = [x; ẋ; ẍ] with the load at t_{n+1}:
    s_{n+1} = A s_n + B u_{n+1} (G_1 = G_2 = B: the held interface force F'_m(t_n) acts at
    t_{n+1}, as in an OpenSees ``analyze`` step with the force imposed before it)."""
    n = M.shape[0]
    eye, zero = np.eye(n), np.zeros((n, n))
    a0, a1 = 1.0 / (beta * dt**2), gamma / (beta * dt)
    Kh_inv = np.linalg.inv(K + a1 * C + a0 * M)
    # x_{n+1} = K̂⁻¹ (u_{n+1} + M (a0 x + v/(βΔt) + (1/(2β) − 1) a)
    #                 + C (a1 x + (γ/β − 1) v + Δt (γ/(2β) − 1) a))
    X = Kh_inv @ np.hstack([a0 * M + a1 * C, M / (beta * dt) + (gamma / beta - 1) * C,
                            (0.5 / beta - 1) * M + dt * (0.5 * gamma / beta - 1) * C])
    Bx = Kh_inv
    # a_{n+1} = a0 (x_{n+1} − x_n) − v_n/(βΔt) − (1/(2β) − 1) a_n
    A_acc = a0 * X - np.hstack([a0 * eye, eye / (beta * dt), (0.5 / beta - 1) * eye])
    B_acc = a0 * Bx
    # v_{n+1} = v_n + Δt ((1 − γ) a_n + γ a_{n+1})
    A_vel = np.hstack([zero, eye, (1 - gamma) * dt * eye]) + gamma * dt * A_acc
    B_vel = gamma * dt * B_acc
    Ad = np.vstack([X, A_vel, A_acc])
    B = np.vstack([Bx, B_vel, B_acc])
    return Discretisation(Ad, B, B.copy(), np.hstack([eye, zero, zero]),
                          np.hstack([zero, eye, zero]))


def _exact_batch(M: np.ndarray, C: np.ndarray, K: np.ndarray, dt: float
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``exact`` discretisation of K substructures at once (stacked matrix exponentials)."""
    nt, n = M.shape[0], M.shape[1]
    Minv = np.linalg.inv(M)
    S = 2 * n
    aug = np.zeros((nt, S + 2 * n, S + 2 * n))
    aug[:, :n, n:S] = np.eye(n) * dt
    aug[:, n:S, :n] = -(Minv @ K) * dt
    aug[:, n:S, n:S] = -(Minv @ C) * dt
    aug[:, n:S, S:S + n] = Minv * dt
    aug[:, S:S + n, S + n:] = np.eye(n)
    E = _expm_stack(aug)
    return E[:, :S, :S], E[:, :S, S:S + n], E[:, :S, S + n:]


def _expm_stack(A: np.ndarray) -> np.ndarray:
    """Matrix exponentials of a stack (K, m, m): scaling and squaring with an 18-term
    Taylor series (truncation < 1e-16 for ‖A/2^s‖₁ ≤ 0.5). Stacked matmuls avoid per-matrix
    library calls, which dominate for thousands of small matrices."""
    norm = np.abs(A).sum(axis=1).max(axis=1)
    s = int(max(0, np.ceil(np.log2(max(float(norm.max()), 1e-300) / 0.5))))
    X = A / (2.0**s)
    eye = np.broadcast_to(np.eye(A.shape[1]), A.shape)
    E = eye + X
    term = X
    for k in range(2, 19):
        term = term @ X / k
        E = E + term
    for _ in range(s):
        E = E @ E
    return E


class NumericalSubstructure(Protocol):
    """What the loop needs from a numerical substructure (linear or a user's nonlinear one).

    Arrays are over K tests: ``z`` and ``zdot`` (K, n_if) interface command and its rate,
    ``x`` (K, n) DOFs. ``step(n, f_n, f_next)`` advances from t_n to t_{n+1} with the
    interface force F'_m (K, n_if) at t_n (held over the step) or, when ``f_next`` is given,
    interpolated linearly to ``f_next`` (implicit use, for the reference).
    """

    n: int
    n_if: int
    z: np.ndarray
    zdot: np.ndarray
    x: np.ndarray
    p: np.ndarray
    """The load p(t_k) per test, (K, N+1, n) (N, N·m), for the record's ``p_num``."""
    gamma: np.ndarray

    def reset(self) -> None: ...

    def step(self, n: int, f_n: np.ndarray, f_next: np.ndarray | None = None) -> None: ...

    def get_state(self) -> np.ndarray: ...

    def set_state(self, state: np.ndarray) -> None: ...

    def halt(self, k: int) -> None:
        """Test k stopped: it rests from now on (no load, zero state); the others go on."""

    def meta(self, test: int = 0) -> dict: ...

    def compiled(self) -> tuple | None:
        """The arrays of the compiled loop's linear step (:func:`rths3d.stepping.linear_step`)
        or None (stepped from Python)."""


NumericalFactory = Callable[[list["Scene"]], NumericalSubstructure]
"""Builds the numerical substructure of K tests from their scenes (``run(numerical=...)``)."""


class LinearSubstructure:
    """K linear substructures stepped together (each may have its own M, C, K).

    Parameters
    ----------
    M, C, K:
        (K, n, n) or (n, n) matrices (kg, N·s/m, N/m).
    gamma:
        Γ, (n, n_if): interface map, z = Γᵀ x.
    p:
        Load history (K, N+1, n) or (N+1, n), N on the grid t_k = k·dt.
    dt:
        Interface step ΔT (s).
    method:
        ``exact`` or ``central_difference``.
    """

    def __init__(self, M: np.ndarray, C: np.ndarray, K: np.ndarray, gamma: np.ndarray,
                 p: np.ndarray, dt: float, method: str = "exact"):
        M, C, K = (np.asarray(a, float) for a in (M, C, K))
        if M.ndim == 2:
            M, C, K = M[None], C[None], K[None]
        p = np.asarray(p, float)
        if p.ndim == 2:
            p = np.broadcast_to(p[None], (M.shape[0],) + p.shape)
        self.K_tests = M.shape[0]
        self.n = M.shape[1]
        self.gamma = np.atleast_2d(np.asarray(gamma, float))
        self.n_if = self.gamma.shape[1]
        self.dt = float(dt)
        self.method = method
        self.M, self.C, self.Kmat = M, C, K
        shared = bool(np.all(M == M[:1]) and np.all(C == C[:1]) and np.all(K == K[:1]))
        self.shared = shared
        if method == "exact" and not shared:
            self.Ad, self.G1, self.G2 = _exact_batch(M, C, K, dt)
            n = M.shape[1]
            self.Cx = np.hstack([np.eye(n), np.zeros((n, n))])
            self.Cv = np.hstack([np.zeros((n, n)), np.eye(n)])
            self.s0_from_a0 = False
        else:
            ds = [discretise(M[i], C[i], K[i], dt, method)
                  for i in range(1 if shared else len(M))]
            stack = lambda name: np.stack([getattr(d, name) for d in ds])  # noqa: E731
            self.Ad, self.G1, self.G2 = stack("Ad"), stack("G1"), stack("G2")
            self.Cx, self.Cv = ds[0].Cx, ds[0].Cv
            self.s0_from_a0 = ds[0].s0_from_a0
        G = self.gamma
        # Force input maps (S × n_if): held force (loop) and interpolated force (reference).
        self.Bf_hold = self.G1 @ G
        self.Bf0 = (self.G1 - self.G2) @ G
        self.Bf1 = self.G2 @ G
        # Known load with first-order hold, precomputed for the whole run: (N, K, S), step
        # by step (the compiled loop reads the K tests' terms of one step together): for one
        # DOF in one compiled pass (tiny batched matmuls cost far more); for several, the
        # batched matmuls of before, whose rounding the multi-DOF records keep.
        A = self.G1 if method == "central_difference" else self.G1 - self.G2
        S = self.Ad.shape[-1]
        if self.n == 1:
            B = np.zeros_like(A[:, :, 0]) if method == "central_difference" else \
                self.G2[:, :, 0]
            self.P = np.empty((p.shape[1] - 1, self.K_tests, S))
            load_terms_1dof(np.ascontiguousarray(np.broadcast_to(p[:, :, 0], (
                self.K_tests, p.shape[1]))), np.ascontiguousarray(A[:, :, 0]),
                np.ascontiguousarray(B), self.P)
        else:
            P = np.matmul(p[:, :-1], np.swapaxes(A, 1, 2))
            if method != "central_difference":
                P = P + np.matmul(p[:, 1:], np.swapaxes(self.G2, 1, 2))
            self.P = np.ascontiguousarray(P.transpose(1, 0, 2))
        self.p = p
        self.Czx = G.T @ self.Cx          # (n_if, S)
        self.Czv = G.T @ self.Cv
        self.s = np.zeros((self.K_tests, S))
        self.z = np.zeros((self.K_tests, self.n_if))
        self.zdot = np.zeros((self.K_tests, self.n_if))
        self.x = np.zeros((self.K_tests, self.n))
        self._CzxT = np.ascontiguousarray(self.Czx.T)
        self._CzvT = np.ascontiguousarray(self.Czv.T)
        self._CxT = np.ascontiguousarray(self.Cx.T)
        # the compiled step's arrays (contiguous, the step allocates nothing)
        c = np.ascontiguousarray
        self._kernel_args = (c(self.Ad), c(self.Bf_hold), self.P, self.s,
                             np.zeros_like(self.s), c(self.Czx), c(self.Czv), c(self.Cx))
        self.reset()

    # ------------------------------------------------------------------ state
    def reset(self) -> None:
        """Start from rest at x = 0 (static equilibrium)."""
        self.s[:] = 0.0
        if self.s0_from_a0:
            # central difference: x_{-1} = ΔT²/2 · a_0 with a_0 = M⁻¹ p_0 from rest
            a0 = np.linalg.solve(self.M, self.p[:, 0, :, None])[..., 0]
            self.s[:, self.n:] = 0.5 * self.dt**2 * a0
        self._outputs()

    def get_state(self) -> np.ndarray:
        """A copy of the state (K, S)."""
        return self.s.copy()

    def set_state(self, state: np.ndarray) -> None:
        """Restore a state from :meth:`get_state`."""
        self.s[:] = state
        self._outputs()

    def _outputs(self) -> None:
        np.matmul(self.s, self._CzxT, out=self.z)
        np.matmul(self.s, self._CzvT, out=self.zdot)
        np.matmul(self.s, self._CxT, out=self.x)

    # ------------------------------------------------------------------ stepping
    def step(self, n: int, f_n: np.ndarray, f_next: np.ndarray | None = None) -> None:
        """Advance from t_n to t_{n+1} (see :class:`NumericalSubstructure`).

        The held-force step (the loop's) is the compiled loop's own kernel
        (:func:`rths3d.stepping.linear_step`); the interpolated-force step (the reference's,
        implicit in F_{n+1}) is batched numpy."""
        if f_next is None:
            Ad, Bf, P, s, s_next, Czx, Czv, Cx = self.compiled()
            _linear_step(Ad, Bf, P, n, np.ascontiguousarray(f_n, dtype=float), s, s_next, Czx,
                         Czv, Cx, self.z, self.zdot, self.x)
            return
        s = np.matmul(self.Ad, self.s[..., None])[..., 0] + self.P[n]
        s -= np.matmul(self.Bf0, f_n[..., None])[..., 0]
        s -= np.matmul(self.Bf1, f_next[..., None])[..., 0]
        self.s[:] = s
        self._outputs()

    def halt(self, k: int) -> None:
        """Test k stopped: it rests from now on (no load, zero state)."""
        self.P[:, k] = 0.0
        self.s[k] = 0.0

    def compiled(self) -> tuple:
        """(A_d, B_f, P, s, s_next, C_zx, C_zv, C_x) for :func:`rths3d.stepping.linear_step`:
        the held-force recurrence with the matrices shared (first axis 1) or per test."""
        return self._kernel_args

    @classmethod
    def from_scenes(cls, scenes: Sequence[Scene], method: str | None = None
                    ) -> LinearSubstructure:
        """The substructures of K scenes with their loads (``method``: the scenes'
        integrator by default)."""
        base = scenes[0]
        t = np.arange(base.n_steps + 1) * base.dt
        M = np.array([s.numerical.M for s in scenes])
        C = np.array([s.numerical.C for s in scenes])
        K = np.array([s.numerical.K for s in scenes])
        # one excitation signal per distinct excitation (a batch's tests mostly share it)
        signals: dict = {}

        def signal(s: Scene) -> tuple[np.ndarray, np.ndarray] | None:
            if s.excitation.kind == "none":
                return None
            key = (s.excitation, repr(s.experiment.h0))
            try:
                if key not in signals:
                    signals[key] = excitation_signal(s.excitation, t, s.experiment.h0)
            except TypeError:  # an excitation with an unhashable value
                return None
            return signals[key]

        p = np.stack([load_history(s.excitation, M[i], C[i], K[i], t, s.experiment.h0,
                                   signal(s)) for i, s in enumerate(scenes)])
        return cls(M, C, K, np.array(base.numerical.gamma), p, base.dt,
                   method or base.numerical.integrator)

    def meta(self, test: int = 0) -> dict:
        """Record metadata ``numerical``: M, C, K, Γ (SI) of one test."""
        return {"M": self.M[test].tolist(), "C": self.C[test].tolist(),
                "K": self.Kmat[test].tolist(), "gamma": self.gamma.tolist(),
                "integrator": self.method}
