"""``inverse``: inverse-model feed-forward from an identified transfer function, with its
filter (Chen & Ricles 2009 for a first-order model; Phillips & Spencer 2013's model-based
feed-forward for higher orders).

The transfer system is modelled as ``G(s)·exp(−sT)`` — e.g. the platform's identified heave
model (``rths3d platform identify``, ``assets/platform_heave_tf.json``), a per-leg model, or a
model fitted to any recorded test by :func:`calibrate`. The design, done once (python-control):

1. The command is held over a step and its answer measured at the end of it, so the step map
   from u_k to the measurement at t_{k+1} is H(z) = z·G_zoh(z) with G_zoh the exact
   (zero-order-hold) discretisation of G (a feedthrough D of G is read at the end of the held
   step). H is biproper, so H⁻¹ is causal: with the target z_k for t_{k+1}, the command
   u = H⁻¹(q) z makes the linear model track exactly.
2. Zeros of H on or outside the unit circle (sampling zeros of models of high relative
   degree) would make H⁻¹ unstable: each is reflected to 1/z̄ with the gain that keeps |H|
   at every frequency (zero-magnitude-error inversion); only its phase is then not undone.
3. The delay T cannot be inverted causally: the target is extrapolated T ahead, w = z + T ż
   (+ T²/2 z̈ with ``delay_order = 2``; z̈ from ż by a backward difference).
4. The correction is low-passed so that the inverse does not amplify high-frequency content
   (H⁻¹ rises with frequency like the model's relative degree): u = w + F(q)(H⁻¹(q) w − w)
   with F a Butterworth low-pass (``filter_order`` at ``filter_hz``; order 0: none, the exact
   inverse). Filtering only the correction keeps F's lag off the dominant part u ≈ w.

All filters run as second-order sections, one per channel (all channels share the model), in
one compiled kernel (:func:`inverse_kernel`: :func:`inverse_row` per channel) that the
compiled loops and :meth:`InverseCompensator.command` run alike.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numba import njit

from ..errors import ConfigError
from .base import (
    BaseCompensator,
    CompensatorConfig,
    check,
    comp_kernel,
    comp_ready,
    register,
    sos_row,
)


@dataclass(frozen=True)
class InverseModel(CompensatorConfig):
    """The model and its inversion (fields shared with ``model_based``).

    Attributes
    ----------
    num, den: G(s) in descending powers of s; empty: the platform's identified heave model
      (``rths3d.transfer.actuators.default_transfer_function``: assets/platform_heave_tf.json,
      or its 50 Hz second-order fallback).
    delay: the model's pure delay T (s), compensated by extrapolating the target, 0.
    delay_order: 1 (w = z + Tż) or 2 (+ T²/2 z̈), 2.
    filter_order, filter_hz: Butterworth low-pass on the inverse's correction, 2nd order at
      100 Hz; order 0: no filter (exact inverse).
    """

    num: tuple[float, ...] = ()
    den: tuple[float, ...] = ()
    delay: float = 0.0
    delay_order: int = 2
    filter_order: int = 2
    filter_hz: float = 100.0

    def check_model(self, name: str) -> None:
        check(f"{name}.num", list(self.num), bool(self.num) == bool(self.den),
              "give both num and den (or neither: the identified platform model)")
        check(f"{name}.num", list(self.num), all(math.isfinite(v) for v in self.num),
              "must be finite")
        check(f"{name}.den", list(self.den), all(math.isfinite(v) for v in self.den),
              "must be finite")
        check(f"{name}.delay", self.delay, math.isfinite(self.delay) and 0 <= self.delay <= 0.2,
              "must be in [0, 0.2] s")
        check(f"{name}.delay_order", self.delay_order, self.delay_order in (1, 2),
              "must be 1 or 2")
        check(f"{name}.filter_order", self.filter_order, 0 <= self.filter_order <= 8,
              "must be in 0…8")
        check(f"{name}.filter_hz", self.filter_hz, self.filter_hz > 0, "must be > 0 Hz")


@dataclass(frozen=True)
class InverseConfig(InverseModel):
    __doc__ = InverseModel.__doc__

    def __post_init__(self) -> None:
        self.check_model("inverse")


def model_of(config: InverseModel) -> tuple[np.ndarray, np.ndarray]:
    """(num, den) of the model: the config's, or the identified platform model."""
    if config.num:
        return np.asarray(config.num, float), np.asarray(config.den, float)
    from ..transfer.actuators import default_transfer_function

    num, den, _ = default_transfer_function()
    return np.asarray(num, float), np.asarray(den, float)


