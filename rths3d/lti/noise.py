"""Sensor noise generators.

Band-limited white noise as Simulink's block of that name makes it: a unit-variance normal
sequence ``w_k`` held over each sample period ``dt``, scaled by ``√(Cov/dt)`` where ``Cov`` is
the noise power (units²·s). Two sources of ``w_k``:

* :func:`normal_sequence` — numpy's PCG64 generator (any seed);
* :func:`simulink_randn` — an emulation of Simulink's Random Number block: a Park–Miller
  minimal-standard LCG (multiplier 16807, modulus 2³¹ − 1, computed exactly as the Schrage
  form does), uniforms ``s/(2³¹ − 1)``, and Marsaglia's polar method (pairs
  ``(2u₁ − 1, 2u₂ − 1)`` rejected while ``r² > 1``, output ``√(−2 ln r²/r²)·(2u₁ − 1)``, the
  second value discarded), with Simulink's seed scrambling (seed 0 → state 1144108930).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ConfigError

__all__ = ["band_limited_std", "band_limited_white_noise", "normal_sequence",
           "simulink_randn", "simulink_seed_state", "simulink_uniform"]

_IM = 2147483647  # 2^31 - 1
_IA = 16807


def band_limited_std(cov: float, dt: float) -> float:
    """Standard deviation ``√(Cov/dt)`` of Simulink band-limited white noise of power Cov."""
    if not (cov >= 0.0):
        raise ConfigError("noise.cov", cov, "noise power must be ≥ 0")
    if not (dt > 0.0):
        raise ConfigError("noise.dt", dt, "sample period must be > 0 s")
    return math.sqrt(cov / dt)


def normal_sequence(n: int, seed: int | None = 0) -> np.ndarray:
    """``n`` independent standard normal samples from numpy's default generator."""
    return np.random.default_rng(seed).standard_normal(int(n))


def simulink_seed_state(seed: int) -> int:
    """Initial LCG state of Simulink's Random Number block for ``seed`` (scrambled).

    Follows Simulink's ``rt_RandnInit``-style scrambling: swap-and-mix of the 16-bit halves,
    then clamp into [1, 2³¹ − 2] (a zero state becomes 1144108930).
    """
    t = int(seed) & 0xFFFFFFFF
    r = t >> 16
    tt = t & 0x8000
    t = ((((t - (r << 16)) + tt) << 16) + tt + r) & 0xFFFFFFFF
    if t < 1:
        t = 1144108930
    elif t > _IM - 1:
        t = _IM - 1
    return t


def simulink_uniform(n: int, state: int) -> tuple[np.ndarray, int]:
    """``n`` uniforms of the Park–Miller LCG from ``state``; returns (u, next state).

    Vectorised by jumping ahead: ``s_{j+i} = a^i s_j mod m`` for blocks of i; all products
    stay below 2⁶² so uint64 arithmetic is exact.
    """
    n = int(n)
    block = 4096
    powers = np.empty(block, dtype=np.uint64)
    p = 1
    for i in range(block):
        p = (p * _IA) % _IM
        powers[i] = p  # a^(i+1)
    jump = int(powers[-1])  # a^block
    n_blocks = -(-n // block)
    starts = np.empty(n_blocks, dtype=np.uint64)
    s = int(state)
    for b in range(n_blocks):
        starts[b] = s
        s = (s * jump) % _IM
    seq = (starts[:, None] * powers[None, :]) % np.uint64(_IM)
    seq = seq.reshape(-1)[:n]
    nxt = int(seq[-1]) if n else int(state)
    return seq.astype(np.float64) * 4.6566128752457969e-10, nxt


def simulink_randn(n: int, seed: int = 0) -> np.ndarray:
    """``n`` standard normal samples exactly as Simulink's Random Number block draws them."""
    n = int(n)
    state = simulink_seed_state(seed)
    out = np.empty(0)
    while out.size < n:
        need = n - out.size
        m = 2 * int(need * 1.35 + 64)  # polar method accepts π/4 of the pairs
        u, state = simulink_uniform(m, state)
        sr = 2.0 * u[0::2] - 1.0
        si = 2.0 * u[1::2] - 1.0
        r2 = sr * sr + si * si
        ok = r2 <= 1.0
        with np.errstate(divide="ignore", invalid="ignore"):
            vals = np.sqrt(-2.0 * np.log(r2[ok]) / r2[ok]) * sr[ok]
        out = np.concatenate([out, vals])
    # The draws after the last accepted pair up to `state` are not used by the block, but
    # each call restarts from the seed, so the sequence is exact for the first n outputs.
    return out[:n]


def band_limited_white_noise(n: int, cov: float, dt: float, seed: int | None = 0,
                             generator: str = "numpy") -> np.ndarray:
    """``n`` samples of band-limited white noise of power ``cov`` at period ``dt``.

    ``generator`` is ``"numpy"`` (PCG64) or ``"simulink"`` (Random Number block emulation).
    """
    std = band_limited_std(cov, dt)
    if generator == "numpy":
        return std * normal_sequence(n, seed)
    if generator == "simulink":
        return std * simulink_randn(n, 0 if seed is None else int(seed))
    raise ConfigError("noise.generator", generator, "must be 'numpy' or 'simulink'")
