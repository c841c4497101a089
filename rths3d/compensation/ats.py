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
    register,
    sos_step,
    watch_step,
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


@njit(cache=True, nogil=True)
def _ats_step(z, zd, zm, u, a, est, st, blocks, zi_u, zi_x, sos, watch, hp, wp, stopped,
              code, ev_val, ev_lim, prm, lo, hi, step_max, prior):
    """One call for all (K, n) channels. ``prm`` = [dt, M (samples per block), B (blocks),
    threshold, ridge, bound_time, interval (s)]; ``wp``: the watch's parameters; ``prior``
    (K, n, 3): the initial coefficients the ridge pulls toward. Returns
    True when a new safety event was raised."""
    dt = prm[0]
    M = int(prm[1])
    B = int(prm[2])
    thr, ridge, bound_time, interval = prm[3], prm[4], prm[5], prm[6]
    K, n = z.shape
    inv2 = 0.5 / dt
    inv_sq = 1.0 / (dt * dt)
    event = False
    A = np.empty((3, 3))
    r = np.empty(3)
    S = np.empty(NSUM)
    for k in range(K):
        if stopped[k]:
            continue
        for j in range(n):
            s = st[k, j]
            # -- identification: the previous command against this measurement ------------
            uf = sos_step(sos, zi_u[k, j], s[_U_PREV])
            xf = sos_step(sos, zi_x[k, j], zm[k, j])
            if s[_NPAIR] >= 2.0:
                b = int(s[_BLOCK])
                blk = blocks[k, j, b]
                x0 = s[_XF1]
                v0 = (xf - s[_XF2]) * inv2
                a0 = (xf - 2.0 * s[_XF1] + s[_XF2]) * inv_sq
                y = s[_UF1]
                blk[0] += x0 * x0
                blk[1] += x0 * v0
                blk[2] += x0 * a0
                blk[3] += v0 * v0
                blk[4] += v0 * a0
                blk[5] += a0 * a0
                blk[6] += x0 * y
                blk[7] += v0 * y
                blk[8] += a0 * y
                am = abs(zm[k, j])
                if am > blk[9]:
                    blk[9] = am
                s[_COUNT] += 1.0
                if s[_COUNT] >= M:
                    if s[_FILLED] < B:
                        s[_FILLED] += 1.0
                    if s[_FILLED] >= B:
                        for q in range(NSUM):
                            S[q] = 0.0
                        for bb in range(B):
                            for q in range(9):
                                S[q] += blocks[k, j, bb, q]
                            if blocks[k, j, bb, 9] > S[9]:
                                S[9] = blocks[k, j, bb, 9]
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
                            r[0] = S[6] / d0 + ridge * d0 * prior[k, j, 0]
                            r[1] = S[7] / d1 + ridge * d1 * prior[k, j, 1]
                            r[2] = S[8] / d2 + ridge * d2 * prior[k, j, 2]
                            if _solve3(A, r):
                                est[k, j, 0] = r[0] / d0
                                est[k, j, 1] = r[1] / d1
                                est[k, j, 2] = r[2] / d2
                                for i in range(3):
                                    e = est[k, j, i]
                                    target = e
                                    if e < lo[i] or e > hi[i]:
                                        target = lo[i] if e < lo[i] else hi[i]
                                        s[_T0 + i] += interval
                                        if s[_T0 + i] > bound_time and code[k, j] == 0:
                                            code[k, j] = 1 + i
                                            ev_val[k, j] = e
                                            ev_lim[k, j] = target
                                            event = True
                                    else:
                                        s[_T0 + i] = 0.0
                                    dlt = target - a[k, j, i]
                                    if dlt > step_max[i]:
                                        dlt = step_max[i]
                                    elif dlt < -step_max[i]:
                                        dlt = -step_max[i]
                                    a[k, j, i] += dlt
                    b = (b + 1) % B
                    for q in range(NSUM):
                        blocks[k, j, b, q] = 0.0
                    s[_BLOCK] = b
                    s[_COUNT] = 0.0
            s[_XF2] = s[_XF1]
            s[_XF1] = xf
            s[_UF1] = uf
            s[_NPAIR] += 1.0
            # -- command -------------------------------------------------------------------
            zdd = (zd[k, j] - s[_ZD_PREV]) / dt if s[_NPAIR] > 1.0 else 0.0
            uk = a[k, j, 0] * z[k, j] + a[k, j, 1] * zd[k, j] + a[k, j, 2] * zdd
            s[_ZD_PREV] = zd[k, j]
            s[_U_PREV] = uk
            u[k, j] = uk
            osc, ru, lim = watch_step(hp, watch[k, j], uk, z[k, j], wp)
            if osc and code[k, j] == 0:
                code[k, j] = 4
                ev_val[k, j] = ru
                ev_lim[k, j] = lim
                event = True
        if code[k].any():
            stopped[k] = True
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
    Config = ATSConfig

    def __init__(self, config: ATSConfig, K: int, n: int, dt: float):
        super().__init__(config, K, n, dt)
        c = config
        check("ats.filter_hz", c.filter_hz, c.filter_order == 0 or c.filter_hz < 0.5 / dt,
              f"must be below the Nyquist frequency {0.5 / dt:g} Hz")
        c.check_watch("ats", dt)
        self.a_init = np.stack([channel_values(f"ats.{k}", getattr(c, k), K, n)
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
        self.prm = np.array([dt, self.M, self.B, c.threshold, c.ridge, c.bound_time, interval])
        S = self.sos.shape[0]
        self.a = np.zeros((K, n, 3))
        self.est = np.zeros((K, n, 3))
        self.st = np.zeros((K, n, NSTATE))
        self.blocks = np.zeros((K, n, self.B, NSUM))
        self.zi_u = np.zeros((K, n, S, 2))
        self.zi_x = np.zeros((K, n, S, 2))
        self.watch = np.zeros((K, n, WATCH_STATES))
        self.code = np.zeros((K, n), dtype=np.int64)
        self.ev_val = np.zeros((K, n))
        self.ev_lim = np.zeros((K, n))
        self.reset()

    @property
    def window_s(self) -> float:
        """The window actually used (s): whole re-estimation intervals."""
        return self.M * self.B * self.dt

    def reset(self) -> None:
        super().reset()
        self.a[:] = self.a_init
        self.est[:] = self.a_init
        for arr in (self.st, self.blocks, self.zi_u, self.zi_x, self.watch, self.ev_val,
                    self.ev_lim):
            arr[:] = 0.0
        self.code[:] = 0

    def command(self, z: np.ndarray, zdot: np.ndarray, z_meas: np.ndarray) -> np.ndarray:
        if _ats_step(z, zdot, z_meas, self.u, self.a, self.est, self.st, self.blocks,
                     self.zi_u, self.zi_x, self.sos, self.watch, self.hp, self.wp, self.stopped,
                     self.code, self.ev_val, self.ev_lim, self.prm, self.lo, self.hi,
                     self.step_max, self.a_init):
            self._events(self.code, self.ev_val, self.ev_lim, LABELS, UNITS)
        self.calls += 1
        return self.u

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
