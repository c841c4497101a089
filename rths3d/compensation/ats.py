"""``ats``: the adaptive time-series compensator (Chae, Kazemibidokhti & Ricles, EESD 42(11),
2013), as OpenFresco sets it up (``EXAMPLES/OneBayFrame/ControlSystem/ATS_setup.m``).

The command is a time series of the desired displacement and its derivatives,

    u = a0 z + a1 ż + a2 z̈,

where a0 corrects the amplitude, a1 ≈ the delay (s) when a0 ≈ 1 and a2 ≈ a1²/2. The
coefficients are those of the *inverse* of the transfer system: the least-squares fit of the
commands that were sent, u, to the measured displacement x_m and its derivatives,

    u(t) ≈ a0 x_m(t) + a1 ẋ_m(t) + a2 ẍ_m(t),

over a moving window, re-estimated every few samples, each coefficient then bounded and
rate-limited. Both u and x_m pass the same low-pass filter before x_m is differentiated
(the filter then cancels from the fit, as both sides go through it), and the fit is done only
while the window's measured motion exceeds a trigger threshold.

Implementation: the window is a ring of blocks of one re-estimation interval each; per sample
the 3×3 normal equations of the newest block are accumulated (no subtraction, no drift), so a
step costs O(1) and a re-estimation sums the blocks. Derivatives are central differences, so
they carry no lag. A small ridge term pulls the solution toward the initial coefficients
along directions the data do not determine (with a single sine, x and ẍ are collinear and
only a0 − ω²a2 is identifiable): there the estimate stays at its start instead of wandering
off, e.g. a2 across its bound 0 on a sine test.

Drift safety: an estimate outside its bounds for longer than ``bound_time`` (the coefficients
meanwhile stay at the bound), or an oscillating command (:class:`~.base.WatchConfig`), stops
the test with the reason.
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
    channel_values,
    check,
    check_bounds,
    comp_kernel,
    comp_ready,
    register,
    sos_row,
    watch_row,
)

INCH = 0.0254


@dataclass(frozen=True)
class ATSConfig(WatchConfig):
    """Parameters (SI). Defaults: OpenFresco's ATS_setup.m (1024 Hz), in seconds so that they
    hold at any step dt (sample counts = round(time / dt)).

    Attributes
    ----------
    a0, a1, a2: initial coefficients (-, s, s²): (1, 0.020, 0.5·0.020²); one value, or one
      per channel.
    a0_bounds, a1_bounds, a2_bounds: allowed ranges, [0.7, 1.3], [0, 0.08] s, [0, 0.0032] s².
    rates: maximum rates of change of (a0, a1, a2) per second: (2, 0.05, 0.001).
    window: length of the moving least-squares window, 1.0 s (rounded to whole intervals).
    interval: re-estimation interval, 16/1024 s (OpenFresco's "skipping number" 16 at
      1024 Hz).
    threshold: adapt only while the peak |x_m| over the window reaches this, 0.01 in =
      0.254 mm (channel units).
    filter_order, filter_hz: Butterworth low-pass on u and x_m before differentiation, 6th
      order at 20 Hz (0: no filter).
    ridge: relative weight pulling the fit toward the initial coefficients (-), 1e-4.
    bound_time: time (s) an estimate may stay outside its bounds before the test stops,
      0.25 s (the plant has left what the compensator can represent, or it drifts).
    osc_*: the command-oscillation watch (:class:`~.base.WatchConfig`).
    """

    a0: float | tuple[float, ...] = 1.0
    a1: float | tuple[float, ...] = 0.020
    a2: float | tuple[float, ...] = 0.5 * 0.020**2
    a0_bounds: tuple[float, float] = (0.7, 1.3)
    a1_bounds: tuple[float, float] = (0.0, 0.08)
    a2_bounds: tuple[float, float] = (0.0, 0.0032)
    rates: tuple[float, float, float] = (2.0, 0.05, 0.001)
    window: float = 1.0
    interval: float = 16.0 / 1024.0
    threshold: float = 0.01 * INCH
    filter_order: int = 6
    filter_hz: float = 20.0
    ridge: float = 1e-4
    bound_time: float = 0.25

    def __post_init__(self) -> None:
        check("ats.bound_time", self.bound_time, self.bound_time >= 0.0, "must be ≥ 0 s")
        for key in ("a0_bounds", "a1_bounds", "a2_bounds"):
            check_bounds(f"ats.{key}", getattr(self, key))
        check("ats.rates", list(self.rates), all(r > 0 for r in self.rates),
              "must be three rates > 0 (per s)")
        check("ats.window", self.window, self.window > 0 and math.isfinite(self.window),
              "must be > 0 s")
        check("ats.interval", self.interval, 0 < self.interval <= self.window,
              "must be in (0, window] s")
        check("ats.threshold", self.threshold, self.threshold >= 0, "must be ≥ 0")
        check("ats.filter_order", self.filter_order, 0 <= self.filter_order <= 10,
              "must be in 0…10")
        check("ats.filter_hz", self.filter_hz, self.filter_hz > 0, "must be > 0 Hz")
        check("ats.ridge", self.ridge, 0 <= self.ridge < 1, "must be in [0, 1)")


# per-channel scalar state
_U_PREV, _ZD_PREV, _XF1, _XF2, _UF1, _NPAIR, _COUNT, _BLOCK, _FILLED = range(9)
_T0 = 9  # three out-of-bound timers
NSTATE = 12
NSUM = 10  # xx xv xa vv va aa xu vu au, peak |x_m|


@njit(cache=True, nogil=True)
def _solve3(M, r):
    """Solve the 3×3 system M s = r by Gaussian elimination with partial pivoting (in
    place); False if singular."""
    for c in range(3):
        p = c
        for i in range(c + 1, 3):
            if abs(M[i, c]) > abs(M[p, c]):
                p = i
        if M[p, c] == 0.0:
            return False
        if p != c:
            for j in range(3):
                M[c, j], M[p, j] = M[p, j], M[c, j]
            r[c], r[p] = r[p], r[c]
        for i in range(c + 1, 3):
            f = M[i, c] / M[c, c]
            for j in range(c, 3):
                M[i, j] -= f * M[c, j]
            r[i] -= f * r[c]
    for c in range(2, -1, -1):
        s = r[c]
        for j in range(c + 1, 3):
            s -= M[c, j] * r[j]
        r[c] = s / M[c, c]
    return True


# the per-row parameters (``p`` of the kernel, (R, P)): scalars, then the bounds, the
# rate limits, the prior, the watch's parameters, its high-pass section, the low-pass sections
_P_N, _P_DT, _P_M, _P_B, _P_THR, _P_RIDGE, _P_BT, _P_INT, _P_NSEC = range(9)
_P_LO, _P_HI, _P_STEP, _P_PRIOR, _P_WP, _P_HP, _P_SOS = 9, 12, 15, 18, 21, 26, 32
# the per-row state (``s`` of the kernel, (R, S)) after the head (3n + 1 columns, used in
# the first row of each test: its coefficients (a0, a1, a2) per channel, then its stop flag,
# so that the coefficients of a test are contiguous and the history a view): the scalars
# (NSTATE), the estimates (3), the event (code, value, limit), the watch, the filter states,
# the window's blocks
_S_EST, _S_CODE, _S_VAL, _S_LIM, _S_WATCH = NSTATE, NSTATE + 3, NSTATE + 4, NSTATE + 5, \
    NSTATE + 6
_S_ZI = _S_WATCH + WATCH_STATES


@comp_kernel
def ats_kernel(p, s, z, zd, zm, u):
    """One call of the ATS compensator for R = K·n rows (test-major): ``p`` (R, P) the
    parameters, ``s`` (R, S) the state (layout: the ``_P_*``, ``_S_*`` offsets; the head of
    each test's first row holds its coefficients and stop flag). The whole compensator —
    the identification, the bounded and rate-limited update, the drift and oscillation
    watch, the command — for the Python object's :meth:`ATSCompensator.command` and the
    compiled loops alike. Returns True when a new safety event was raised (its code, value
    and limit in the channel's state)."""
    n = int(p[0, _P_N])
    H = 3 * n + 1
    K = z.shape[0] // n
    event = False
    A = np.empty((3, 3))
    r = np.empty(3)
    S = np.empty(NSUM)
    for k in range(K):
        h0 = k * n
        head = s[h0]
        if head[3 * n] != 0.0:
            continue
        for j in range(n):
            row = h0 + j
            pr = p[row]
            sr = s[row]
            dt = pr[_P_DT]
            M = int(pr[_P_M])
            B = int(pr[_P_B])
            thr, ridge, bound_time, interval = pr[_P_THR], pr[_P_RIDGE], pr[_P_BT], pr[_P_INT]
            nsec = int(pr[_P_NSEC])
            inv2 = 0.5 / dt
            inv_sq = 1.0 / (dt * dt)
            zi_u = H + _S_ZI
            zi_x = zi_u + 2 * nsec
            blk0 = zi_x + 2 * nsec
            st = H  # the scalars
            ca = 3 * j  # this channel's coefficients in the head
            # -- identification: the previous command against this measurement ------------
            uf = sos_row(pr, _P_SOS, nsec, sr, zi_u, sr[st + _U_PREV])
            xf = sos_row(pr, _P_SOS, nsec, sr, zi_x, zm[row])
            if sr[st + _NPAIR] >= 2.0:
                b = int(sr[st + _BLOCK])
                q0 = blk0 + b * NSUM
                x0 = sr[st + _XF1]
                v0 = (xf - sr[st + _XF2]) * inv2
                a0 = (xf - 2.0 * sr[st + _XF1] + sr[st + _XF2]) * inv_sq
                y = sr[st + _UF1]
                sr[q0] += x0 * x0
                sr[q0 + 1] += x0 * v0
                sr[q0 + 2] += x0 * a0
                sr[q0 + 3] += v0 * v0
                sr[q0 + 4] += v0 * a0
                sr[q0 + 5] += a0 * a0
                sr[q0 + 6] += x0 * y
                sr[q0 + 7] += v0 * y
                sr[q0 + 8] += a0 * y
                am = abs(zm[row])
                if am > sr[q0 + 9]:
                    sr[q0 + 9] = am
                sr[st + _COUNT] += 1.0
                if sr[st + _COUNT] >= M:
                    if sr[st + _FILLED] < B:
                        sr[st + _FILLED] += 1.0
                    if sr[st + _FILLED] >= B:
                        for q in range(NSUM):
                            S[q] = 0.0
                        for bb in range(B):
                            qb = blk0 + bb * NSUM
                            for q in range(9):
                                S[q] += sr[qb + q]
                            if sr[qb + 9] > S[9]:
                                S[9] = sr[qb + 9]
                        if S[9] >= thr and S[0] > 0.0 and S[3] > 0.0 and S[5] > 0.0:
                            d0 = math.sqrt(S[0])
                            d1 = math.sqrt(S[3])
                            d2 = math.sqrt(S[5])
                            A[0, 0] = 1.0 + ridge
                            A[1, 1] = 1.0 + ridge
                            A[2, 2] = 1.0 + ridge
                            A[0, 1] = A[1, 0] = S[1] / (d0 * d1)
                            A[0, 2] = A[2, 0] = S[2] / (d0 * d2)
                            A[1, 2] = A[2, 1] = S[4] / (d1 * d2)
                            r[0] = S[6] / d0 + ridge * d0 * pr[_P_PRIOR]
                            r[1] = S[7] / d1 + ridge * d1 * pr[_P_PRIOR + 1]
                            r[2] = S[8] / d2 + ridge * d2 * pr[_P_PRIOR + 2]
                            if _solve3(A, r):
                                sr[H + _S_EST] = r[0] / d0
                                sr[H + _S_EST + 1] = r[1] / d1
                                sr[H + _S_EST + 2] = r[2] / d2
                                for i in range(3):
                                    e = sr[H + _S_EST + i]
                                    lo, hi = pr[_P_LO + i], pr[_P_HI + i]
                                    target = e
                                    if e < lo or e > hi:
                                        target = lo if e < lo else hi
                                        sr[st + _T0 + i] += interval
                                        if sr[st + _T0 + i] > bound_time and \
                                                sr[H + _S_CODE] == 0.0:
                                            sr[H + _S_CODE] = 1.0 + i
                                            sr[H + _S_VAL] = e
                                            sr[H + _S_LIM] = target
                                            event = True
                                    else:
                                        sr[st + _T0 + i] = 0.0
                                    dlt = target - head[ca + i]
                                    smax = pr[_P_STEP + i]
                                    if dlt > smax:
                                        dlt = smax
                                    elif dlt < -smax:
                                        dlt = -smax
                                    head[ca + i] += dlt
                    b = (b + 1) % B
                    q0 = blk0 + b * NSUM
                    for q in range(NSUM):
                        sr[q0 + q] = 0.0
                    sr[st + _BLOCK] = b
                    sr[st + _COUNT] = 0.0
            sr[st + _XF2] = sr[st + _XF1]
            sr[st + _XF1] = xf
            sr[st + _UF1] = uf
            sr[st + _NPAIR] += 1.0
            # -- command -------------------------------------------------------------------
            zdd = (zd[row] - sr[st + _ZD_PREV]) / dt if sr[st + _NPAIR] > 1.0 else 0.0
            uk = head[ca] * z[row] + head[ca + 1] * zd[row] + head[ca + 2] * zdd
            sr[st + _ZD_PREV] = zd[row]
            sr[st + _U_PREV] = uk
            u[row] = uk
            osc, ru, lim = watch_row(pr, _P_WP, _P_HP, sr, H + _S_WATCH, uk, z[row])
            if osc and sr[H + _S_CODE] == 0.0:
                sr[H + _S_CODE] = 4.0
                sr[H + _S_VAL] = ru
                sr[H + _S_LIM] = lim
                event = True
        for j in range(n):
            if s[h0 + j, H + _S_CODE] != 0.0:
                head[3 * n] = 1.0
    return event


LABELS = ("a0 estimate (channel {ch}) outside its bounds", "a1 estimate (channel {ch}) "
          "outside its bounds", "a2 estimate (channel {ch}) outside its bounds",
          "command oscillation (channel {ch}, high-pass RMS)")
UNITS = ("", "s", "s^2", "")


@register
class ATSCompensator(BaseCompensator):
    """Adaptive time-series compensator (see module docstring). ``coefficients()``:
    ``a0`` (-), ``a1`` (s), ``a2`` (s²), each (K, n)."""

    name = "ats"
    rank = 40
    adaptive = True
    event_labels = LABELS
    event_units = UNITS
    Config = ATSConfig

    def __init__(self, config: ATSConfig, K: int, n: int, dt: float):
        super().__init__(config, K, n, dt)
        c = config
        check("ats.filter_hz", c.filter_hz, c.filter_order == 0 or c.filter_hz < 0.5 / dt,
              f"must be below the Nyquist frequency {0.5 / dt:g} Hz")
        c.check_watch("ats", dt)
        a_init = np.stack([channel_values(f"ats.{k}", getattr(c, k), K, n)
                           for k in ("a0", "a1", "a2")], axis=-1)
        self.M = max(1, int(round(c.interval / dt)))
        self.B = max(1, int(round(c.window / (self.M * dt))))
        self.lo = np.array([c.a0_bounds[0], c.a1_bounds[0], c.a2_bounds[0]])
        self.hi = np.array([c.a0_bounds[1], c.a1_bounds[1], c.a2_bounds[1]])
        interval = self.M * dt
        self.step_max = np.asarray(c.rates, dtype=float) * interval
        self.sos = butter_sos(c.filter_order, c.filter_hz, dt)
        self.hp = butter_sos(2, c.osc_corner, dt, "highpass")
        self.wp = c.watch_params(dt)
        nsec = self.sos.shape[0]
        R = K * n
        # the kernel's arrays (rows test-major, row = k·n + j): its parameters ...
        p = np.zeros((R, _P_SOS + 6 * nsec))
        p[:, :_P_LO] = [n, dt, self.M, self.B, c.threshold, c.ridge, c.bound_time, interval,
                        nsec]
        p[:, _P_LO:_P_HI] = self.lo
        p[:, _P_HI:_P_STEP] = self.hi
        p[:, _P_STEP:_P_PRIOR] = self.step_max
        p[:, _P_PRIOR:_P_WP] = a_init.reshape(R, 3)
        p[:, _P_WP:_P_HP] = self.wp
        p[:, _P_HP:_P_SOS] = self.hp[0]
        p[:, _P_SOS:] = self.sos.reshape(-1)
        self.params = p
        # ... and its state; the Python object reads views of them
        H = 3 * n + 1
        self.state = s = np.zeros((R, H + _S_ZI + 4 * nsec + self.B * NSUM))
        self.a_init = p[:, _P_PRIOR:_P_WP].reshape(K, n, 3)
        """The initial coefficients (K, n, 3), which the ridge pulls toward (a view)."""
        self.a = s.reshape(K, n * s.shape[1])[:, :3 * n].reshape(K, n, 3)
        """The coefficients (K, n, 3) in use (a view of the kernel's state)."""
        self.est = s[:, H + _S_EST:H + _S_EST + 3].reshape(K, n, 3)
        self.code = s[:, H + _S_CODE].reshape(K, n)
        self.ev_val = s[:, H + _S_VAL].reshape(K, n)
        self.ev_lim = s[:, H + _S_LIM].reshape(K, n)
        self.reset()

    @property
    def window_s(self) -> float:
        """The window actually used (s): whole re-estimation intervals."""
        return self.M * self.B * self.dt

    def reset(self) -> None:
        super().reset()
        self.state[:] = 0.0
        self.a[:] = self.a_init
        self.est[:] = self.a_init

    def command(self, z: np.ndarray, zdot: np.ndarray, z_meas: np.ndarray) -> np.ndarray:
        if ats_kernel(self.params, self.state, np.ascontiguousarray(z).reshape(-1),
                      np.ascontiguousarray(zdot).reshape(-1),
                      np.ascontiguousarray(z_meas).reshape(-1), self.u.reshape(-1)):
            self.events()
        self.calls += 1
        return self.u


    def compiled(self):
        return (comp_ready(ats_kernel),), self.params, self.state

    def coefficients(self) -> dict[str, np.ndarray]:
        return {"a0": self.a[:, :, 0], "a1": self.a[:, :, 1], "a2": self.a[:, :, 2]}

    prior_keys = ("a0", "a1", "a2")

    def start_from_delay(self, delay: np.ndarray) -> bool:
        """(a0, a1, a2) = (1, d, d²/2) per test, the inverse of a pure delay d (s) to
        second order (ATS_setup.m's "a1 ≈ expected delay, a2 = a1²/2"), within the bounds."""
        d = np.broadcast_to(np.asarray(delay, dtype=float).reshape(-1, 1), (self.K, self.n))
        a = np.stack([np.ones_like(d), d, 0.5 * d * d], axis=-1)
        self.a_init[:] = np.clip(a, self.lo, self.hi)
        self.reset()
        return True

    def history(self) -> np.ndarray:
        return self.a

    def estimates(self) -> dict[str, np.ndarray]:
        """The latest unbounded least-squares estimates (K, n)."""
        return {"a0": self.est[:, :, 0], "a1": self.est[:, :, 1], "a2": self.est[:, :, 2]}


def calibrate(u: np.ndarray, z_meas: np.ndarray, dt: float,
              config: ATSConfig | None = None) -> ATSConfig:
    """Initial (a0, a1, a2) from a predefined displacement test, by the same least squares
    as the online fit (same pairing, filter and central differences) over the whole record.

    ``u`` (N,) or (N, n): the commands sent at each call; ``z_meas``: the measurements passed
    at the same calls. OpenFresco's ATS_setup.m: "Par values can be obtained from predefined
    displacement tests". Returns ``config`` with ``a0``, ``a1``, ``a2`` set (per channel for
    2-D input), clipped to the bounds.
    """
    import scipy.signal

    config = config or ATSConfig()
    U = np.asarray(u, dtype=float)
    X = np.asarray(z_meas, dtype=float)
    if U.ndim == 1:
        U, X = U[:, None], X[:, None]
    if U.shape != X.shape or U.shape[0] < 16:
        raise ValueError(f"u {U.shape} and z_meas {X.shape}: need equal shapes and ≥ 16 "
                         "samples")
    sos = butter_sos(config.filter_order, config.filter_hz, dt)
    lo = (config.a0_bounds[0], config.a1_bounds[0], config.a2_bounds[0])
    hi = (config.a0_bounds[1], config.a1_bounds[1], config.a2_bounds[1])
    coefs = []
    for j in range(U.shape[1]):
        uf = scipy.signal.sosfilt(sos, np.concatenate([[0.0], U[:-1, j]]))
        xf = scipy.signal.sosfilt(sos, X[:, j])
        A = np.stack([xf[1:-1], (xf[2:] - xf[:-2]) / (2 * dt),
                      (xf[2:] - 2 * xf[1:-1] + xf[:-2]) / dt**2], axis=1)
        a, *_ = np.linalg.lstsq(A, uf[1:-1], rcond=None)
        coefs.append(np.clip(a, lo, hi))
    c = np.array(coefs)
    vals = [float(v[0]) if v.size == 1 else tuple(float(x) for x in v) for v in c.T]
    return replace(config, a0=vals[0], a1=vals[1], a2=vals[2])
