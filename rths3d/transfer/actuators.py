"""Actuator models of the 1-D transfer systems: the identified platform model and its
discretisation, and (K, n_if) callables over the effect blocks.

The per-step physics lives in :mod:`rths3d.effects.blocks` (delay line, LTI state space,
lag, gain, offset, noise) and :mod:`rths3d.compensation`; this module holds the
platform's identified heave model G(s) (:func:`default_transfer_function`,
:func:`follow_servo_settings`, :func:`default_transport_delay`), its zero-order-hold
discretisation (:func:`discretise_tf`, python-control's arithmetic), and small callables
over the blocks (:class:`DelayLine`, :class:`LTIActuator`, :class:`SensorModel`; the
compensator's in :mod:`.compensator`) for users who step one piece on its own. It imports nothing of
:mod:`rths3d.compensation`, whose inverse compensator reads the identified model here.
"""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..effects.blocks import (
    DelayBlock,
    GainBlock,
    LagBlock,
    LTIBlock,
    NoiseBlock,
    OffsetBlock,
)
from ..errors import ConfigError
from ..kernels import Chain

DEFAULT_TF_OMEGA = 2 * math.pi * 50.0
"""Fallback actuator model: second-order lag, 50 Hz, ζ = 0.7 (≈ 4.5 ms delay at low f, the
size measured on the simulated platform with velocity feed-forward)."""
DEFAULT_TF_ZETA = 0.7


def _tf_file() -> Path:
    return Path(__file__).resolve().parents[2] / "assets" / "platform_heave_tf.json"


@functools.lru_cache(maxsize=1)
def _tf_data() -> dict | None:
    """The identification file's contents, or None when it is missing or unreadable (read
    once per process)."""
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
    set-point lag is the block α/(1 − (1 − α)z⁻¹), α = 1 − p, p = e^(−ΔT/τ), which delays by
    ΔT/(1 − p) − ΔT ≈ τ − ΔT/2: it enters as 1/(τ_e s + 1) with τ_e = ΔT/(1 − p) − ΔT/2, and
    its half-step lead ΔT/2 leaves the delay when the scene has no lag. A model left with a
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
    # the platform's set-point lag is a block at the interface rate, α/(1 − (1 − α)z⁻¹): a
    # continuous lag τ_e followed by a lead of ΔT/2, which leaves with the lag
    if ident["timeconst"] > 0 and not timeconst > 0:
        delay += 0.5 * dt
    elif timeconst > 0 and not ident["timeconst"] > 0:
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


