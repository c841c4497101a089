"""Continuous-time linear time-invariant systems: state space, transfer functions, block diagrams.

A :class:`ContinuousSS` holds ``ẋ = A x + B u``, ``y = C x + D u`` (SI units of whatever the
signals are; time in s). Build one from a transfer function (:func:`tf`), from matrices
(:func:`ss`), or by connecting systems (:func:`series`, :func:`parallel`, :func:`feedback`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.signal

from ..errors import ConfigError

__all__ = ["ContinuousSS", "feedback", "parallel", "series", "ss", "system_from_dict", "tf"]


def _matrix(name: str, value: object, shape: tuple[int, int] | None = None) -> np.ndarray:
    try:
        arr = np.atleast_2d(np.asarray(value, dtype=float))
    except (TypeError, ValueError) as exc:
        raise ConfigError(name, value, "must be a numeric matrix") from exc
    if arr.ndim != 2:
        raise ConfigError(name, arr.shape, "must be a 2-D matrix")
    if not np.all(np.isfinite(arr)):
        raise ConfigError(name, value, "must be finite")
    if shape is not None and arr.shape != shape:
        raise ConfigError(name, arr.shape, f"shape must be {shape}")
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class ContinuousSS:
    """Continuous LTI system ``ẋ = A x + B u``, ``y = C x + D u``.

    Attributes
    ----------
    A, B, C, D:
        Read-only float matrices of shapes (n, n), (n, m), (p, n), (p, m).
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray

    @property
    def n_states(self) -> int:
        return self.A.shape[0]

    @property
    def n_inputs(self) -> int:
        return self.B.shape[1]

    @property
    def n_outputs(self) -> int:
        return self.C.shape[0]

    def poles(self) -> np.ndarray:
        """Eigenvalues of A (rad/s), sorted by real part then imaginary part."""
        if self.n_states == 0:
            return np.zeros(0, dtype=complex)
        ev = np.linalg.eigvals(self.A)
        return ev[np.lexsort((ev.imag, ev.real))]

    def is_stable(self) -> bool:
        """True when every pole has a strictly negative real part."""
        return bool(np.all(self.poles().real < 0.0))

    def freqresp(self, omega: Sequence[float] | np.ndarray) -> np.ndarray:
        """Frequency response G(jω), shape (len(ω), p, m); ω in rad/s."""
        w = np.atleast_1d(np.asarray(omega, dtype=float))
        n = self.n_states
        out = np.empty((w.size, self.n_outputs, self.n_inputs), dtype=complex)
        eye = np.eye(n)
        for i, wi in enumerate(w):
            if n:
                out[i] = self.C @ np.linalg.solve(1j * wi * eye - self.A, self.B) + self.D
            else:
                out[i] = self.D
        return out

    def dcgain(self) -> np.ndarray:
        """Static gain ``D − C A⁻¹ B``, shape (p, m)."""
        if self.n_states == 0:
            return np.array(self.D)
        return self.D - self.C @ np.linalg.solve(self.A, self.B)

    def to_tf(self) -> tuple[np.ndarray, np.ndarray]:
        """Numerator and denominator (descending powers of s) of a SISO system."""
        if self.n_inputs != 1 or self.n_outputs != 1:
            raise ConfigError("system", (self.n_outputs, self.n_inputs), "to_tf needs SISO")
        num, den = scipy.signal.ss2tf(self.A, self.B, self.C, self.D)
        return np.asarray(num[0], dtype=float), np.asarray(den, dtype=float)


def ss(A: object, B: object, C: object, D: object | None = None) -> ContinuousSS:
    """A continuous system from its matrices (D defaults to zeros); shapes are checked."""
    A_ = _matrix("A", A)
    n = A_.shape[0]
    if A_.shape != (n, n):
        raise ConfigError("A", A_.shape, "must be square")
    B_ = _matrix("B", B)
    if n == 0:
        B_ = B_.reshape(0, B_.shape[-1])
    if B_.shape[0] != n:
        raise ConfigError("B", B_.shape, f"must have {n} rows (states)")
    C_ = _matrix("C", C)
    if C_.shape[1] != n and not (n == 0):
        raise ConfigError("C", C_.shape, f"must have {n} columns (states)")
    if n == 0:
        C_ = C_.reshape(C_.shape[0] if C_.size else 1, 0)
    p, m = C_.shape[0], B_.shape[1]
    D_ = _matrix("D", np.zeros((p, m)) if D is None else D, (p, m))
    return ContinuousSS(A_, B_, C_, D_)


def tf(num: Sequence[float], den: Sequence[float]) -> ContinuousSS:
    """A SISO system from a transfer function N(s)/D(s), coefficients in descending powers.

    The realisation is the controllable canonical form of :func:`scipy.signal.tf2ss`. The
    transfer function must be proper (deg N ≤ deg D) and D(s) must not be zero.
    """
    num_ = np.trim_zeros(np.atleast_1d(np.asarray(num, dtype=float)), "f")
    den_ = np.trim_zeros(np.atleast_1d(np.asarray(den, dtype=float)), "f")
    if den_.size == 0:
        raise ConfigError("den", list(den), "denominator must not be zero")
    if not (np.all(np.isfinite(num_)) and np.all(np.isfinite(den_))):
        raise ConfigError("num/den", (list(num), list(den)), "coefficients must be finite")
    if num_.size > den_.size:
        raise ConfigError("num", list(num), f"degree must be ≤ that of den ({den_.size - 1})")
    if num_.size == 0:
        num_ = np.zeros(1)
    A, B, C, D = scipy.signal.tf2ss(num_, den_)
    n = den_.size - 1
    return ss(np.reshape(A, (n, n)), np.reshape(B, (n, 1)), np.reshape(C, (1, n)),
              np.reshape(D, (1, 1)))


