"""Continuous-time LTI systems: python-control state-space objects built from scene data.

The design-time objects are python-control's (:class:`control.StateSpace`; time in s, SI
units of whatever the signals are). :class:`ContinuousSS` is a ``control.StateSpace`` with
``dt = 0`` and the few conveniences rths3d code and scenes use (see :class:`SSConveniences`);
:func:`tf`, :func:`ss`, :func:`series`, :func:`parallel` and :func:`feedback` check their
input, name the bad field in a :class:`~rths3d.errors.ConfigError`, and call
``control.tf2ss``, ``control.ss``, ``control.series``, ``control.parallel`` and
``control.feedback``. Any python-control function takes these objects directly.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import control
import numpy as np

from ..errors import ConfigError

__all__ = ["ContinuousSS", "SSConveniences", "feedback", "parallel", "series", "ss",
           "system_from_dict", "tf", "tf_coefficients"]


class SSConveniences:
    """Methods rths3d adds to a ``control.StateSpace`` (mixed in before it).

    ``freqresp`` and ``dcgain`` always return arrays of shape (len(ω), p, m) and (p, m), also
    for SISO systems (python-control squeezes them); ``to_tf`` returns coefficient arrays.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    dt: Any
    nstates: int
    ninputs: int
    noutputs: int

    @property
    def n_states(self) -> int:
        return self.nstates

    @property
    def n_inputs(self) -> int:
        return self.ninputs

    @property
    def n_outputs(self) -> int:
        return self.noutputs

    def freqresp(self, omega: Sequence[float] | np.ndarray) -> np.ndarray:
        """Frequency response at ω (rad/s), shape (len(ω), p, m): G(jω), or G(e^{jω dt})
        for a discrete system."""
        w = np.atleast_1d(np.asarray(omega, dtype=float))
        x = np.exp(1j * w * self.dt) if self.dt else 1j * w
        return np.moveaxis(np.asarray(self(x, squeeze=False)), -1, 0)  # type: ignore[operator]

    def dcgain(self, warn_infinite: bool = False) -> np.ndarray:
        """Static gain, shape (p, m): ``D − C A⁻¹ B`` (continuous), ``D + C (I − A)⁻¹ B``
        (discrete)."""
        g = super().dcgain(warn_infinite)  # type: ignore[misc]
        return np.asarray(g, dtype=float if np.isrealobj(g) else complex).reshape(
            self.noutputs, self.ninputs)

    def to_tf(self) -> tuple[np.ndarray, np.ndarray]:
        """:func:`tf_coefficients` of this (SISO) system."""
        return tf_coefficients(self)  # type: ignore[arg-type]


def tf_coefficients(sys: control.StateSpace) -> tuple[np.ndarray, np.ndarray]:
    """Numerator and denominator of a SISO system (``control.ss2tf``), descending powers of
    s (or z), the numerator padded with leading zeros to the denominator's length (so that,
    for a discrete system, they are also the coefficients of z⁻¹)."""
    if sys.ninputs != 1 or sys.noutputs != 1:
        raise ConfigError("system", (sys.noutputs, sys.ninputs), "needs a SISO system")
    g = control.ss2tf(sys)
    num = np.asarray(g.num[0][0], dtype=float)
    den = np.asarray(g.den[0][0], dtype=float)
    return np.concatenate([np.zeros(max(den.size - num.size, 0)), num]), den


class ContinuousSS(SSConveniences, control.StateSpace):
    """Continuous LTI system ``ẋ = A x + B u``, ``y = C x + D u`` (a ``control.StateSpace``
    with ``dt = 0``). ``ContinuousSS(sys)`` takes any continuous python-control system."""

    def __init__(self, *args: Any, **kwargs: Any):
        if len(args) == 1:
            sys = control.ss(args[0])
            if sys.dt not in (0, None):
                raise ConfigError("system", sys.dt, "must be continuous (dt = 0)")
            args = (sys.A, sys.B, sys.C, sys.D)
        super().__init__(*args, 0, **kwargs)

    def is_stable(self) -> bool:
        """True when every pole has a strictly negative real part."""
        return bool(np.all(self.poles().real < 0.0))