def design_inverse(num, den, dt: float, name: str = "inverse"
                   ) -> tuple[np.ndarray, np.ndarray, dict]:
    """The discrete inverse H⁻¹(z) of the held-step map H(z) = z·G_zoh(z) (see module
    docstring), as second-order sections (S, 6), its zeros/poles, and a report: ``reflected``
    (the zeros of H moved inside), ``dcgain`` of H⁻¹ (= 1/G(0))."""
    import control
    import scipy.signal

    num = np.trim_zeros(np.atleast_1d(np.asarray(num, float)), "f")
    den = np.trim_zeros(np.atleast_1d(np.asarray(den, float)), "f")
    if den.size == 0 or num.size == 0 or num.size > den.size:
        raise ConfigError(f"{name}.den", den.tolist(), "the model must be proper and nonzero")
    G = control.ss(control.tf(num, den))
    if G.nstates == 0:
        D = float(np.squeeze(G.D))
        if D == 0.0:
            raise ConfigError(f"{name}.num", num.tolist(), "the model must not be zero")
        return np.array([[1.0 / D, 0, 0, 1.0, 0, 0]]), np.zeros(0), {"reflected": [],
                                                                     "dcgain": 1.0 / D}
    Gd = control.c2d(G, dt, method="zoh")
    A, B, C = np.asarray(Gd.A), np.asarray(Gd.B), np.asarray(Gd.C)
    D = float(np.squeeze(Gd.D))
    n = A.shape[0]
    # H(z) = z·(C (zI − A)⁻¹ B) + D: numerator z·(num of the strictly proper part) + D·den
    b_sp, a = scipy.signal.ss2tf(A, B, C, np.zeros((1, 1)))
    b_sp, a = np.atleast_1d(np.squeeze(b_sp)), np.atleast_1d(np.squeeze(a))
    h_num = np.polyadd(np.polymul(b_sp, [1.0, 0.0])[-(n + 1):], D * a)
    h_num = np.trim_zeros(h_num, "f")
    if h_num.size != n + 1 or h_num[0] == 0.0:
        raise ConfigError(f"{name}.num", num.tolist(), "the held-step map is not biproper")
    zeros = np.roots(h_num)
    gain = h_num[0]
    reflected = []
    kept = []
    for zr in zeros:
        if abs(zr) >= 1.0 - 1e-9:
            # |e^{jω} − z| = |z|·|e^{jω} − 1/z̄|: same magnitude, the phase is not inverted
            gain *= abs(zr)
            kept.append(1.0 / np.conj(zr))
            reflected.append(complex(zr))
        else:
            kept.append(zr)
    poles_a = np.roots(a)
    # H⁻¹ = a(z) / (gain · Π(z − kept)): zeros at the plant's poles, poles at the kept zeros
    z_inv, p_inv, k_inv = poles_a, np.array(kept), 1.0 / gain
    sos = scipy.signal.zpk2sos(z_inv, p_inv, k_inv, pairing="nearest")
    dc = float(np.real(np.prod(1 - z_inv) / np.prod(1 - p_inv) * k_inv))
    return np.ascontiguousarray(sos, dtype=float), p_inv, {
        "reflected": reflected, "dcgain": dc, "zeros": z_inv, "poles": p_inv}


# the inverse's columns in a kernel row, from its parameter offset ``po``: T, c2, 1/dt, the
# number of sections of H⁻¹ and of F, then those sections (6 each) ...
_I_T, _I_C2, _I_DTI, _I_NC, _I_NF, _I_SOS = range(6)
# ... and from its state offset ``so``: ż of the last call, whether there was one, then the
# sections' states (2 each, H⁻¹'s then F's)
_I_PREV, _I_HAS, _I_ZI = range(3)


