"""``rodeac``: robust decentralised adaptive compensation (RoDeAC; Quiroz, Gálmez &
Fermandois 2024, the reference controller of the multi-axial RTHS benchmark;
FermandoisLab/maRTHS-bmk-RoDeAC), one RLS adaptive FIR inverse per channel.

Per channel at call k, with the channel's signals in the controller's unit (channel unit ×
``signal_scale``: mm for a channel in m, as RoDeAC runs):

    φ_t,k = [z_k, z_{k−1}, …, z_{k−N+1}]            taps of the target
    x̃_k   = B(q) x_m,k,   φ_k = [x̃_k, …, x̃_{k−N+1}]   taps of the low-passed measurement
    g_k   = P_{k−1} φ_k / (λ + φ_kᵀ P_{k−1} φ_k)
    θ_k   = θ_{k−1} + g_k (ũ_k − θ_{k−1}ᵀ φ_k),   ũ = B(q) u (same low-pass, own state)
    P_k   = (P_{k−1} − g_k φ_kᵀ P_{k−1}) / λ
    u_k   = θ_kᵀ φ_t,k                                 (θ_k used at the same call)

B is a Butterworth low-pass (4th order, 20 Hz; MATLAB ``butter``'s direct form). ũ_k depends
on u_k through B's direct term b₀ and u_k on θ_k: Simulink solves this algebraic loop; it is
linear, so it is solved exactly here (``algebraic_loop=True``: θ_k = θ_{k−1} + g_k e₀ /
(1 − b₀ φ_t,kᵀ g_k) with e₀ the error at u_k = θ_{k−1}ᵀφ_t,k), or in one pass (False).

θ₀ and P₀ come from an offline calibration (:func:`calibrate`, RoDeAC's batch least squares
of the target on the raw measured taps: θ₀ = (ΓᵀΓ)⁻¹Γᵀz, P₀ = (ΓᵀΓ)⁻¹ with Γ in channel
units, m — RoDeAC computes P₀ from regressors in m and uses it with signals in mm, which
``signal_scale = 1000`` reproduces). P₀ = 0 keeps θ = θ₀ (the non-adaptive variant).

Bounds (safety, not in RoDeAC): the inverse's DC gain Σθ must stay within ``gain_bounds``;
an estimate outside them for longer than ``bound_time``, a non-finite command or an
oscillating one (:class:`~.base.WatchConfig`) stops the test with the reason.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numba import njit

from .base import (
    WATCH_STATES,
    BaseCompensator,
    WatchConfig,
    butter_sos,
    channel_blocks,
    check,
    check_bounds,
    comp_kernel,
    comp_ready,
    register,
    watch_row,
)


@dataclass(frozen=True)
class RoDeACConfig(WatchConfig):
    """Parameters.

    Attributes
    ----------
    taps: FIR length N (RoDeAC: 4), taps one call apart.
    theta0: initial θ: N values for every channel, or N per channel flattened channel by
      channel; empty: θ = [1, 0, …] (no compensation to start).
    p0: initial covariance: one value (p0·I), N² values (one matrix, row-major) for every
      channel, or N² per channel; in 1/(channel unit)² as RoDeAC stores it. Default 1e4.
    forgetting: λ (-), 1 in RoDeAC.
    filter_order, filter_hz: Butterworth low-pass B on x_m and u (4, 20 Hz; order 0: none).
    signal_scale: the controller's unit per channel unit (1000: mm for a channel in m).
    algebraic_loop: solve the loop through b₀ exactly (True) or in one pass.
    gain_bounds: allowed DC gain Σθ of the inverse (-), [0.05, 20] (RoDeAC with λ = 1 drifts
      toward small Σθ while only sensor noise is measured, e.g. 0.21 before the motion).
    bound_time: time (s) Σθ may stay outside its bounds before the test stops, 0.25 s.
    osc_*: the command-oscillation watch (:class:`~.base.WatchConfig`).
    """

    taps: int = 4
    theta0: tuple[float, ...] = ()
    p0: tuple[float, ...] = (1e4,)
    forgetting: float = 1.0
    filter_order: int = 4
    filter_hz: float = 20.0
    signal_scale: float = 1000.0
    algebraic_loop: bool = True
    gain_bounds: tuple[float, float] = (0.05, 20.0)
    bound_time: float = 0.25

    def __post_init__(self) -> None:
        N = self.taps
        check("rodeac.taps", self.taps, 1 <= self.taps <= 32, "must be in 1…32")
        check("rodeac.theta0", list(self.theta0),
              all(math.isfinite(v) for v in self.theta0)
              and (len(self.theta0) == 0 or len(self.theta0) % N == 0),
              f"must be empty or {N} values (taps) per channel")
        check("rodeac.p0", list(self.p0), len(self.p0) >= 1
              and all(math.isfinite(v) for v in self.p0)
              and (len(self.p0) == 1 or len(self.p0) % (N * N) == 0),
              f"must be one value or {N * N} (an N×N matrix) per channel")
        check("rodeac.forgetting", self.forgetting, 0.0 < self.forgetting <= 1.0,
              "must be in (0, 1]")
        check("rodeac.filter_order", self.filter_order, 0 <= self.filter_order <= 8,
              "must be in 0…8")
        check("rodeac.filter_hz", self.filter_hz, self.filter_hz > 0, "must be > 0 Hz")
        check("rodeac.signal_scale", self.signal_scale,
              self.signal_scale > 0 and math.isfinite(self.signal_scale), "must be > 0")
        check_bounds("rodeac.gain_bounds", self.gain_bounds)
        check("rodeac.bound_time", self.bound_time, self.bound_time >= 0.0, "must be ≥ 0 s")


_TIMER = 0
# the per-row parameters (``p`` of the kernel, (R, P)): scalars, the watch's parameters,
# its high-pass section, then the measurement filter's b and a (order + 1 each)
_P_N, _P_TAPS, _P_ORDER, _P_SCALE, _P_LAM, _P_EXACT, _P_GLO, _P_GHI, _P_BT, _P_DT = range(10)
_P_WP, _P_HP, _P_B = 10, 15, 21
# the per-row state (``s`` of the kernel, (R, S)) after the head (n·N + 1 columns, used in
# the first row of each test: θ per channel, then the stop flag, so that the coefficients
# of a test are contiguous and the history a view): the timer, the event (code, value,
# limit), the watch, then P, the target and measurement taps and the filter states
_S_CODE, _S_VAL, _S_LIM, _S_WATCH = 1, 2, 3, 4
_S_P = _S_WATCH + WATCH_STATES


@njit(cache=True, nogil=True, inline="always")
def _lfilter_row(p, bo, ao, order, s, zo, x):
    """One sample of ``b/a`` (transposed direct form II, a[0] = 1) with ``b``/``a`` in the
    parameter row ``p`` from ``bo``/``ao`` and the state (``order`` values) in the state
    row ``s`` from ``zo``."""
    y = p[bo] * x + (s[zo] if order else 0.0)
    for i in range(order - 1):
        s[zo + i] = p[bo + i + 1] * x - p[ao + i + 1] * y + s[zo + i + 1]
    if order:
        s[zo + order - 1] = p[bo + order] * x - p[ao + order] * y
    return y


@comp_kernel
def rodeac_kernel(p, s, z, zd, zm, u):
    """One call of RoDeAC for R = K·n rows (test-major): ``p`` (R, P) the parameters, ``s``
    (R, S) the state (layout: the ``_P_*``, ``_S_*`` offsets; the head of each test's first
    row holds θ and the stop flag). The whole compensator — the taps, the RLS update with
    the algebraic loop, the command, the gain bound, the non-finite and oscillation watch —
    for :meth:`RoDeACCompensator.command` and the compiled loops alike. Returns True when a
    new safety event was raised."""
    n = int(p[0, _P_N])
    N = int(p[0, _P_TAPS])
    H = n * N + 1
    K = z.shape[0] // n
    event = False
    Pphi = np.empty(N)
    for k in range(K):
        h0 = k * n
        head = s[h0]
        if head[n * N] != 0.0:
            continue
        for j in range(n):
            row = h0 + j
            pr = p[row]
            sr = s[row]
            order = int(pr[_P_ORDER])
            scale, lam, exact = pr[_P_SCALE], pr[_P_LAM], pr[_P_EXACT] > 0.5
            glo, ghi, bound_time, dt = pr[_P_GLO], pr[_P_GHI], pr[_P_BT], pr[_P_DT]
            bo = _P_B
            ao = _P_B + order + 1
            b0 = pr[bo]
            pp = H + _S_P
            pt = pp + N * N
            px = pt + N
            zi_x = px + N
            zi_u = zi_x + order
            th = j * N  # this channel's θ, in the head
            xt = z[row] * scale
            xm = zm[row] * scale
            for i in range(N - 1, 0, -1):
                sr[pt + i] = sr[pt + i - 1]
                sr[px + i] = sr[px + i - 1]
            sr[pt] = xt
            sr[px] = _lfilter_row(pr, bo, ao, order, sr, zi_x, xm)
            den = lam
            th_t = 0.0
            th_m = 0.0
            for r in range(N):
                acc = 0.0
                for c in range(N):
                    acc += sr[pp + r * N + c] * sr[px + c]
                Pphi[r] = acc
                den += sr[px + r] * acc
                th_t += head[th + r] * sr[pt + r]
                th_m += head[th + r] * sr[px + r]
            rk = sr[zi_u] if order else 0.0
            e = b0 * th_t + rk - th_m
            if exact:
                gt = 0.0
                for r in range(N):
                    gt += Pphi[r] * sr[pt + r]
                e = e / (1.0 - b0 * gt / den)
            for r in range(N):
                head[th + r] += Pphi[r] / den * e
            for r in range(N):
                for c in range(r, N):
                    v = (sr[pp + r * N + c] - Pphi[r] * Pphi[c] / den) / lam
                    sr[pp + r * N + c] = v
                    sr[pp + c * N + r] = v
            uk = 0.0
            g = 0.0
            for r in range(N):
                uk += head[th + r] * sr[pt + r]
                g += head[th + r]
            _lfilter_row(pr, bo, ao, order, sr, zi_u, uk)
            u[row] = uk / scale
            if not (glo <= g <= ghi):
                sr[H + _TIMER] += dt
                if sr[H + _TIMER] > bound_time and sr[H + _S_CODE] == 0.0:
                    sr[H + _S_CODE] = 1.0
                    sr[H + _S_VAL] = g
                    sr[H + _S_LIM] = glo if g < glo else ghi
                    event = True
            else:
                sr[H + _TIMER] = 0.0
            if not math.isfinite(uk) and sr[H + _S_CODE] == 0.0:
                sr[H + _S_CODE] = 2.0
                sr[H + _S_VAL] = uk
                sr[H + _S_LIM] = 0.0
                event = True
            osc, ru, lim = watch_row(pr, _P_WP, _P_HP, sr, H + _S_WATCH, u[row], z[row])
            if osc and sr[H + _S_CODE] == 0.0:
                sr[H + _S_CODE] = 3.0
                sr[H + _S_VAL] = ru
                sr[H + _S_LIM] = lim
                event = True
        for j in range(n):
            if s[h0 + j, H + _S_CODE] != 0.0:
                head[n * N] = 1.0
    return event


LABELS = ("inverse DC gain Σθ (channel {ch}) outside its bounds",
          "non-finite command (channel {ch})",
          "command oscillation (channel {ch}, high-pass RMS)")
UNITS = ("", "", "")


def butter_ba(order: int, cutoff: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """MATLAB ``butter(order, cutoff/(fs/2))``: (b, a); order 0 gives (1, 1)."""
    import scipy.signal

    if order <= 0:
        return np.array([1.0]), np.array([1.0])
    b, a = scipy.signal.butter(order, cutoff, fs=1.0 / dt)
    return np.ascontiguousarray(b, dtype=float), np.ascontiguousarray(a, dtype=float)


@register
class RoDeACCompensator(BaseCompensator):
    """RoDeAC (see module docstring). ``coefficients()``: ``theta0``…``theta{N−1}`` and
    ``gain`` = Σθ (-), (K, n)."""

    name = "rodeac"
    rank = 65
    adaptive = True
    event_labels = LABELS
    event_units = UNITS
    Config = RoDeACConfig

    def __init__(self, config: RoDeACConfig, K: int, n: int, dt: float):
        super().__init__(config, K, n, dt)
        c = config
        check("rodeac.filter_hz", c.filter_hz, c.filter_order == 0 or c.filter_hz < 0.5 / dt,
              f"must be below the Nyquist frequency {0.5 / dt:g} Hz")
        c.check_watch("rodeac", dt)
        N = c.taps
        if c.theta0:
            self.theta_init = channel_blocks("rodeac.theta0", c.theta0, N, K, n, (N,))
        else:
            self.theta_init = np.zeros((K, n, N))
            self.theta_init[:, :, 0] = 1.0
        if len(c.p0) == 1:
            self.p_init = np.broadcast_to(np.eye(N) * c.p0[0], (K, n, N, N)).copy()
        else:
            self.p_init = channel_blocks("rodeac.p0", c.p0, N * N, K, n, (N, N))
        self.b, self.a = butter_ba(c.filter_order, c.filter_hz, dt)
        order = self.a.size - 1
        self.hp = butter_sos(2, c.osc_corner, dt, "highpass")
        self.wp = c.watch_params(dt)
        R = K * n
        # the kernel's arrays (rows test-major, row = k·n + j): its parameters ...
        p = np.zeros((R, _P_B + 2 * (order + 1)))
        p[:, :_P_WP] = [n, N, order, c.signal_scale, c.forgetting,
                        1.0 if c.algebraic_loop else 0.0, c.gain_bounds[0], c.gain_bounds[1],
                        c.bound_time, dt]
        p[:, _P_WP:_P_HP] = self.wp
        p[:, _P_HP:_P_B] = self.hp[0]
        p[:, _P_B:_P_B + order + 1] = self.b
        p[:, _P_B + order + 1:] = self.a
        self.params = p
        # ... and its state; the Python object reads views of them
        H = n * N + 1
        pp = H + _S_P
        self.state = s = np.zeros((R, pp + N * N + 2 * N + 2 * order))
        self.theta = s.reshape(K, n * s.shape[1])[:, :n * N].reshape(K, n, N)
        """θ (K, n, N) (a view of the kernel's state)."""
        self.P = s[:, pp:pp + N * N].reshape(K, n, N, N)
        self.code = s[:, H + _S_CODE].reshape(K, n)
        self.ev_val = s[:, H + _S_VAL].reshape(K, n)
        self.ev_lim = s[:, H + _S_LIM].reshape(K, n)
        self._gain = np.zeros((K, n))
        self.reset()

    def reset(self) -> None:
        super().reset()
        self.state[:] = 0.0
        self.theta[:] = self.theta_init
        self.P[:] = self.p_init

    def command(self, z: np.ndarray, zdot: np.ndarray, z_meas: np.ndarray) -> np.ndarray:
        if rodeac_kernel(self.params, self.state, np.ascontiguousarray(z).reshape(-1),
                         np.ascontiguousarray(zdot).reshape(-1),
                         np.ascontiguousarray(z_meas).reshape(-1), self.u.reshape(-1)):
            self.events()
        self.calls += 1
        return self.u


    def compiled(self):
        return (comp_ready(rodeac_kernel),), self.params, self.state

    def history(self) -> np.ndarray:
        return self.theta

    def history_coefficients(self, states: np.ndarray) -> dict[str, np.ndarray]:
        out = {f"theta{i}": states[..., i] for i in range(states.shape[-1])}
        out["gain"] = states.sum(axis=-1)
        return out

    def coefficients(self) -> dict[str, np.ndarray]:
        th = self.theta
        out = {f"theta{i}": th[:, :, i] for i in range(th.shape[2])}
        np.sum(th, axis=2, out=self._gain)
        out["gain"] = self._gain
        return out


def fit_inverse(target: np.ndarray, measured: np.ndarray, taps: int = 4
                ) -> tuple[np.ndarray, np.ndarray]:
    """RoDeAC's batch least squares for one channel: Γ rows [x_m,k, …, x_m,k−N+1] (raw
    measurement, k from the N-th sample), θ = (ΓᵀΓ)⁻¹Γᵀ z_k and P = (ΓᵀΓ)⁻¹, in the units
    of the data. Returns (θ (N,), P (N, N))."""
    z = np.asarray(target, dtype=float).ravel()
    x = np.asarray(measured, dtype=float).ravel()
    if z.shape != x.shape or z.size < 10 * taps:
        raise ValueError(f"target {z.shape} and measured {x.shape}: need equal shapes and "
                         "enough samples")
    n = z.size
    G = np.stack([x[taps - 1 - i: n - i] for i in range(taps)], axis=1)
    GtG = G.T @ G
    P = np.linalg.inv(GtG)
    return P @ (G.T @ z[taps - 1:]), 0.5 * (P + P.T)


def calibrate(u: np.ndarray, z_meas: np.ndarray, dt: float,
              config: RoDeACConfig | None = None) -> RoDeACConfig:
    """RoDeAC's offline calibration on one recorded test: ``u`` (N,) or (N, n) the commands
    (targets) sent at each call, ``z_meas`` the measurements passed at the same calls (the
    answer to the previous call's command), in channel units. Sets θ₀ and P₀ per channel
    (:func:`fit_inverse`)."""
    config = config or RoDeACConfig()
    U = np.asarray(u, dtype=float)
    X = np.asarray(z_meas, dtype=float)
    if U.ndim == 1:
        U, X = U[:, None], X[:, None]
    th, ps = [], []
    for j in range(U.shape[1]):
        t, p = fit_inverse(U[:, j], X[:, j], config.taps)
        th.append(t)
        ps.append(p.ravel())
    return replace(config, theta0=tuple(float(v) for v in np.concatenate(th)),
                   p0=tuple(float(v) for v in np.concatenate(ps)))