def discretise_tf(num: Sequence[float], den: Sequence[float], dt: float
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """(A_d, B_d, C_d, D_d) of G(s) = num/den discretised exactly with the input held over
    ΔT (zero-order hold), in controllable canonical form.

    The arithmetic of python-control's ``sample_system(tf2ss(tf(num, den)), dt, "zoh")``
    without slycot (SciPy's ``tf2ss`` realisation, then the matrix exponential of
    [[A, B], [0, 0]]·ΔT as SciPy's ``cont2discrete``), the same to the last bit
    (tests/test_transfer_lti.py), computed here with ``scipy.linalg.expm``: importing
    python-control (and with it ``scipy.signal`` and matplotlib) cost every sweep worker 2 s
    of its start for this one conversion. (With slycot installed, python-control realises a
    minimal form instead: the same input-output map in other coordinates.)
    """
    num = np.atleast_1d(np.asarray(num, float))
    den = np.atleast_1d(np.asarray(den, float))
    if den.size < num.size or den[0] == 0:
        raise ConfigError("transfer.den", den.tolist(), "transfer function must be proper")
    A, B, C, D = _tf2ss(num, den)
    if A.shape[0] == 0:
        return np.zeros((0, 0)), np.zeros(0), np.zeros(0), D
    from scipy.linalg import expm

    n = A.shape[0]
    em = np.zeros((n + 1, n + 1))
    em[:n, :n] = A
    em[:n, n] = B
    ms = expm(dt * em)[:n, :]
    return ms[:, :n].copy(), ms[:, n].copy(), C, D


def _tf2ss(num: np.ndarray, den: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                      float]:
    """Controllable canonical realisation (A, B (n,), C (n,), D) of a proper SISO num/den,
    as python-control hands it to SciPy's ``tf2ss``: both polynomials stripped of leading
    zeros, then normalised by den[0]."""
    num = np.trim_zeros(num, "f")
    if num.size == 0:
        num = np.zeros(1)
    den = np.trim_zeros(den, "f")
    num, den = num / den[0], den / den[0]
    K = den.size
    if K == 1:  # a static gain
        return np.zeros((0, 0)), np.zeros(0), np.zeros(0), float(num[-1])
    num = np.concatenate([np.zeros(K - num.size), num])
    A = np.zeros((K - 1, K - 1))
    A[0] = -den[1:]
    A[1:, :-1] = np.eye(K - 2)
    B = np.zeros(K - 1)
    B[0] = 1.0
    C = num[1:] - num[0] * den[1:]
    return A, B, C, float(num[0])


def delay_estimate(num: Sequence[float], den: Sequence[float]) -> float:
    """Low-frequency group delay −dφ/dω at ω → 0 (s) of G(s) = num/den: −∠G(jω)/ω at
    ω = 10⁻³ rad/s (SciPy's ``freqs`` at that one frequency, whose import cost each sweep
    worker a second)."""
    w = 1e-3
    s = 1j * w
    h = np.polyval(np.asarray(num, float), s) / np.polyval(np.asarray(den, float), s)
    return float(-np.angle(h) / w)


class _Blocks:
    """A chain of blocks as a (K, n) callable with ``reset``."""

    def __init__(self, K: int, n: int, blocks: list) -> None:
        self.chain = Chain(K, n, blocks)

    def reset(self) -> None:
        self.chain.reset()

    def __call__(self, u: np.ndarray) -> np.ndarray:
        return self.chain(u)


class DelayLine(_Blocks):
    """Pure delay τ (s) of a (K, n) signal sampled at ΔT (:class:`~rths3d.effects.blocks.
    DelayBlock`); one τ for all tests."""

    def __init__(self, K: int, n: int, delay: float, dt: float):
        self.block = DelayBlock(K, n, delay, dt)
        super().__init__(K, n, [self.block])


class PerTestDelayLine(DelayLine):
    """:class:`DelayLine` with one τ_k (s) per test."""

    def __init__(self, K: int, n: int, delays: Sequence[float], dt: float):
        d = np.asarray(delays, dtype=float).reshape(-1)
        if d.size != K:
            raise ValueError(f"delays: {d.size} given for K = {K}")
        self.block = DelayBlock(K, n, np.repeat(d, n), dt)
        _Blocks.__init__(self, K, n, [self.block])


class LTIActuator(_Blocks):
    """G(s) = num/den per channel, discretised exactly with the command held over ΔT
    (:func:`discretise_tf`, :class:`~rths3d.effects.blocks.LTIBlock`)."""

    def __init__(self, K: int, n: int, num, den, dt: float):
        self.Ad, self.Bd, self.Cd, self.Dd = discretise_tf(num, den, dt)
        self.ns = self.Ad.shape[0]
        self.num = np.atleast_1d(np.asarray(num, float))
        self.den = np.atleast_1d(np.asarray(den, float))
        self.dcgain = float(self.num[-1] / self.den[-1]) if self.den[-1] != 0 else math.inf
        super().__init__(K, n, [LTIBlock(K, n, [(self.Ad, self.Bd, self.Cd, self.Dd)])])

    def delay_estimate(self) -> float:
        """Low-frequency group delay (s) of G(s) (see :func:`delay_estimate`)."""
        return delay_estimate(self.num, self.den)


class PerTestLTIActuator(_Blocks):
    """:class:`LTIActuator` with one transfer function per test."""

    def __init__(self, K: int, n: int, models: Sequence[tuple[Sequence[float], Sequence[float]]],
                 dt: float):
        if len(models) != K:
            raise ValueError(f"models: {len(models)} given for K = {K}")
        rows = [discretise_tf(num, den, dt) for num, den in models for _ in range(n)]
        block = LTIBlock(K, n, rows)
        self.ns = max(r[0].shape[0] for r in rows)
        """The largest model order (the others are padded)."""
        super().__init__(K, n, [block])


class SensorModel(_Blocks):
    """Force-torque sensor between F_m and F'_m (see :mod:`rths3d.transfer.sensor`):
    optional first-order dynamics τ_f, gain, offset, white noise (std; one seed, or one per
    test) and a delay; ``ideal`` passes F_m."""

    def __init__(self, K: int, n: int, dt: float, kind: str = "ideal", time_constant: float = 0,
                 noise_std: float = 0.0, gain: float = 1.0, offset: float = 0.0,
                 delay: float = 0.0, seed: int | Sequence[int] = 0):
        blocks: list = []
        if kind == "first_order":
            blocks.append(LagBlock(K, n, time_constant, dt))
        if gain != 1.0:
            blocks.append(GainBlock(K, n, gain))
        if offset != 0.0:
            blocks.append(OffsetBlock(K, n, offset))
        if noise_std:
            blocks.append(NoiseBlock(K, n, noise_std, seed))
        if delay > 0:
            blocks.append(DelayBlock(K, n, delay, dt))
        self.ideal = not blocks
        super().__init__(K, n, blocks)
