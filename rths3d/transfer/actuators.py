"""Actuator models (command z → achieved z'), compensation and the force-sensor model.

All work on (K, n_if) arrays, K tests × interface DOFs, one call per interface step ΔT.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import scipy.signal

from ..errors import ConfigError

DEFAULT_TF_OMEGA = 2 * math.pi * 50.0
"""Fallback actuator model: second-order lag, 50 Hz, ζ = 0.7 (≈ 4.5 ms delay at low f, the
size measured on the simulated platform with velocity feed-forward)."""
DEFAULT_TF_ZETA = 0.7


class DelayLine:
    """Pure delay τ (s) of a (K, n) signal sampled at ΔT, linear interpolation between
    samples for fractional delays. Before t = τ the output is the initial value 0."""

    def __init__(self, K: int, n: int, delay: float, dt: float):
        steps = delay / dt
        self.d0 = int(math.floor(steps + 1e-12))
        self.frac = steps - self.d0
        self.size = self.d0 + 2
        self.buf = np.zeros((self.size, K, n))
        self.i = 0
        self.out = np.zeros((K, n))
        self._b = np.zeros((K, n))

    def reset(self) -> None:
        self.buf[:] = 0.0
        self.i = 0
        self.out[:] = 0.0

    def __call__(self, u: np.ndarray) -> np.ndarray:
        """Push u(t_n); return u(t_n − τ)."""
        i = self.i
        self.buf[i] = u
        a = self.buf[(i - self.d0) % self.size]
        if self.frac:
            b = self.buf[(i - self.d0 - 1) % self.size]
            np.multiply(a, 1.0 - self.frac, out=self.out)
            self.out += np.multiply(self.frac, b, out=self._b)
        else:
            self.out[:] = a
        self.i = (i + 1) % self.size
        return self.out


class PerTestDelayLine:
    """:class:`DelayLine` with one delay τ_k (s) per test, so that tests whose actuators
    differ only in their transport delay are stepped together. Same interpolation and
    start-up, the same floating-point operations per test (a test's output equals that of a
    :class:`DelayLine` with its τ_k)."""

    def __init__(self, K: int, n: int, delays: Sequence[float], dt: float):
        steps = np.asarray(delays, dtype=float) / dt
        if steps.shape != (K,):
            raise ValueError(f"delays: {steps.shape[0] if steps.ndim else 1} given for K = {K}")
        d0 = np.floor(steps + 1e-12).astype(int)
        self.K = K
        self.size = int(d0.max()) + 2
        # ring buffer of (slot, test) rows; the rows to read when slot i was just written are
        # tabulated for every i, so a step gathers with np.take and allocates nothing
        self.buf = np.zeros((self.size * K, n))
        slots = np.arange(self.size)[:, None]
        tests = np.arange(K)
        self._row_a = ((slots - d0) % self.size) * K + tests
        self._row_b = ((slots - d0 - 1) % self.size) * K + tests
        frac = (steps - d0)[:, None]
        self._keep = 1.0 - frac
        self._frac = frac
        self._interp = bool(np.any(frac))
        self.i = 0
        self.out = np.zeros((K, n))
        self._b = np.zeros((K, n))

    def reset(self) -> None:
        self.buf[:] = 0.0
        self.i = 0
        self.out[:] = 0.0

    def __call__(self, u: np.ndarray) -> np.ndarray:
        """Push u(t_n) (K, n); return u_k(t_n − τ_k) per test."""
        i, K = self.i, self.K
        self.buf[i * K:(i + 1) * K] = u
        # mode "clip" (the rows are valid): "raise" buffers the output inside numpy
        np.take(self.buf, self._row_a[i], axis=0, out=self.out, mode="clip")
        if self._interp:
            np.take(self.buf, self._row_b[i], axis=0, out=self._b, mode="clip")
            self.out *= self._keep
            self._b *= self._frac
            self.out += self._b
        self.i = (i + 1) % self.size
        return self.out


def _tf_file() -> Path:
    return Path(__file__).resolve().parents[2] / "assets" / "platform_heave_tf.json"


def _tf_data() -> dict | None:
    """The identification file's contents, or None when it is missing or unreadable."""
    path = _tf_file()
    if not path.exists():
        return None
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def default_transfer_function() -> tuple[list[float], list[float], str]:
    """(num, den, source) of the actuator model: ``assets/platform_heave_tf.json`` when the
    platform's identification wrote it, else the 50 Hz second-order fallback. The file's
    transport delay is in :func:`default_transport_delay`."""
    data = _tf_data()
    if data is not None:
        try:
            return (list(map(float, data["num"])), list(map(float, data["den"])),
                    _tf_file().name)
        except (KeyError, ValueError, TypeError):
            pass
    w, z = DEFAULT_TF_OMEGA, DEFAULT_TF_ZETA
    return [w * w], [1.0, 2 * z * w, w * w], "second-order 50 Hz fallback"


