"""The compensator protocol, the registry and what every compensator shares.

A compensator shapes the command sent to a transfer system (one interface DOF or one leg of
the Stewart platform per channel) so that the *measured* displacement follows the desired one
despite the transfer system's delay and amplitude error. It is a filter with state, stepped
once per loop step for K tests × n channels:

    comp = COMPENSATORS["ats"](ATSConfig(), K, n, dt)   # or build("ats", K, n, dt, {...})
    u = comp.command(z, zdot, z_meas)                    # (K, n) → (K, n), every step
    comp.coefficients()                                  # {"a0": (K, n), …}
    comp.stopped, comp.reasons                           # drift safety, per test

Timing convention (the loop's): at call k, ``z`` (K, n) is the desired displacement for the
*end* of the step (t_{k+1}), ``zdot`` its rate, and ``z_meas`` the latest measurement, taken
at t_k, i.e. the answer to the command of call k − 1. Adaptive compensators pair their
command of call k − 1 with the measurement of call k. Units are those of the channel (m for
translations and leg lengths, rad for rotations), s for times.

Drift safety: a test whose compensator leaves its safe range (an adaptive coefficient
estimate outside its bounds for longer than ``bound_time``, or a command oscillating against
the desired motion, see :class:`WatchConfig`) is flagged in ``stopped`` (K,) with the reason
in ``reasons[k]`` and the :class:`~rths3d.errors.SafetyStop` in ``stops[k]`` (its ``t`` is
``t0 + k·dt`` for call k after :meth:`reset`); from then on that test's command is held at its
last value, and the driver stops the test as at any other safety limit.
"""

from __future__ import annotations

import math
import types
import typing
from collections.abc import Mapping, Sequence
from dataclasses import MISSING, dataclass, fields
from numbers import Integral, Real
from typing import Any, ClassVar, Protocol, runtime_checkable

import numba
import numpy as np
from numba import njit

from ..errors import ConfigError, SafetyStop
from ..kernels import F1, F2, ready

__all__ = [
    "COMPENSATORS", "COMP_SIG", "BaseCompensator", "Compensator", "CompensatorConfig",
    "WatchConfig", "build", "comp_kernel", "comp_ready", "compensator_class", "compensator_names",
    "config_from_dict", "register",
]


@runtime_checkable
class Compensator(Protocol):
    """What a transfer system (or the benchmark loop) drives, once per step.

    Built as ``cls(config, K, n, dt)``; ``name`` is its registry key. ``command`` returns a
    (K, n) buffer owned by the compensator (overwritten by the next call) and allocates
    nothing. ``coefficients`` returns its current (adaptive) coefficients as (K, n) arrays
    (views: copy them to keep a history).
    """

    name: ClassVar[str]
    config: Any
    K: int
    n: int
    dt: float
    stopped: np.ndarray
    reasons: list[str]

    def command(self, z: np.ndarray, zdot: np.ndarray, z_meas: np.ndarray) -> np.ndarray: ...

    def reset(self) -> None: ...

    def coefficients(self) -> dict[str, np.ndarray]: ...


COMP_SIG = numba.types.boolean(F2, F2, F1, F1, F1, F1)
"""Signature of a compensator's per-step kernel for the compiled loop: (params (R, P),
state (R, S), z (R,), ż (R,), z_meas (R,), u (R,)) over R = K·n rows (test-major: row
k·n + j), returning True when it raised a new safety event (a drifting adaptive
compensator: the loop hands the step back to Python, which turns it into the stop through
the compensator's ``events(call)``)."""


def comp_kernel(fn: Any) -> Any:
    """``fn`` as a compensator kernel, compiled for :data:`COMP_SIG` (cached) on first use:
    its compensator's constructor calls :func:`comp_ready` (as block kernels,
    :func:`rths3d.effects.blocks.block_kernel`, importing loads nothing)."""
    return numba.njit(cache=True, nogil=True)(fn)


def comp_ready(kernel: Any) -> Any:
    """``kernel`` (a :func:`comp_kernel`) compiled for :data:`COMP_SIG` and closed to other
    signatures."""
    return ready(kernel, COMP_SIG)


