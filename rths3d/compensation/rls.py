"""``rls``: adaptive model-based compensation by recursive least squares, decentralised — one
independent compensator per channel (per actuator, per Stewart leg), after RoDeAC (Quiroz,
Gálmez & Fermandois, robust decentralised adaptive compensation for the multi-axial RTHS
benchmark; FermandoisLab/maRTHS-bmk-RoDeAC, ``Offline_calibration.m``, ``S3_Controller.m``).

Each channel's compensator is an FIR inverse model of its actuator: the command that produced
the measured displacement is regressed on the current and past measurements,

    u_{k−1} ≈ θᵀ φ_k,   φ_k = [x_m,k, x_m,k−s, …, x_m,k−(N−1)s]   (N taps, s samples apart)

(RoDeAC: 4 taps at 1024 Hz), both signals through the same low-pass filter (RoDeAC: 4th-order
Butterworth at 20 Hz), and the same FIR applied to the desired displacement gives the
command, u_k = θᵀ [z_k, z_{k−s}, …]. θ starts from an offline calibration (:func:`calibrate`,
a batch least-squares fit on a recorded test, as RoDeAC's) and is updated every sample by
RLS with forgetting factor λ = exp(−dt/``memory``) (λ = 1 for ``memory = inf``, RoDeAC's
choice). Updates pause while the recent motion is below ``threshold`` and the covariance
trace is capped at its initial value (no wind-up in quiet periods).

Two readings of θ are bounded (the coefficients of :meth:`coefficients`): the inverse's DC
gain Σθ (≈ 1/actuator gain) and its lead time −Σ θ_i·i·s·dt / Σθ (≈ the actuator delay). An
estimate outside these bounds is not applied (the last in-bounds θ is); if it stays outside
for ``bound_time`` the test stops with the reason.
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
    register,
    sos_step,
    watch_step,
)

INCH = 0.0254


@dataclass(frozen=True)
class RLSConfig(WatchConfig):
    """Parameters (SI).

    Attributes
    ----------
    taps: FIR length N (RoDeAC: 4).
    spacing: time between taps (s), rounded to whole steps (RoDeAC: its sample period,
      1/1024 s).
    theta0: initial θ (N values, or N per channel flattened channel by channel); empty: no
      compensation to start (θ = [1, 0, …]). Use :func:`calibrate` for RoDeAC's offline
      calibration.
    p0: initial covariance P = p0·I (1/unit², e.g. m⁻²), 1e4; also the cap of trace(P)/N.
    memory: forgetting time (s): λ = exp(−dt/memory), 10 s; ``inf`` for λ = 1.
    threshold: update only while the measured |x_m| (peak decaying with 1 s) reaches this,
      0.01 in = 0.254 mm.
    filter_order, filter_hz: Butterworth low-pass on u and x_m (4th order, 20 Hz; 0: none).
    gain_bounds: allowed DC gain of the inverse Σθ (-), [0.7, 1.3].
    lead_bounds: allowed lead time −Σθ_i·i·s·dt/Σθ (s), [−0.005, 0.08] (ATS's a1 range,
      a little below 0 so that an estimate converging from the uncompensated start, lead 0,
      may pass through it).
    bound_time: time (s) an estimate may stay outside its bounds before the test stops,
      0.25 s (the plant has left what the compensator can represent, or it drifts).
    osc_*: the command-oscillation watch (:class:`~.base.WatchConfig`).
    """

    taps: int = 4
    spacing: float = 0.008
    theta0: tuple[float, ...] = ()
    p0: float = 1e4
    memory: float = 10.0
    threshold: float = 0.01 * INCH
    filter_order: int = 4
    filter_hz: float = 20.0
    gain_bounds: tuple[float, float] = (0.7, 1.3)
    lead_bounds: tuple[float, float] = (-0.005, 0.08)
    bound_time: float = 0.25

    def __post_init__(self) -> None:
        check("rls.bound_time", self.bound_time, self.bound_time >= 0.0, "must be ≥ 0 s")
        check("rls.taps", self.taps, 1 <= self.taps <= 32, "must be in 1…32")
        check("rls.spacing", self.spacing, self.spacing > 0 and math.isfinite(self.spacing),
              "must be > 0 s")
        check("rls.theta0", list(self.theta0),
              all(math.isfinite(v) for v in self.theta0)
              and (len(self.theta0) == 0 or len(self.theta0) % self.taps == 0),
              f"must be empty or {self.taps} values (taps) per channel")
        check("rls.p0", self.p0, self.p0 > 0 and math.isfinite(self.p0), "must be > 0")
        check("rls.memory", self.memory, self.memory > 0, "must be > 0 s (inf: no forgetting)")
        check("rls.threshold", self.threshold, self.threshold >= 0, "must be ≥ 0")
        check("rls.filter_order", self.filter_order, 0 <= self.filter_order <= 10,
              "must be in 0…10")
        check("rls.filter_hz", self.filter_hz, self.filter_hz > 0, "must be > 0 Hz")
        check_bounds("rls.gain_bounds", self.gain_bounds)
        check_bounds("rls.lead_bounds", self.lead_bounds)


# per-channel scalar state
_U_PREV, _PEAK, _FILLED, _TIMER, _IDX = range(5)
NSTATE = 5


@njit(cache=True, nogil=True)
def _rls_step(z, zm, u, theta, used, P, xr, zr, st, zi_u, zi_x, sos, watch, hp, wp, stopped,
              code, ev_val, ev_lim, prm):
    """One call for all (K, n) channels. ``prm`` = [dt, spacing (samples), λ, p_cap (trace),
    threshold, peak decay, gain lo, gain hi, lead lo, lead hi, bound_time]; ``wp``: the
    watch's parameters. Rings ``xr``/``zr`` (K, n, L) hold filtered x_m and z."""
    dt = prm[0]
    sp = int(prm[1])
    lam = prm[2]
    p_cap = prm[3]
    thr, decay = prm[4], prm[5]
    glo, ghi, llo, lhi, bound_time = prm[6], prm[7], prm[8], prm[9], prm[10]
    K, n = z.shape
    N = theta.shape[2]
    L = xr.shape[2]
    event = False
    phi = np.empty(N)
    Pphi = np.empty(N)
    for k in range(K):
        if stopped[k]:
            continue
        for j in range(n):
            s = st[k, j]
            uf = sos_step(sos, zi_u[k, j], s[_U_PREV])
            xf = sos_step(sos, zi_x[k, j], zm[k, j])
            idx = int(s[_IDX])
            xr[k, j, idx] = xf
            zr[k, j, idx] = z[k, j]
            am = abs(zm[k, j])
            s[_PEAK] = am if am > s[_PEAK] * decay else s[_PEAK] * decay
            if s[_FILLED] < L:
                s[_FILLED] += 1.0
            if s[_FILLED] >= L and s[_PEAK] >= thr:
                for i in range(N):
                    phi[i] = xr[k, j, (idx - i * sp) % L]
                den = lam
                err = uf
                for r in range(N):
                    acc = 0.0
                    for c in range(N):
                        acc += P[k, j, r, c] * phi[c]
                    Pphi[r] = acc
                    den += phi[r] * acc
                    err -= theta[k, j, r] * phi[r]
                tr = 0.0
                for r in range(N):
                    theta[k, j, r] += Pphi[r] / den * err
                for r in range(N):
                    for c in range(r, N):
                        v = (P[k, j, r, c] - Pphi[r] * Pphi[c] / den) / lam
                        P[k, j, r, c] = v
                        P[k, j, c, r] = v
                    tr += P[k, j, r, r]
                if tr > p_cap:
                    f = p_cap / tr
                    for r in range(N):
                        for c in range(N):
                            P[k, j, r, c] *= f
                # the bounded readings of θ: DC gain and lead time
                g = 0.0
                m1 = 0.0
                for i in range(N):
                    g += theta[k, j, i]
                    m1 += theta[k, j, i] * i
                lead = -m1 * sp * dt / g if g != 0.0 else math.inf
                inside = glo <= g <= ghi and llo <= lead <= lhi
                if inside:
                    s[_TIMER] = 0.0
                    for i in range(N):
                        used[k, j, i] = theta[k, j, i]
                else:
                    s[_TIMER] += dt
                    if s[_TIMER] > bound_time and code[k, j] == 0:
                        if not (glo <= g <= ghi):
                            code[k, j] = 1
                            ev_val[k, j] = g
                            ev_lim[k, j] = glo if g < glo else ghi
                        else:
                            code[k, j] = 2
                            ev_val[k, j] = lead
                            ev_lim[k, j] = llo if lead < llo else lhi
                        event = True
            # command: the FIR on the desired displacement
            uk = 0.0
            for i in range(N):
                uk += used[k, j, i] * zr[k, j, (idx - i * sp) % L]
            s[_IDX] = (idx + 1) % L
            s[_U_PREV] = uk
            u[k, j] = uk
            osc, ru, lim = watch_step(hp, watch[k, j], uk, z[k, j], wp)
            if osc and code[k, j] == 0:
                code[k, j] = 3
                ev_val[k, j] = ru
                ev_lim[k, j] = lim
                event = True
        if code[k].any():
            stopped[k] = True
    return event