def _identified_servo() -> dict | None:
    """The leg-servo settings of the identification run behind the default G(s), or None."""
    data = _tf_data()
    try:
        act = data["platform"]  # type: ignore[index]
        return {"timeconst": float(act["timeconst"]), "velocity_ff": bool(act["velocity_ff"]),
                "kp": float(act["kp"]), "kv": float(act["kv"])}
    except (KeyError, ValueError, TypeError):
        return None


def follow_servo_settings(num: Sequence[float], den: Sequence[float], delay: float,
                          timeconst: float, velocity_ff: bool, kp: float, kv: float,
                          dt: float) -> tuple[list[float], list[float], float]:
    """The identified model G(s) = num/den after a pure ``delay`` (s), changed so that the 1-D
    LTI path follows the scene's leg-servo settings instead of the identification run's:
    returns (num, den, delay).

    Two first-order factors of the platform's chain (see
    :func:`rths3d.platform.model.predicted_delay`) depend on the settings: the set-point lag
    (``timeconst`` τ, s) and, without velocity feed-forward, the servo lag 1/((kv/kp)s + 1)
    (``kp`` N/m, ``kv`` N·s/m). The identification run's factors are divided out and the
    scene's multiplied in; with the identification's settings nothing changes. MuJoCo's
    set-point filter is discrete, (1 − p)/(z − p) with p = e^(−ΔT/τ), and delays by
    ΔT/(1 − p) ≈ τ + ΔT/2: it enters as 1/(τ_e s + 1) with τ_e = ΔT/(1 − p) − ΔT/2, and its
    extra half step ΔT/2 leaves the delay when the scene has no filter. A model left with a
    feedthrough D (no filter, feed-forward on) reads D·z at the end of the held step where the
    platform's servo follows the set-point within it: the delay shortens by a further D·ΔT/2.
    This matches the platform's 1 Hz delay to ≤ 0.1 ms (``tests/test_transfer.py``). The
    servo's mass resonance stays the identified one: it matters only well above the test
    frequencies (≈ 0.7 ms at 10 Hz). Without the identification file: no change.
    """
    ident = _identified_servo()
    if ident is None:
        return list(num), list(den), delay

    def tau_e(tc: float) -> float:
        return dt / -math.expm1(-dt / tc) - 0.5 * dt if tc > 0 else 0.0

    def lags(tc: float, ff: bool, p: float, v: float) -> np.ndarray:
        poly = np.array([tau_e(tc), 1.0]) if tc > 0 else np.array([1.0])
        if not ff and v > 0:
            poly = np.polymul(poly, [v / p, 1.0])
        return poly

    c_num = lags(ident["timeconst"], ident["velocity_ff"], ident["kp"], ident["kv"])
    c_den = lags(float(timeconst), bool(velocity_ff), float(kp), float(kv))
    if c_num.size == c_den.size and np.allclose(c_num, c_den, rtol=1e-12, atol=0.0):
        return list(num), list(den), delay
    num2, den2 = np.polymul(num, c_num), np.polymul(den, c_den)
    if ident["timeconst"] > 0 and not timeconst > 0:
        delay -= 0.5 * dt
    if num2.size == den2.size:
        delay -= 0.5 * dt * num2[0] / den2[0]
    return num2.tolist(), den2.tolist(), max(0.0, delay)