COMPENSATORS: dict[str, type[BaseCompensator]] = {}
"""Registry: name → compensator class (each with a ``Config`` frozen dataclass)."""


def register(cls: type[BaseCompensator]) -> type[BaseCompensator]:
    """Class decorator: add ``cls`` to :data:`COMPENSATORS` under ``cls.name``."""
    name = getattr(cls, "name", "")
    if not name or not isinstance(name, str):
        raise TypeError(f"{cls.__name__} needs a class attribute 'name'")
    if name in COMPENSATORS and COMPENSATORS[name] is not cls:
        raise ValueError(f"compensator {name!r} is already registered")
    COMPENSATORS[name] = cls
    return cls


def compensator_names() -> list[str]:
    """The registered names in listing order (fixed schemes, then model-based and adaptive)."""
    return sorted(COMPENSATORS, key=lambda n: (COMPENSATORS[n].rank, n))


def compensator_class(name: str, field: str = "compensator") -> type[BaseCompensator]:
    """The registered class ``name``; ConfigError naming the choices if unknown."""
    try:
        return COMPENSATORS[name]
    except (KeyError, TypeError):
        raise ConfigError(field, name, "must be one of " + ", ".join(compensator_names())
                          ) from None


def _convert(field: str, tp: Any, value: Any) -> Any:
    """``value`` converted to the field type ``tp`` (float, int, bool, str, tuples, optional)."""
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        errors = []
        for a in args:
            if a is type(None):
                continue
            try:
                return _convert(field, a, value)
            except ConfigError as exc:
                errors.append(exc.limit)
        raise ConfigError(field, value, " or ".join(dict.fromkeys(errors)))
    if tp is bool:
        if not isinstance(value, bool | np.bool_):
            raise ConfigError(field, value, "must be true or false")
        return bool(value)
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, Integral):
            raise ConfigError(field, value, "must be an integer")
        return int(value)
    if tp is float:
        if isinstance(value, bool | np.bool_) or not isinstance(value, Real):
            raise ConfigError(field, value, "must be a number")
        return float(value)
    if tp is str:
        if not isinstance(value, str):
            raise ConfigError(field, value, "must be a string")
        return value
    if origin is tuple:
        if isinstance(value, str | bytes | Mapping) or not isinstance(value, Sequence
                                                                           | np.ndarray):
            raise ConfigError(field, value, "must be a list")
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_convert(field, args[0], v) for v in value)
        if len(value) != len(args):
            raise ConfigError(field, value, f"must be a list of {len(args)} values")
        return tuple(_convert(field, a, v) for a, v in zip(args, value, strict=True))
    raise TypeError(f"unsupported config field type {tp!r}")  # a programming error


def config_from_dict(name: str, data: Mapping[str, Any] | None = None,
                     field: str = "compensator") -> Any:
    """The frozen config of compensator ``name`` from a mapping (scene table, sweep row).

    Unknown keys and values of the wrong type raise :class:`ConfigError` naming
    ``<field>.<key>``; out-of-range values are refused by the config itself.
    """
    cls = compensator_class(name, field)
    cfg_cls = cls.Config
    data = dict(data or {})
    hints = typing.get_type_hints(cfg_cls)
    known = {f.name: f for f in fields(cfg_cls)}
    kw = {}
    for key, value in data.items():
        if key not in known:
            raise ConfigError(f"{field}.{key}", value, f"unknown key for {name!r} (allowed: "
                              f"{', '.join(known)})")
        kw[key] = _convert(f"{field}.{key}", hints[key], value)
    return cfg_cls(**kw)


def build(name: str, K: int, n: int, dt: float, config: Any = None,
          field: str = "compensator") -> BaseCompensator:
    """Compensator ``name`` for K tests × n channels at step ``dt`` (s); ``config`` is its
    Config, a mapping of its fields, or None for the defaults."""
    cls = compensator_class(name, field)
    if config is None or isinstance(config, Mapping):
        config = config_from_dict(name, config, field)
    elif not isinstance(config, cls.Config):
        raise ConfigError(field, type(config).__name__, f"must be a {cls.Config.__name__}")
    return cls(config, K, n, dt)