def ss(A: object, B: object, C: object, D: object | None = None) -> ContinuousSS:
    """A continuous system from its matrices (D defaults to zeros); python-control checks the
    shapes, a bad one or a non-finite entry is a ConfigError naming the matrix."""
    mats = {"A": A, "B": B, "C": C, "D": 0.0 if D is None else D}
    for name, value in mats.items():
        try:
            finite = bool(np.all(np.isfinite(np.asarray(value, dtype=float))))
        except (TypeError, ValueError):
            finite = False
        if not finite:
            raise ConfigError(name, value, "must be a finite numeric matrix")
    try:
        return ContinuousSS(*mats.values())
    except ValueError as exc:  # control.ControlDimension names the matrix and its shape
        raise ConfigError("ss", message=f"ss: {exc}") from exc


def tf(num: Sequence[float], den: Sequence[float]) -> ContinuousSS:
    """A SISO system from a transfer function N(s)/D(s), coefficients in descending powers.

    The realisation is ``control.tf2ss`` (without slycot: the controllable canonical form of
    :func:`scipy.signal.tf2ss`). The transfer function must be proper (deg N ≤ deg D) and
    D(s) must not be zero. For python-control's transfer-function object use
    ``control.tf(num, den)``.
    """
    return ContinuousSS(control.tf2ss(*proper_polynomials(num, den)))


def proper_polynomials(num: Sequence[float], den: Sequence[float]
                       ) -> tuple[np.ndarray, np.ndarray]:
    """N(s), D(s) as float arrays without leading zeros (N = [0] if zero), checked: finite,
    D ≠ 0, deg N ≤ deg D; else a ConfigError naming ``num`` or ``den``."""
    num_ = np.trim_zeros(np.atleast_1d(np.asarray(num, dtype=float)), "f")
    den_ = np.trim_zeros(np.atleast_1d(np.asarray(den, dtype=float)), "f")
    if den_.size == 0:
        raise ConfigError("den", list(den), "denominator must not be zero")
    if not (np.all(np.isfinite(num_)) and np.all(np.isfinite(den_))):
        raise ConfigError("num/den", (list(num), list(den)), "coefficients must be finite")
    if num_.size > den_.size:
        raise ConfigError("num", list(num), f"degree must be ≤ that of den ({den_.size - 1})")
    return (num_ if num_.size else np.zeros(1)), den_


def _connect(name: str, fn: Any, *systems: Any, **kwargs: Any) -> ContinuousSS:
    """``fn(*systems)`` of python-control as a ContinuousSS; its ValueError (sizes, algebraic
    loop) as a ConfigError naming the connection."""
    try:
        return ContinuousSS(fn(*systems, **kwargs))
    except ValueError as exc:
        sizes = [np.shape(s.D) for s in systems]  # (outputs, inputs) of each
        raise ConfigError(name, sizes, str(exc)) from exc


def series(first: ContinuousSS, second: ContinuousSS) -> ContinuousSS:
    """``second ∘ first``: the output of ``first`` drives ``second`` (G = G₂ G₁);
    ``control.series``, without its promotion of a SISO system to a diagonal MIMO one."""
    if first.noutputs != second.ninputs:
        raise ConfigError("series", (first.noutputs, second.ninputs),
                          "outputs of the first must equal inputs of the second")
    return _connect("series", control.series, first, second)


def parallel(a: ContinuousSS, b: ContinuousSS) -> ContinuousSS:
    """``a + b``: same input to both, outputs summed; ``control.parallel``, without its
    promotion of a SISO system to a diagonal MIMO one."""
    if (a.ninputs, a.noutputs) != (b.ninputs, b.noutputs):
        raise ConfigError("parallel", ((a.noutputs, a.ninputs), (b.noutputs, b.ninputs)),
                          "systems must have the same input and output sizes")
    return _connect("parallel", control.parallel, a, b)


def feedback(forward: ContinuousSS, back: ContinuousSS | None = None,
             sign: int = -1) -> ContinuousSS:
    """Closed loop ``y = G (r + sign·H y)``; H defaults to the identity (unity feedback);
    ``control.feedback``. An algebraic loop ``I − sign·D_H D_G`` that is singular is a
    ConfigError."""
    H = np.eye(forward.noutputs) if back is None else back
    try:
        return ContinuousSS(control.feedback(forward, H, sign=sign))
    except ValueError as exc:
        raise ConfigError("feedback", sign, str(exc)) from exc


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