def default_transport_delay(dt: float, actuator_delay: float = 0.0) -> float:
    """Pure delay (s) the 1-D LTI path applies before the default G(s) so that it reproduces
    the identified platform at the loop's samples.

    The file's model is ``G(s)·exp(−sT)``, fitted to the *sampled* ratio z'_k/z_k of the
    platform run with the loop's timing convention (command z_{n+1} held from t_n). The LTI
    actuator holds the same command over [t_n, t_{n+1}] and reads z' at t_{n+1}: a
    zero-order hold of the next sample leads the continuous G by ΔT/2. The platform's
    measured response already contains that lead, so the LTI path adds ΔT/2 back.
    ``T`` also contains the transport delay of the identification run's leg actuators
    (``platform.delay`` in the file); the scene's ``transfer.delay`` (``actuator_delay``)
    replaces it, so that ``transfer.delay`` means the actuator transport delay for both the
    ``lti`` and the ``stewart`` transfer systems. Without the file: ``actuator_delay``.
    """
    data = _tf_data()
    if data is not None:
        try:
            T = float(data["delay"])
            t_act = float(data.get("platform", {}).get("delay", 0.0))
        except (KeyError, ValueError, TypeError, AttributeError):
            return float(actuator_delay)
        if math.isfinite(T) and math.isfinite(t_act):
            return max(0.0, T - t_act + 0.5 * dt + float(actuator_delay))
    return float(actuator_delay)


class LTIActuator:
    """Continuous transfer function G(s) = num/den per interface DOF, discretised exactly
    with the command held over ΔT (zero-order hold), stepped for K·n_if channels."""

    def __init__(self, K: int, n: int, num, den, dt: float):
        num = np.atleast_1d(np.asarray(num, float))
        den = np.atleast_1d(np.asarray(den, float))
        if den.size < num.size or den[0] == 0:
            raise ConfigError("transfer.den", den.tolist(), "transfer function must be proper")
        A, B, C, D = scipy.signal.tf2ss(num, den)
        if A.size == 0:
            Ad = np.zeros((0, 0))
            Bd = np.zeros((0, 1))
            Cd = np.zeros((1, 0))
            Dd = np.atleast_2d(D)
        else:
            Ad, Bd, Cd, Dd, _ = scipy.signal.cont2discrete((A, B, C, D), dt, method="zoh")
        self.ns = Ad.shape[0]
        self.AdT = np.ascontiguousarray(Ad.T)
        self.Bd = Bd[:, 0].copy()
        self.Cd = Cd[0].copy()
        self.Dd = float(Dd[0, 0])
        self.x = np.zeros((K * n, self.ns))  # channels × states: one matmul per step
        self._x_next = np.zeros((K * n, self.ns))  # swapped with x each step
        # B u per channel from full-size operands (a broadcast product of two small axes
        # makes numpy allocate an iteration buffer)
        self._B = np.tile(self.Bd, (K * n, 1))
        self._u = np.zeros((K * n, self.ns))
        self._bu = np.zeros((K * n, self.ns))
        self._du = np.zeros((K, n))
        self.y = np.zeros((K, n))
        self._y2 = self.y.reshape(K * n)
        self.num, self.den = num, den
        self.dcgain = float(num[-1] / den[-1]) if den[-1] != 0 else math.inf

    def reset(self) -> None:
        self.x[:] = 0.0
        self.y[:] = 0.0

    def __call__(self, u: np.ndarray) -> np.ndarray:
        """Apply command u(t_n) (held until t_{n+1}); return the output y(t_{n+1})."""
        u2 = u.reshape(-1)
        x = np.matmul(self.x, self.AdT, out=self._x_next)
        np.copyto(self._u, u2[:, None])
        x += np.multiply(self._u, self._B, out=self._bu)
        self.x, self._x_next = x, self.x
        np.matmul(x, self.Cd, out=self._y2)
        if self.Dd:
            self.y += np.multiply(self.Dd, u, out=self._du)
        return self.y

    def delay_estimate(self) -> float:
        """Low-frequency group delay −dφ/dω at ω → 0 (s) of G(s) (plus half a ZOH step)."""
        w = 1e-3
        _, h = scipy.signal.freqs(self.num, self.den, worN=[w])
        return float(-np.angle(h[0]) / w)