# ---------------------------------------------------------------------------------------
# configuration helpers

def check(field: str, value: Any, ok: bool, limit: str) -> None:
    """ConfigError ``field: value (limit)`` unless ``ok``."""
    if not ok:
        raise ConfigError(field, value, limit)


def check_bounds(field: str, lo_hi: tuple[float, float]) -> None:
    lo, hi = lo_hi
    check(field, list(lo_hi), math.isfinite(lo) and math.isfinite(hi) and lo <= hi,
          "must be two finite numbers [lo, hi] with lo ≤ hi")


def channel_blocks(field: str, values: Sequence[float], size: int, K: int, n: int,
                   shape: tuple[int, ...]) -> np.ndarray:
    """A block parameter (``size`` numbers of ``shape``, e.g. FIR taps or a covariance) as a
    (K, n, *shape) array: one block for every channel, or one per channel (n·size values)."""
    v = np.asarray(values, dtype=float)
    if v.size == size:
        return np.broadcast_to(v.reshape(shape), (K, n, *shape)).copy()
    if v.size == n * size:
        return np.broadcast_to(v.reshape(n, *shape), (K, n, *shape)).copy()
    check(field, list(values), False, f"must be {size} values, or {n * size} ({size} per "
          "channel)")
    raise AssertionError  # pragma: no cover


def channel_values(field: str, value: float | Sequence[float], K: int, n: int,
                   per: str = "channel") -> np.ndarray:
    """A parameter as a (K, n) array: a scalar for all, or one value per channel (length n,
    ``per="channel"``) or per test (length K, ``per="test"``)."""
    a = np.asarray(value, dtype=float)
    if a.ndim == 0:
        return np.full((K, n), float(a))
    size = n if per == "channel" else K
    if a.ndim != 1 or a.size != size:
        raise ConfigError(field, list(np.atleast_1d(a).tolist()),
                          f"must be one number or {size} (one per {per})")
    return np.ascontiguousarray(np.broadcast_to(a[None, :] if per == "channel"
                                                else a[:, None], (K, n)))


@dataclass(frozen=True)
class CompensatorConfig:
    """Base of every compensator's configuration (frozen; SI units)."""

    def check(self, name: str) -> None:  # subclasses validate in __post_init__
        return None


@dataclass(frozen=True)
class WatchConfig(CompensatorConfig):
    """The command-oscillation watch shared by the adaptive and feedback compensators.

    Attributes
    ----------
    osc_ratio, osc_floor, osc_corner, osc_time, osc_hold: the command oscillates when the RMS
      of its part above ``osc_corner`` (Hz; 2nd-order Butterworth high-pass), averaged over
      ``osc_time`` (s, exponential window), has exceeded ``osc_ratio`` × the RMS of the
      desired motion (about its running mean, same window) plus ``osc_floor`` (channel
      units: m or rad) for longer than ``osc_hold`` (s). A tracking command carries little
      above the corner (a 5 Hz motion: 6 % of its RMS) and a start transient dies out within
      the hold; a compensator or loop going unstable keeps its growing oscillation there.
      Defaults 0.5, 0.1 mm, 20 Hz, 0.05 s, 0.25 s; ``osc_ratio = inf`` turns the watch off.
    """

    osc_ratio: float = 0.5
    osc_floor: float = 1e-4
    osc_corner: float = 20.0
    osc_time: float = 0.05
    osc_hold: float = 0.25

    def check_watch(self, name: str, dt: float) -> None:
        check(f"{name}.osc_ratio", self.osc_ratio, self.osc_ratio > 0.0,
              "must be > 0 (inf: off)")
        check(f"{name}.osc_floor", self.osc_floor,
              self.osc_floor >= 0.0 and math.isfinite(self.osc_floor), "must be ≥ 0")
        check(f"{name}.osc_corner", self.osc_corner,
              0.0 < self.osc_corner < 0.5 / dt, f"must be in (0, {0.5 / dt:g}) Hz (Nyquist)")
        check(f"{name}.osc_time", self.osc_time, self.osc_time >= dt,
              f"must be ≥ one step ({dt:g} s)")
        check(f"{name}.osc_hold", self.osc_hold, self.osc_hold >= 0.0, "must be ≥ 0 s")

    def watch_params(self, dt: float) -> np.ndarray:
        """``[α, ratio, floor, dt, hold]`` for :func:`watch_row` (ratio inf → 1e300)."""
        ratio = self.osc_ratio if math.isfinite(self.osc_ratio) else 1e300
        return np.array([-math.expm1(-dt / self.osc_time), ratio, self.osc_floor, dt,
                         self.osc_hold])