LABELS = ("inverse DC gain (channel {ch}) outside its bounds",
          "lead time (channel {ch}) outside its bounds",
          "command oscillation (channel {ch}, high-pass RMS)")
UNITS = ("", "s", "")


def _theta0(config: RLSConfig, K: int, n: int) -> np.ndarray:
    N = config.taps
    if not config.theta0:
        th = np.zeros((K, n, N))
        th[:, :, 0] = 1.0
        return th
    return channel_blocks("rls.theta0", config.theta0, N, K, n, (N,))


def _spacing_steps(config: RLSConfig, dt: float) -> int:
    return max(1, int(round(config.spacing / dt)))


@register
class RLSCompensator(BaseCompensator):
    """Decentralised RLS adaptive FIR compensator (see module docstring).
    ``coefficients()``: ``theta0``…``theta{N−1}``, ``gain`` (-) and ``lead`` (s), (K, n)."""

    name = "rls"
    rank = 60
    Config = RLSConfig

    def __init__(self, config: RLSConfig, K: int, n: int, dt: float):
        super().__init__(config, K, n, dt)
        c = config
        check("rls.filter_hz", c.filter_hz, c.filter_order == 0 or c.filter_hz < 0.5 / dt,
              f"must be below the Nyquist frequency {0.5 / dt:g} Hz")
        c.check_watch("rls", dt)
        N = c.taps
        self.sp = _spacing_steps(c, dt)
        L = (N - 1) * self.sp + 1
        self.theta_init = _theta0(c, K, n)
        lam = math.exp(-dt / c.memory) if math.isfinite(c.memory) else 1.0
        self.sos = butter_sos(c.filter_order, c.filter_hz, dt)
        self.hp = butter_sos(2, c.osc_corner, dt, "highpass")
        self.prm = np.array([dt, self.sp, lam, c.p0 * N, c.threshold, math.exp(-dt / 1.0),
                             c.gain_bounds[0], c.gain_bounds[1], c.lead_bounds[0],
                             c.lead_bounds[1], c.bound_time])
        self.wp = c.watch_params(dt)
        S = self.sos.shape[0]
        self.theta = np.zeros((K, n, N))
        self.used = np.zeros((K, n, N))
        self.P = np.zeros((K, n, N, N))
        self.xr = np.zeros((K, n, L))
        self.zr = np.zeros((K, n, L))
        self.st = np.zeros((K, n, NSTATE))
        self.zi_u = np.zeros((K, n, S, 2))
        self.zi_x = np.zeros((K, n, S, 2))
        self.watch = np.zeros((K, n, WATCH_STATES))
        self.code = np.zeros((K, n), dtype=np.int64)
        self.ev_val = np.zeros((K, n))
        self.ev_lim = np.zeros((K, n))
        self._gain = np.zeros((K, n))
        self._lead = np.zeros((K, n))
        self.reset()

    def reset(self) -> None:
        super().reset()
        self.theta[:] = self.theta_init
        self.used[:] = self.theta_init
        self.P[:] = 0.0
        idx = np.arange(self.config.taps)
        self.P[:, :, idx, idx] = self.config.p0
        for arr in (self.xr, self.zr, self.st, self.zi_u, self.zi_x, self.watch, self.ev_val,
                    self.ev_lim):
            arr[:] = 0.0
        self.code[:] = 0

    def command(self, z: np.ndarray, zdot: np.ndarray, z_meas: np.ndarray) -> np.ndarray:
        if _rls_step(z, z_meas, self.u, self.theta, self.used, self.P, self.xr, self.zr,
                     self.st, self.zi_u, self.zi_x, self.sos, self.watch, self.hp, self.wp,
                     self.stopped, self.code, self.ev_val, self.ev_lim, self.prm):
            self._events(self.code, self.ev_val, self.ev_lim, LABELS, UNITS)
        self.calls += 1
        return self.u

    prior_keys = ("theta0",)

    def start_from_delay(self, delay: np.ndarray) -> bool:
        """θ = the Lagrange extrapolation of the target d ahead (s), per test, through the
        first three taps (second order, as ATS's a2 = a1²/2; two taps: first order, one
        tap: θ = [1]): DC gain 1 and lead d. The covariance stays p0·I, so RLS refines θ
        from there. On the platform a spacing of about half the delay keeps the
        extrapolation's gain near 1 up to the part's resonance (docs/compensation.md)."""
        from .polynomial import lagrange_weights

        d = np.asarray(delay, dtype=float).reshape(-1)
        N = self.config.taps
        order = min(N - 1, 2)
        th = np.zeros((self.K, self.n, N))
        for k in range(self.K):
            th[k, :, :order + 1] = lagrange_weights(float(d[k]), self.sp * self.dt, order)
        self.theta_init = th
        self.reset()
        return True

    def history(self) -> np.ndarray:
        return self.used

    def history_coefficients(self, states: np.ndarray) -> dict[str, np.ndarray]:
        N = states.shape[-1]
        out = {f"theta{i}": states[..., i] for i in range(N)}
        g = states.sum(axis=-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            out["gain"] = g
            out["lead"] = -(states @ np.arange(N, dtype=float)) * self.sp * self.dt / g
        return out

    def coefficients(self) -> dict[str, np.ndarray]:
        th = self.used
        out = {f"theta{i}": th[:, :, i] for i in range(th.shape[2])}
        np.sum(th, axis=2, out=self._gain)
        m1 = th @ np.arange(th.shape[2], dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            np.divide(-m1 * self.sp * self.dt, self._gain, out=self._lead)
        out["gain"] = self._gain
        out["lead"] = self._lead
        return out


def calibrate(u: np.ndarray, z_meas: np.ndarray, dt: float,
              config: RLSConfig | None = None) -> RLSConfig:
    """RoDeAC's offline calibration: θ0 by batch least squares on a recorded test.

    ``u`` (N,) or (N, n): the commands sent at each call; ``z_meas``: the measurements
    passed at the same calls (the answer to the previous call's command). Same pairing,
    filter and taps as the online update. Returns ``config`` with ``theta0`` set (one θ per
    channel for 2-D input).
    """
    import scipy.signal

    config = config or RLSConfig()
    U = np.asarray(u, dtype=float)
    X = np.asarray(z_meas, dtype=float)
    if U.ndim == 1:
        U, X = U[:, None], X[:, None]
    if U.shape != X.shape or U.shape[0] < 10 * config.taps:
        raise ValueError(f"u {U.shape} and z_meas {X.shape}: need equal shapes and enough "
                         "samples")
    sos = butter_sos(config.filter_order, config.filter_hz, dt)
    sp = _spacing_steps(config, dt)
    N = config.taps
    L = (N - 1) * sp
    thetas = []
    for j in range(U.shape[1]):
        u_prev = np.concatenate([[0.0], U[:-1, j]])
        uf = scipy.signal.sosfilt(sos, u_prev)
        xf = scipy.signal.sosfilt(sos, X[:, j])
        Phi = np.stack([xf[L - i * sp: xf.size - i * sp] for i in range(N)], axis=1)
        th, *_ = np.linalg.lstsq(Phi, uf[L:], rcond=None)
        thetas.append(th)
    return replace(config, theta0=tuple(float(v) for v in np.concatenate(thetas)))