class PerTestLTIActuator:
    """:class:`LTIActuator` with one transfer function per test, so that tests whose
    actuators differ (servo lag, velocity feed-forward, identified or user models) are
    stepped together. Each test's discrete state-space model is padded with decoupled zero
    states to the largest order; one stacked matmul per step serves all K·n_if channels."""

    def __init__(self, K: int, n: int, models: Sequence[tuple[Sequence[float], Sequence[float]]],
                 dt: float):
        if len(models) != K:
            raise ValueError(f"models: {len(models)} given for K = {K}")
        parts = [LTIActuator(1, 1, num, den, dt) for num, den in models]
        ns = max(p.ns for p in parts)
        C = K * n
        A = np.zeros((C, ns, ns))
        B = np.zeros((C, ns))
        Cr = np.zeros((C, 1, ns))
        D = np.zeros((K, n))
        for k, p in enumerate(parts):
            rows = slice(k * n, (k + 1) * n)
            A[rows, :p.ns, :p.ns] = p.AdT.T
            B[rows, :p.ns] = p.Bd
            Cr[rows, 0, :p.ns] = p.Cd
            D[k] = p.Dd
        self.ns = ns
        self.A, self.B, self.Cr, self.D = A, B, Cr, D
        self._has_d = bool(np.any(D))
        # two state buffers, swapped each step, each with its (C, ns) view made once
        self.x = np.zeros((C, ns, 1))
        self._x_next = np.zeros((C, ns, 1))
        self._x2, self._x_next2 = self.x[:, :, 0], self._x_next[:, :, 0]
        self._bu = np.zeros((C, ns))
        self._u = np.zeros((C, ns))  # u per channel and state (see LTIActuator)
        self._du = np.zeros((K, n))
        self.y = np.zeros((K, n))
        self._y3 = self.y.reshape(C, 1, 1)

    def reset(self) -> None:
        self.x[:] = 0.0
        self._x_next[:] = 0.0
        self.y[:] = 0.0

    def __call__(self, u: np.ndarray) -> np.ndarray:
        """Apply command u(t_n) (held until t_{n+1}); return the output y(t_{n+1})."""
        np.matmul(self.A, self.x, out=self._x_next)
        self.x, self._x_next = self._x_next, self.x
        self._x2, self._x_next2 = self._x_next2, self._x2
        np.copyto(self._u, u.reshape(-1, 1))
        np.multiply(self.B, self._u, out=self._bu)
        self._x2 += self._bu
        np.matmul(self.Cr, self.x, out=self._y3)
        if self._has_d:
            np.multiply(self.D, u, out=self._du)
            self.y += self._du
        return self.y