# ---------------------------------------------------------------------------------------
# numba kernels shared by the compensators

WATCH_STATES = 6
"""Per-channel state of the oscillation watch: the high-pass section of u (2), the running
mean of z, the mean square of z about it, the mean square of u_hp, the time over the limit."""


@njit(cache=True, nogil=True, inline="always")
def sos_row(p, po, nsec, s, so, x):
    """One sample ``x`` through second-order sections (transposed direct form II), for the
    kernels of :data:`COMP_SIG`: ``nsec`` sections [b0, b1, b2, 1, a1, a2] stored in the
    parameter row ``p`` from column ``po`` (6 each, scipy's ``sos`` rows), their state in the
    state row ``s`` from column ``so`` (2 each, updated in place); returns the output."""
    y = x
    for i in range(nsec):
        q = po + 6 * i
        b0, b1, b2, a1, a2 = p[q], p[q + 1], p[q + 2], p[q + 4], p[q + 5]
        z0 = so + 2 * i
        out = b0 * y + s[z0]
        s[z0] = b1 * y - a1 * out + s[z0 + 1]
        s[z0 + 1] = b2 * y - a2 * out
        y = out
    return y


@njit(cache=True, nogil=True, inline="always")
def watch_row(p, wpo, hpo, s, w, u, z):
    """The oscillation watch of one channel, for the kernels of :data:`COMP_SIG`: its
    parameters [α, ratio, floor, dt, hold] (:meth:`WatchConfig.watch_params`) in the
    parameter row ``p`` from column ``wpo`` (5), its high-pass section from ``hpo`` (6), its
    state in the state row ``s`` from column ``w`` (:data:`WATCH_STATES`). The command ``u``
    oscillates when the running RMS of its high-passed part has exceeded ``ratio`` × the
    running RMS of the desired motion ``z`` about its mean, plus ``floor``, for longer than
    ``hold`` (s). Returns (oscillating, rms of u_hp, limit)."""
    h = hpo
    alpha, ratio, floor, dt, hold = p[wpo], p[wpo + 1], p[wpo + 2], p[wpo + 3], p[wpo + 4]
    yu = p[h] * u + s[w]
    s[w] = p[h + 1] * u - p[h + 4] * yu + s[w + 1]
    s[w + 1] = p[h + 2] * u - p[h + 5] * yu
    s[w + 2] += alpha * (z - s[w + 2])
    dz = z - s[w + 2]
    s[w + 3] += alpha * (dz * dz - s[w + 3])
    s[w + 4] += alpha * (yu * yu - s[w + 4])
    ru = math.sqrt(s[w + 4])
    lim = ratio * math.sqrt(s[w + 3]) + floor
    if ru > lim:
        s[w + 5] += dt
    else:
        s[w + 5] = 0.0
    return s[w + 5] > hold, ru, lim


def butter_sos(order: int, cutoff: float, dt: float, kind: str = "lowpass") -> np.ndarray:
    """Digital Butterworth (bilinear, prewarped at ``cutoff`` Hz) as sections (S, 6);
    order 0 gives an identity section."""
    import scipy.signal

    if order <= 0:
        return np.array([[1.0, 0.0, 0.0, 1.0, 0.0, 0.0]])
    return np.ascontiguousarray(scipy.signal.butter(order, cutoff, btype=kind, fs=1.0 / dt,
                                                    output="sos"), dtype=float)


# ---------------------------------------------------------------------------------------
# the base class