@njit(cache=True, nogil=True, inline="always")
def inverse_row(p, po, s, so, z, zd):
    """The inverse feed-forward of one channel (``inverse``'s kernel and ``model_based``'s
    alike): w = z + T ż + c2 z̈ (z̈ from ż by a backward difference, 0 on the first call),
    u = w + F(H⁻¹ w − w). ``p`` a parameter row with the inverse's columns from ``po``,
    ``s`` a state row with its state from ``so`` (the ``_I_*`` offsets); returns u."""
    nc = int(p[po + _I_NC])
    nf = int(p[po + _I_NF])
    zdd = (zd - s[so + _I_PREV]) * p[po + _I_DTI] if s[so + _I_HAS] > 0.0 else 0.0
    s[so + _I_PREV] = zd
    s[so + _I_HAS] = 1.0
    w = z + p[po + _I_T] * zd + p[po + _I_C2] * zdd
    v = sos_row(p, po + _I_SOS, nc, s, so + _I_ZI, w)
    return w + sos_row(p, po + _I_SOS + 6 * nc, nf, s, so + _I_ZI + 2 * nc, v - w)


@comp_kernel
def inverse_kernel(p, s, z, zd, zm, u):
    """One call of the ``inverse`` compensator for R = K·n rows: :func:`inverse_row` per
    row (parameters and state from column 0)."""
    for r in range(z.shape[0]):
        u[r] = inverse_row(p[r], 0, s[r], 0, z[r], zd[r])
    return False


class InverseCore:
    """The inverse feed-forward's design and its columns in a kernel's rows (shared by
    ``inverse`` and ``model_based``; the arithmetic is :func:`inverse_row`): ``P``
    parameter and ``S`` state columns per row."""

    def __init__(self, config: InverseModel, K: int, n: int, dt: float, name: str):
        from .base import butter_sos

        config.check_model(name)
        check(f"{name}.filter_hz", config.filter_hz,
              config.filter_order == 0 or config.filter_hz < 0.5 / dt,
              f"must be below the Nyquist frequency {0.5 / dt:g} Hz")
        num, den = model_of(config)
        self.model = (num, den)
        self.sos_c, _, self.report = design_inverse(num, den, dt, name)
        self.sos_f = butter_sos(config.filter_order, config.filter_hz, dt)
        self.order = config.delay_order
        self.K, self.n, self.dt = K, n, dt
        self.delay = float(config.delay)
        nc, nf = self.sos_c.shape[0], self.sos_f.shape[0]
        self.P = _I_SOS + 6 * (nc + nf)
        self.S = _I_ZI + 2 * (nc + nf)

    def fill(self, p: np.ndarray, po: int) -> None:
        """Write the inverse's parameters into the rows of ``p`` (K·n, ·) from column
        ``po``: T = the configured delay for every test."""
        nc, nf = self.sos_c.shape[0], self.sos_f.shape[0]
        p[:, po + _I_DTI] = 1.0 / self.dt
        p[:, po + _I_NC] = nc
        p[:, po + _I_NF] = nf
        p[:, po + _I_SOS:po + _I_SOS + 6 * nc] = self.sos_c.reshape(-1)
        p[:, po + _I_SOS + 6 * nc:po + self.P] = self.sos_f.reshape(-1)
        self._delays(p, po, np.full(self.K, self.delay))

    def _delays(self, p: np.ndarray, po: int, T: np.ndarray) -> None:
        """T (K,) s per test and c2 = T²/2 (0 for ``delay_order = 1``) into the rows."""
        c2 = 0.5 * T**2 if self.order == 2 else np.zeros(self.K)
        p[:, po + _I_T] = np.repeat(T, self.n)
        p[:, po + _I_C2] = np.repeat(c2, self.n)

    def delays(self, p: np.ndarray, po: int) -> np.ndarray:
        """The model's pure delay T (K,) s per test, read from the rows."""
        return p[::self.n, po + _I_T].copy()

    def start_from_delay(self, delay: np.ndarray, p: np.ndarray, po: int) -> None:
        """T per test = what the model G leaves of ``delay`` (K,) s, the transfer system's
        predicted delay from command to measurement: delay − G's low-frequency group delay
        + ΔT/2 (the held-step map z·G_zoh that H⁻¹ inverts leads G by half a step), ≥ 0;
        written with c2 into the parameter rows ``p`` from column ``po``."""
        from ..transfer.actuators import delay_estimate

        rest = np.asarray(delay, dtype=float).reshape(-1) - delay_estimate(*self.model) \
            + 0.5 * self.dt
        self._delays(p, po, np.maximum(rest, 0.0))