class Compensator:
    """Delay compensation of the command: ``velocity`` z_c = z + τ_c ż; ``polynomial``
    z_c = p(t + τ_c) with p the polynomial of ``order`` through the last order+1 commands
    (Lagrange extrapolation); ``none`` passes z through."""

    def __init__(self, K: int, n: int, kind: str, tau: float | Sequence[float], dt: float,
                 order: int = 2):
        """``tau``: τ_c (s), or one per test for ``velocity`` (0 for tests without
        compensation, so that tests with and without it are stepped together)."""
        self.kind = kind
        if np.ndim(tau):
            if kind != "velocity":
                raise ValueError(f"per-test tau needs kind 'velocity', not {kind!r}")
            taus = np.asarray(tau, dtype=float).reshape(K, 1)
            self.tau = taus
            self._pass = not np.any(taus)
            tau = 0.0
        else:
            self.tau = float(tau)
            self._pass = kind == "none" or self.tau == 0.0
        self.order = int(order)
        self.hist = np.zeros((order + 1, K, n))
        self.out = np.zeros((K, n))
        # Lagrange weights for extrapolating samples at t_n, t_{n-1}, ... to t_n + τ
        s = tau / dt
        nodes = -np.arange(order + 1, dtype=float)
        w = np.ones(order + 1)
        for j in range(order + 1):
            for m in range(order + 1):
                if m != j:
                    w[j] *= (s - nodes[m]) / (nodes[j] - nodes[m])
        self.w = w

    def reset(self) -> None:
        self.hist[:] = 0.0

    def __call__(self, z: np.ndarray, zdot: np.ndarray) -> np.ndarray:
        if self._pass:
            return z
        if self.kind == "velocity":
            np.multiply(zdot, self.tau, out=self.out)
            self.out += z
            return self.out
        h = self.hist
        for j in range(self.order, 0, -1):  # shift in place, newest first (no copy)
            h[j] = h[j - 1]
        h[0] = z
        np.einsum("j,jkn->kn", self.w, self.hist, out=self.out)
        return self.out


class SensorModel:
    """Force-torque sensor between F_m and F'_m: optional first-order dynamics (time constant
    τ_f), gain, offset, white noise (std, seeded) and a delay. ``ideal`` passes F_m.

    ``seed``: one seed for the K tests (one noise stream drawn across them), or a sequence of
    K seeds, one generator per test, so that a test's noise depends only on its own seed, not
    on the tests stepped with it."""

    def __init__(self, K: int, n: int, dt: float, kind: str = "ideal", time_constant: float = 0,
                 noise_std: float = 0.0, gain: float = 1.0, offset: float = 0.0,
                 delay: float = 0.0, seed: int | Sequence[int] = 0):
        self.ideal = (kind == "ideal" and noise_std == 0 and gain == 1 and offset == 0
                      and delay == 0)
        self.alpha = 1.0 - math.exp(-dt / time_constant) if kind == "first_order" else 1.0
        self.gain, self.offset, self.noise_std = gain, offset, noise_std
        if not isinstance(seed, int | np.integer) and len(seed) != K:
            raise ValueError(f"seed: {len(seed)} seeds given for K = {K} tests")
        self.seed = seed
        self.rng = self._generators()
        self.state = np.zeros((K, n))
        self.out = np.zeros((K, n))
        # step buffers (no allocation per step): the lag's increment, the noise draw and its
        # per-test rows, the gained signal ahead of the delay
        self._inc = np.zeros((K, n))
        self._noise = np.zeros((K, n))
        self._noise_rows = list(self._noise)
        self._pre = np.zeros((K, n)) if delay > 0 else self.out
        self.delay = DelayLine(K, n, delay, dt) if delay > 0 else None

    def reset(self) -> None:
        self.state[:] = 0.0
        self.rng = self._generators()
        if self.delay is not None:
            self.delay.reset()

    def _generators(self):
        if isinstance(self.seed, int | np.integer):
            return np.random.default_rng(self.seed)
        return [np.random.default_rng(int(s)) for s in self.seed]

    def __call__(self, f: np.ndarray) -> np.ndarray:
        if self.ideal:
            return f
        if self.alpha < 1.0:
            np.subtract(f, self.state, out=self._inc)
            self._inc *= self.alpha
            self.state += self._inc
        else:
            self.state[:] = f
        out = self._pre
        np.multiply(self.state, self.gain, out=out)
        out += self.offset
        if self.noise_std:
            if isinstance(self.rng, list):
                for g, row in zip(self.rng, self._noise_rows, strict=True):
                    g.standard_normal(out=row)
            else:
                self.rng.standard_normal(out=self._noise)
            self._noise *= self.noise_std
            out += self._noise
        if self.delay is not None:
            self.out[:] = self.delay(out)
        return self.out