class BaseCompensator:
    """Buffers, safety flags and reasons every compensator has (see module docstring).

    Subclasses set ``name`` and ``Config``, fill ``self.u`` in :meth:`command`, and report
    stops through :meth:`_stop` (or the event arrays of :meth:`_events`).
    """

    name: ClassVar[str] = ""
    Config: ClassVar[type] = CompensatorConfig
    rank: ClassVar[int] = 100
    """Position in listings and ``all`` tables (fixed schemes first, then adaptive ones)."""
    adaptive: ClassVar[bool] = False
    """Whether its coefficients change during a test (its :meth:`history` is copied after
    every step) and its kernel may raise safety events (:meth:`events`)."""

    def __init__(self, config: Any, K: int, n: int, dt: float):
        if not (isinstance(K, Integral) and K >= 1 and isinstance(n, Integral) and n >= 1):
            raise ValueError(f"K = {K}, n = {n}: need K ≥ 1 tests and n ≥ 1 channels")
        if not (dt > 0.0 and math.isfinite(dt)):
            raise ConfigError(f"{self.name}.dt", dt, "must be > 0 s")
        self.config = config
        self.K, self.n, self.dt = int(K), int(n), float(dt)
        self.u = np.zeros((self.K, self.n))
        self.stopped = np.zeros(self.K, dtype=bool)
        self._any_stopped = False
        self.reasons: list[str] = [""] * self.K
        self.stops: list[SafetyStop | None] = [None] * self.K
        self.t0 = 0.0
        """Time (s) of the first call after reset, for the stop reasons."""
        self.calls = 0
        """Calls of :meth:`command` since reset."""

    # -- protocol ----------------------------------------------------------------------
    def command(self, z: np.ndarray, zdot: np.ndarray, z_meas: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    @property
    def any_stopped(self) -> bool:
        """Whether a test has stopped (cheaper than ``stopped.any()`` every step)."""
        return self._any_stopped

    def reset(self) -> None:
        self._any_stopped = False
        self.u[:] = 0.0
        self.stopped[:] = False
        self.reasons = [""] * self.K
        self.stops = [None] * self.K
        self.calls = 0

    def coefficients(self) -> dict[str, np.ndarray]:
        return {}

    prior_keys: ClassVar[tuple[str, ...]] = ()
    """Config keys that :meth:`start_from_delay` sets (a scene giving any of them keeps its
    own initial values)."""

    def start_from_delay(self, delay: np.ndarray) -> bool:
        """Start from the inverse of a pure delay: ``delay`` (K,) s per test, the transfer
        system's predicted delay (its ``transfer_meta["predicted_delay"]``). Sets the
        initial (adaptive) coefficients and resets; False for compensators without any
        (they keep their configuration)."""
        return False

    def history(self) -> np.ndarray | None:
        """A live (K, n, w) array that holds what the coefficients are made of, updated in
        place by :meth:`command` (the loop copies it after every step to record the
        coefficients over time, :meth:`history_coefficients` turns the copies into
        coefficients). None: no coefficients."""
        return None

    def history_coefficients(self, states: np.ndarray) -> dict[str, np.ndarray]:
        """The coefficients (..., K, n) from copies (..., K, n, w) of :meth:`history`, in
        the order of :meth:`coefficients`; by default state i is the i-th coefficient."""
        return {name: states[..., i] for i, name in enumerate(self.coefficients())}

    def compiled(self) -> tuple[tuple[Any], np.ndarray, np.ndarray] | None:
        """((kernel,), params, state) of a compensator whose step is one :data:`COMP_SIG`
        kernel (the compiled loop runs it); None for those stepped from Python."""
        return None

    event_labels: ClassVar[tuple[str, ...]] = ()
    """What each event code i ≥ 1 of its kernel means (``labels[i-1]``, ``{ch}`` the channel);
    empty: a compensator whose kernel raises none. With labels, the compensator keeps the
    kernel's event arrays as ``code``, ``ev_val`` and ``ev_lim`` (K, n)."""
    event_units: ClassVar[tuple[str, ...]] = ()
    """The unit of each event's value (same order as :attr:`event_labels`)."""

    def events(self, call: int | None = None, tests: slice = slice(None)) -> None:
        """Turn the safety events its kernel raised for ``tests`` (a :data:`COMP_SIG` kernel
        returned True) into stops at call ``call`` (default: this one); the compiled loop
        calls this after the step whose kernel call returned True. Nothing for a
        compensator without events."""
        if self.event_labels:
            self._events(self.code, self.ev_val, self.ev_lim, self.event_labels,
                         self.event_units, call, tests)

    # -- stops -------------------------------------------------------------------------
    def _stop(self, k: int, quantity: str, value: float, limit: float, unit: str = "",
              call: int | None = None) -> None:
        """Stop test ``k`` (once) with a SafetyStop at call ``call`` (default: this one)."""
        if self.stopped[k] and self.stops[k] is not None:
            return
        c = self.calls if call is None else call
        stop = SafetyStop(quantity, value, limit, self.t0 + c * self.dt, k, unit)
        self._any_stopped = True
        self.stopped[k] = True
        self.stops[k] = stop
        self.reasons[k] = stop.reason

    def _events(self, code: np.ndarray, value: np.ndarray, limit: np.ndarray,
                labels: Sequence[str], units: Sequence[str], call: int | None = None,
                tests: slice = slice(None)) -> None:
        """Turn kernel events into stops: ``code`` (K, n) (0: none, i ≥ 1: ``labels[i-1]``),
        with the offending ``value`` and ``limit`` (K, n), at call ``call`` (default: this
        one), for ``tests``."""
        for k in range(self.K)[tests]:
            if self.stops[k] is not None:
                continue
            hit = np.flatnonzero(code[k])
            if hit.size:
                j = int(hit[0])
                c = int(code[k, j]) - 1
                label = labels[c].format(ch=j)
                self._stop(k, f"{self.name} {label}", float(value[k, j]),
                           float(limit[k, j]), units[c], call)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(K={self.K}, n={self.n}, dt={self.dt:g}, {self.config})"


def config_defaults(cfg_cls: type) -> dict[str, Any]:
    """Field name → default of a config class (for docs and tables)."""
    out = {}
    for f in fields(cfg_cls):
        if f.default is not MISSING:
            out[f.name] = f.default
        elif f.default_factory is not MISSING:  # pragma: no cover - none use factories yet
            out[f.name] = f.default_factory()
    return out


def measured_delay(u: np.ndarray, z_meas: np.ndarray, dt: float,
                   band: tuple[float, float] = (0.2, 5.0), segment: float = 4.0,
                   coherence: float = 0.9) -> float:
    """The delay (s) from the command of each call to the measurement of the next, from a
    recorded test: the phase delay −∠H/ω of the Welch cross-spectral estimate, averaged over
    the lines in ``band`` (Hz) whose coherence reaches ``coherence``, weighted by the
    command's power. A compensator that advances the target by this time makes the
    measurement of call k + 1 meet the target of call k at those frequencies."""
    import scipy.signal

    U = np.asarray(u, dtype=float).ravel()
    X = np.asarray(z_meas, dtype=float).ravel()
    if U.shape != X.shape or U.size < 64:
        raise ValueError(f"u {U.shape} and z_meas {X.shape}: need equal 1-D shapes")
    uu, xx = U[:-1], X[1:]
    nper = min(uu.size, int(round(segment / dt)))
    f, Puu = scipy.signal.welch(uu, fs=1 / dt, nperseg=nper)
    _, Pux = scipy.signal.csd(uu, xx, fs=1 / dt, nperseg=nper)
    _, Pxx = scipy.signal.welch(xx, fs=1 / dt, nperseg=nper)
    with np.errstate(divide="ignore", invalid="ignore"):
        coh = np.abs(Pux) ** 2 / (Puu * Pxx)
    sel = (f >= band[0]) & (f <= band[1]) & (coh >= coherence)
    if not np.any(sel):
        raise ValueError(f"no excited line in {band} Hz with coherence ≥ {coherence}")
    H = Pux[sel] / Puu[sel]
    tau = -np.unwrap(np.angle(H)) / (2 * np.pi * f[sel])
    return float(np.average(tau, weights=Puu[sel]))