def series(first: ContinuousSS, second: ContinuousSS) -> ContinuousSS:
    """``second ∘ first``: the output of ``first`` drives ``second`` (G = G₂ G₁)."""
    if first.n_outputs != second.n_inputs:
        raise ConfigError("series", (first.n_outputs, second.n_inputs),
                          "outputs of the first must equal inputs of the second")
    n1, n2 = first.n_states, second.n_states
    A = np.block([[first.A, np.zeros((n1, n2))], [second.B @ first.C, second.A]])
    B = np.vstack([first.B, second.B @ first.D])
    C = np.hstack([second.D @ first.C, second.C])
    D = second.D @ first.D
    return ss(A, B, C, D)


def parallel(a: ContinuousSS, b: ContinuousSS) -> ContinuousSS:
    """``a + b``: same input to both, outputs summed."""
    if (a.n_inputs, a.n_outputs) != (b.n_inputs, b.n_outputs):
        raise ConfigError("parallel", ((a.n_outputs, a.n_inputs), (b.n_outputs, b.n_inputs)),
                          "systems must have the same input and output sizes")
    A = scipy.linalg.block_diag(a.A, b.A)
    return ss(A, np.vstack([a.B, b.B]), np.hstack([a.C, b.C]), a.D + b.D)


def feedback(forward: ContinuousSS, back: ContinuousSS | None = None,
             sign: int = -1) -> ContinuousSS:
    """Closed loop ``y = G (r + sign·H y)``; H defaults to the identity (unity feedback).

    Requires ``I − sign·D_G D_H`` to be invertible (no algebraic loop without a solution).
    """
    if back is None:
        p = forward.n_outputs
        back = ss(np.zeros((0, 0)), np.zeros((0, p)), np.zeros((p, 0)), np.eye(p))
    G, H = forward, back
    if H.n_inputs != G.n_outputs or H.n_outputs != G.n_inputs:
        raise ConfigError("feedback", (H.n_outputs, H.n_inputs), "H must map outputs to inputs")
    s = float(sign)
    E = np.eye(G.n_inputs) - s * H.D @ G.D
    try:
        Ei = np.linalg.inv(E)
    except np.linalg.LinAlgError as exc:
        raise ConfigError("feedback", sign, "algebraic loop I − sign·D_H D_G is singular") \
            from exc
    # u = Ei (r + s H.C xh + s H.D G.C xg); y = G.C xg + G.D u; ẋh = H.A xh + H.B y
    Kg = s * Ei @ H.D @ G.C
    Kh = s * Ei @ H.C
    A = np.block([
        [G.A + G.B @ Kg, G.B @ Kh],
        [H.B @ (G.C + G.D @ Kg), H.A + H.B @ G.D @ Kh],
    ])
    B = np.vstack([G.B @ Ei, H.B @ G.D @ Ei])
    C = np.hstack([G.C + G.D @ Kg, G.D @ Kh])
    D = G.D @ Ei
    return ss(A, B, C, D)


def system_from_dict(spec: Mapping[str, object], field: str = "system") -> ContinuousSS:
    """A continuous system from scene data.

    ``{"num": [...], "den": [...]}`` (transfer function, descending powers of s) or
    ``{"A": [[...]], "B": [[...]], "C": [[...]], "D": [[...]]}`` (D optional); a list of such
    tables under ``"series"`` connects them in order (signal flows first → last).
    """
    if not isinstance(spec, Mapping):
        raise ConfigError(field, spec, "must be a table")
    if "series" in spec:
        parts = spec["series"]
        if not isinstance(parts, Sequence) or isinstance(parts, str) or not parts:
            raise ConfigError(f"{field}.series", parts, "must be a non-empty list of systems")
        sys = system_from_dict(parts[0], f"{field}.series[0]")
        for i, part in enumerate(parts[1:], start=1):
            sys = series(sys, system_from_dict(part, f"{field}.series[{i}]"))
        return sys
    if "num" in spec or "den" in spec:
        if "num" not in spec or "den" not in spec:
            missing = "num" if "num" not in spec else "den"
            raise ConfigError(f"{field}.{missing}", None, "a transfer function needs num and den")
        return tf(spec["num"], spec["den"])  # type: ignore[arg-type]
    if "A" in spec:
        for key in ("B", "C"):
            if key not in spec:
                raise ConfigError(f"{field}.{key}", None, "a state-space system needs A, B, C")
        return ss(spec["A"], spec["B"], spec["C"], spec.get("D"))
    raise ConfigError(field, sorted(spec), "needs num/den, A/B/C(/D) or series")