@register
class InverseCompensator(BaseCompensator):
    """Inverse-model feed-forward (see module docstring); no adaptive coefficients. Its step
    is :func:`inverse_kernel` (parameters and state per row: the ``_I_*`` columns)."""

    name = "inverse"
    rank = 50
    Config = InverseConfig

    def __init__(self, config: InverseConfig, K: int, n: int, dt: float):
        super().__init__(config, K, n, dt)
        self.core = core = InverseCore(config, K, n, dt, "inverse")
        comp_ready(inverse_kernel)
        self.params = np.zeros((K * n, core.P))
        core.fill(self.params, 0)
        self.state = np.zeros((K * n, core.S))

    def reset(self) -> None:
        super().reset()
        self.state[:] = 0.0

    prior_keys = ("delay",)

    def start_from_delay(self, delay: np.ndarray) -> bool:
        """The model's pure delay T = what the model leaves of ``delay`` (per test; see
        :meth:`InverseCore.start_from_delay`)."""
        self.core.start_from_delay(delay, self.params, 0)
        self.reset()
        return True

    def command(self, z: np.ndarray, zdot: np.ndarray, z_meas: np.ndarray) -> np.ndarray:
        flat = self.u.reshape(-1)
        inverse_kernel(self.params, self.state, np.ascontiguousarray(z).reshape(-1),
                       np.ascontiguousarray(zdot).reshape(-1), flat, flat)
        self.calls += 1
        return self.u

    def compiled(self):
        return (inverse_kernel,), self.params, self.state


def calibrate(u: np.ndarray, z_meas: np.ndarray, dt: float,
              config: InverseModel | None = None, band: tuple[float, float] = (0.2, 30.0),
              n_num: int = 1, n_den: int = 2, segment: float = 4.0,
              coherence: float = 0.9, lines: int = 40) -> InverseModel:
    """Identify the model from a recorded test: the frequency response from the command of
    each call to the measurement of the next (Welch H1 estimate over ``segment``-second
    windows; up to ``lines`` log-spaced lines in ``band`` Hz among those whose coherence
    reaches ``coherence``: the excited ones), corrected for the held step (a held command
    answered at the end of the step leads the continuous model by dt/2), then
    ``num/den·exp(−sT)`` fitted as ``rths3d platform identify`` fits the platform
    (:func:`rths3d.lti.identify.fit_transfer_function`). Returns ``config`` (default
    :class:`InverseConfig`) with num, den and delay set."""
    import scipy.signal

    from ..lti.identify import fit_transfer_function

    config = config or InverseConfig()
    U = np.asarray(u, dtype=float).ravel()
    X = np.asarray(z_meas, dtype=float).ravel()
    if U.shape != X.shape or U.size < 64:
        raise ValueError(f"u {U.shape} and z_meas {X.shape}: need equal 1-D shapes")
    uu, xx = U[:-1], X[1:]  # command of call k, its answer at call k + 1
    nper = min(uu.size, int(round(segment / dt)))
    f, Puu = scipy.signal.welch(uu, fs=1 / dt, nperseg=nper)
    _, Pux = scipy.signal.csd(uu, xx, fs=1 / dt, nperseg=nper)
    _, Pxx = scipy.signal.welch(xx, fs=1 / dt, nperseg=nper)
    with np.errstate(divide="ignore", invalid="ignore"):
        coh = np.abs(Pux) ** 2 / (Puu * Pxx)
    ok = np.flatnonzero((f >= band[0]) & (f <= band[1]) & (coh >= coherence))
    if ok.size < n_num + n_den + 2:
        raise ValueError(f"only {ok.size} excited lines in {band} Hz with coherence ≥ "
                         f"{coherence}: the record does not identify the model")
    # lines spread evenly in log frequency (as the platform's multisine): Welch's linear
    # grid would otherwise let the upper decade outweigh the low frequencies that matter
    want = np.geomspace(f[ok[0]], f[ok[-1]], lines)
    sel = np.unique(ok[np.abs(np.log(f[ok])[None, :] - np.log(want)[:, None]).argmin(axis=1)])
    H = Pux[sel] / Puu[sel] * np.exp(-1j * np.pi * f[sel] * dt)
    num, den, delay, _err = fit_transfer_function(f[sel], H, n_num=n_num, n_den=n_den)
    return replace(config, num=tuple(float(v) for v in num),
                   den=tuple(float(v) for v in den), delay=float(delay))
