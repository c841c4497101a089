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
    sos_row,
    watch_row,
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


# the per-row parameters (``p`` of the kernel, (R, P)): scalars, the watch's parameters,
# its high-pass section, the low-pass sections
(_P_N, _P_DT, _P_SP, _P_LAM, _P_CAP, _P_THR, _P_DECAY, _P_GLO, _P_GHI, _P_LLO, _P_LHI,
 _P_BT, _P_TAPS, _P_L, _P_NSEC) = range(15)
_P_WP, _P_HP, _P_SOS = 15, 20, 26
# the per-row state (``s`` of the kernel, (R, S)) after the head (n·N + 1 columns, used in
# the first row of each test: the θ in use per channel, then the stop flag, so that the
# coefficients of a test are contiguous and the history a view): the scalars (NSTATE), the
# event (code, value, limit), the watch, then θ, P, the rings and the filter states
_S_CODE, _S_VAL, _S_LIM, _S_WATCH = NSTATE, NSTATE + 1, NSTATE + 2, NSTATE + 3
_S_TH = _S_WATCH + WATCH_STATES


@comp_kernel
def rls_kernel(p, s, z, zd, zm, u):
    """One call of the RLS compensator for R = K·n rows (test-major): ``p`` (R, P) the
    parameters, ``s`` (R, S) the state (layout: the ``_P_*``, ``_S_*`` offsets; the head of
    each test's first row holds the θ in use and the stop flag). The whole compensator —
    filters, the RLS update with its covariance cap, the bounded readings of θ and their
    drift stop, the FIR command, the oscillation watch — for :meth:`RLSCompensator.command`
    and the compiled loops alike. Returns True when a new safety event was raised."""
    n = int(p[0, _P_N])
    N = int(p[0, _P_TAPS])
    H = n * N + 1
    K = z.shape[0] // n
    event = False
    phi = np.empty(N)
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
            dt = pr[_P_DT]
            sp = int(pr[_P_SP])
            lam = pr[_P_LAM]
            p_cap = pr[_P_CAP]
            thr, decay = pr[_P_THR], pr[_P_DECAY]
            glo, ghi, llo, lhi, bound_time = pr[_P_GLO], pr[_P_GHI], pr[_P_LLO], \
                pr[_P_LHI], pr[_P_BT]
            L = int(pr[_P_L])
            nsec = int(pr[_P_NSEC])
            st = H
            th = H + _S_TH
            pp = th + N
            xr = pp + N * N
            zr = xr + L
            zi_u = zr + L
            zi_x = zi_u + 2 * nsec
            ca = j * N  # this channel's θ in use, in the head
            uf = sos_row(pr, _P_SOS, nsec, sr, zi_u, sr[st + _U_PREV])
            xf = sos_row(pr, _P_SOS, nsec, sr, zi_x, zm[row])
            idx = int(sr[st + _IDX])
            sr[xr + idx] = xf
            sr[zr + idx] = z[row]
            am = abs(zm[row])
            sr[st + _PEAK] = am if am > sr[st + _PEAK] * decay else sr[st + _PEAK] * decay
            if sr[st + _FILLED] < L:
                sr[st + _FILLED] += 1.0
            if sr[st + _FILLED] >= L and sr[st + _PEAK] >= thr:
                for i in range(N):
                    phi[i] = sr[xr + (idx - i * sp) % L]
                den = lam
                err = uf
                for r in range(N):
                    acc = 0.0
                    for c in range(N):
                        acc += sr[pp + r * N + c] * phi[c]
                    Pphi[r] = acc
                    den += phi[r] * acc
                    err -= sr[th + r] * phi[r]
                tr = 0.0
                for r in range(N):
                    sr[th + r] += Pphi[r] / den * err
                for r in range(N):
                    for c in range(r, N):
                        v = (sr[pp + r * N + c] - Pphi[r] * Pphi[c] / den) / lam
                        sr[pp + r * N + c] = v
                        sr[pp + c * N + r] = v
                    tr += sr[pp + r * N + r]
                if tr > p_cap:
                    f = p_cap / tr
                    for r in range(N):
                        for c in range(N):
                            sr[pp + r * N + c] *= f
                # the bounded readings of θ: DC gain and lead time
                g = 0.0
                m1 = 0.0
                for i in range(N):
                    g += sr[th + i]
                    m1 += sr[th + i] * i
                lead = -m1 * sp * dt / g if g != 0.0 else math.inf
                inside = glo <= g <= ghi and llo <= lead <= lhi
                if inside:
                    sr[st + _TIMER] = 0.0
                    for i in range(N):
                        head[ca + i] = sr[th + i]
                else:
                    sr[st + _TIMER] += dt
                    if sr[st + _TIMER] > bound_time and sr[H + _S_CODE] == 0.0:
                        if not (glo <= g <= ghi):
                            sr[H + _S_CODE] = 1.0
                            sr[H + _S_VAL] = g
                            sr[H + _S_LIM] = glo if g < glo else ghi
                        else:
                            sr[H + _S_CODE] = 2.0
                            sr[H + _S_VAL] = lead
                            sr[H + _S_LIM] = llo if lead < llo else lhi
                        event = True
            # command: the FIR on the desired displacement
            uk = 0.0
            for i in range(N):
                uk += head[ca + i] * sr[zr + (idx - i * sp) % L]
            sr[st + _IDX] = (idx + 1) % L
            sr[st + _U_PREV] = uk
            u[row] = uk
            osc, ru, lim = watch_row(pr, _P_WP, _P_HP, sr, H + _S_WATCH, uk, z[row])
            if osc and sr[H + _S_CODE] == 0.0:
                sr[H + _S_CODE] = 3.0
                sr[H + _S_VAL] = ru
                sr[H + _S_LIM] = lim
                event = True
        for j in range(n):
            if s[h0 + j, H + _S_CODE] != 0.0:
                head[n * N] = 1.0
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
    adaptive = True
    event_labels = LABELS
    event_units = UNITS
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
        self.wp = c.watch_params(dt)
        nsec = self.sos.shape[0]
        R = K * n
        # the kernel's arrays (rows test-major, row = k·n + j): its parameters ...
        p = np.zeros((R, _P_SOS + 6 * nsec))
        p[:, :_P_WP] = [n, dt, self.sp, lam, c.p0 * N, c.threshold, math.exp(-dt / 1.0),
                        c.gain_bounds[0], c.gain_bounds[1], c.lead_bounds[0],
                        c.lead_bounds[1], c.bound_time, N, L, nsec]
        p[:, _P_WP:_P_HP] = self.wp
        p[:, _P_HP:_P_SOS] = self.hp[0]
        p[:, _P_SOS:] = self.sos.reshape(-1)
        self.params = p
        # ... and its state; the Python object reads views of them
        H = n * N + 1
        th = H + _S_TH
        self.state = s = np.zeros((R, th + N + N * N + 2 * L + 4 * nsec))
        self.used = s.reshape(K, n * s.shape[1])[:, :n * N].reshape(K, n, N)
        """θ in use (K, n, N) (a view of the kernel's state)."""
        self.theta = s[:, th:th + N].reshape(K, n, N)
        """The latest RLS estimate of θ (K, n, N)."""
        self.P = s[:, th + N:th + N + N * N].reshape(K, n, N, N)
        self.code = s[:, H + _S_CODE].reshape(K, n)
        self.ev_val = s[:, H + _S_VAL].reshape(K, n)
        self.ev_lim = s[:, H + _S_LIM].reshape(K, n)
        self._gain = np.zeros((K, n))
        self._lead = np.zeros((K, n))
        self.reset()

    def reset(self) -> None:
        super().reset()
        self.state[:] = 0.0
        self.theta[:] = self.theta_init
        self.used[:] = self.theta_init
        idx = np.arange(self.config.taps)
        self.P[:, :, idx, idx] = self.config.p0

    def command(self, z: np.ndarray, zdot: np.ndarray, z_meas: np.ndarray) -> np.ndarray:
        if rls_kernel(self.params, self.state, np.ascontiguousarray(z).reshape(-1),
                      np.ascontiguousarray(zdot).reshape(-1),
                      np.ascontiguousarray(z_meas).reshape(-1), self.u.reshape(-1)):
            self.events()
        self.calls += 1
        return self.u


    def compiled(self):
        return (comp_ready(rls_kernel),), self.params, self.state

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
