"""Signal blocks: the per-step physics of an effect, written once and compiled.

A block acts on R channel rows (K tests × n channels, row ``k·n + j``) one interface step ΔT
at a time. It holds ``params`` (R, P) and ``state`` (R, S) float arrays and a numba kernel

    kernel(params, state, u, y, w)      # u, y, w: (R,) input, output, standard-normal draw

that maps the step's input rows ``u`` to the outputs ``y`` (``w`` is used only by noise).
Every block at its "off" setting passes its input through unchanged, bit for bit. The same
kernel serves the compiled loop (:mod:`rths3d.stepping`), the Python loop (a block is
callable on (K, n) arrays) and whole recorded signals (:func:`run_blocks`, used by the
diagnosis to apply an effect to a replay), so each piece of physics exists once.

The block machinery (:class:`Block`, :class:`Chain`, :func:`run_chain`, :func:`run_blocks`)
and the project's numba settings live in :mod:`rths3d.kernels`; they are importable from here
too, as before.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..kernels.chain import Block, Chain, padded_kernels, run_blocks, run_chain
from ..kernels.compiler import (
    BLOCK_SIG,
    F1,
    F2,
    KernelTuple,
    block_kernel,
    inline_njit,
    kernel_tuple,
    njit,
    ready,
)

__all__ = ["BLOCK_SIG", "F1", "F2", "Block", "Chain", "DelayBlock", "GainBlock", "KernelTuple",
           "LTIBlock", "LagBlock", "NoiseBlock", "OffsetBlock", "PlayBlock", "RateLimitBlock",
           "block_kernel", "inline_njit", "kernel_tuple", "njit", "padded_kernels", "ready",
           "run_chain", "run_blocks"]


def _rows(value: Any, R: int) -> np.ndarray:
    """``value`` (a scalar or one per row) as a float array of R rows."""
    a = np.asarray(value, dtype=float).reshape(-1)
    if a.size == 1:
        return np.full(R, float(a[0]))
    if a.size != R:
        raise ValueError(f"{a.size} values given for {R} rows")
    return a.copy()


# ---------------------------------------------------------------------------- kernels
@block_kernel
def _delay_kernel(p, s, u, y, w):
    # p: [d0, frac, size]; s: [slot, ring buffer...]
    for r in range(u.shape[0]):
        d0 = int(p[r, 0])
        fr = p[r, 1]
        size = int(p[r, 2])
        i = int(s[r, 0])
        s[r, 1 + i] = u[r]
        a = s[r, 1 + (i - d0) % size]
        if fr != 0.0:
            b = s[r, 1 + (i - d0 - 1) % size]
            y[r] = a * (1.0 - fr) + b * fr
        else:
            y[r] = a
        s[r, 0] = (i + 1) % size


@block_kernel
def _lag_kernel(p, s, u, y, w):
    # first-order lag, discrete: s += α (u − s), α = 1 − e^(−ΔT/τ); α = 1 passes u
    for r in range(u.shape[0]):
        a = p[r, 0]
        if a < 1.0:
            s[r, 0] += (u[r] - s[r, 0]) * a
        else:
            s[r, 0] = u[r]
        y[r] = s[r, 0]


@block_kernel
def _gain_kernel(p, s, u, y, w):
    for r in range(u.shape[0]):
        y[r] = u[r] * p[r, 0]


@block_kernel
def _offset_kernel(p, s, u, y, w):
    for r in range(u.shape[0]):
        y[r] = u[r] + p[r, 0]


@block_kernel
def _noise_kernel(p, s, u, y, w):
    for r in range(u.shape[0]):
        y[r] = u[r] + w[r] * p[r, 0]


@block_kernel
def _lti_kernel(p, s, u, y, w):
    # p: [ns, Ad (m×m row-major), Bd (m), Cd (m), Dd] with m the largest order of the rows;
    # s: [x (m), x_next (m)]; zero-order hold of u over the step, y at its end
    m = s.shape[1] // 2
    for r in range(u.shape[0]):
        ns = int(p[r, 0])
        ur = u[r]
        for i in range(ns):
            acc = 0.0
            for j in range(ns):
                acc += s[r, j] * p[r, 1 + i * m + j]
            s[r, m + i] = acc + ur * p[r, 1 + m * m + i]
        acc = 0.0
        for i in range(ns):
            s[r, i] = s[r, m + i]
            acc += s[r, i] * p[r, 1 + m * m + m + i]
        d = p[r, 1 + m * m + 2 * m]
        if d != 0.0:
            acc += d * ur
        y[r] = acc


@block_kernel
def _rate_kernel(p, s, u, y, w):
    # rate limit: |y_n − y_{n−1}| ≤ p[r, 0] (v_max·ΔT); inf passes u
    for r in range(u.shape[0]):
        st = p[r, 0]
        d = u[r] - s[r, 0]
        if d > st:
            d = st
        elif d < -st:
            d = -st
        s[r, 0] += d
        y[r] = s[r, 0]


@block_kernel
def _play_kernel(p, s, u, y, w):
    # play (backlash) operator of total width p[r, 0]: the output follows once the input
    # has taken up half the play on either side
    for r in range(u.shape[0]):
        h = 0.5 * p[r, 0]
        if s[r, 0] < u[r] - h:
            s[r, 0] = u[r] - h
        elif s[r, 0] > u[r] + h:
            s[r, 0] = u[r] + h
        y[r] = s[r, 0]


# ---------------------------------------------------------------------------- blocks
class RateLimitBlock(Block):
    """Rate limit |Δy| ≤ v_max·ΔT per row (v_max in units/s; inf: off), starting at rest (0)."""

    kernel = _rate_kernel

    def __init__(self, K: int, n: int, v_max: float | Sequence[float], dt: float):
        v = _rows(v_max, K * n)
        super().__init__(K, n, (v * dt)[:, None], np.zeros((K * n, 1)))


class PlayBlock(Block):
    """Play (backlash) of total width b per row (0: off), starting at rest (0)."""

    kernel = _play_kernel

    def __init__(self, K: int, n: int, width: float | Sequence[float]):
        super().__init__(K, n, _rows(width, K * n)[:, None], np.zeros((K * n, 1)))


class DelayBlock(Block):
    """Pure delay τ (s) per row, linear interpolation between samples for fractional delays;
    the output is 0 before t = τ (the loop starts at rest)."""

    kernel = _delay_kernel

    def __init__(self, K: int, n: int, delay: float | Sequence[float], dt: float):
        """``delay``: τ (s), one for all rows or one per row."""
        per_row = _rows(delay, K * n)
        steps = per_row / dt
        d0 = np.floor(steps + 1e-12)
        size = int(d0.max()) + 2 if d0.size else 2
        params = np.stack([d0, steps - d0, np.full(d0.shape, size)], axis=1)
        super().__init__(K, n, params, np.zeros((K * n, size + 1)))
        self.delays = per_row


class LagBlock(Block):
    """First-order lag 1/(1 + sτ) with time constant τ (s) per row, discretised as
    s_{n+1} = s_n + α (u − s_n), α = 1 − e^(−ΔT/τ); τ = 0 passes the input."""

    kernel = _lag_kernel

    def __init__(self, K: int, n: int, time_constant: float | Sequence[float], dt: float):
        tc = _rows(time_constant, K * n)
        alpha = np.array([lag_alpha(dt, t) for t in tc])
        super().__init__(K, n, alpha[:, None], np.zeros((K * n, 1)))


class GainBlock(Block):
    """y = g·u per row (1: off)."""

    kernel = _gain_kernel

    def __init__(self, K: int, n: int, gain: float | Sequence[float]):
        super().__init__(K, n, _rows(gain, K * n)[:, None], np.zeros((K * n, 0)))


class OffsetBlock(Block):
    """y = u + b per row (0: off)."""

    kernel = _offset_kernel

    def __init__(self, K: int, n: int, offset: float | Sequence[float]):
        super().__init__(K, n, _rows(offset, K * n)[:, None], np.zeros((K * n, 0)))


class NoiseBlock(Block):
    """y = u + σ·w, w white standard-normal, σ per row (0: off).

    ``seed``: one seed (one generator drawn across all rows, row by row per step) or one per
    test (each test's rows from its own generator, so that a test's noise depends on its own
    seed, not on the tests stepped with it)."""

    kernel = _noise_kernel
    uses_noise = True

    def __init__(self, K: int, n: int, std: float | Sequence[float],
                 seed: int | Sequence[int] = 0):
        super().__init__(K, n, _rows(std, K * n)[:, None], np.zeros((K * n, 0)))
        if not isinstance(seed, int | np.integer) and len(seed) != K:
            raise ValueError(f"seed: {len(seed)} seeds given for K = {K} tests")
        self.seed = seed
        self.reset()

    def reset(self) -> None:
        super().reset()
        if isinstance(self.seed, int | np.integer):
            self._rng: Any = np.random.default_rng(int(self.seed))
        else:
            self._rng = [np.random.default_rng(int(s)) for s in self.seed]

    def draw(self, out: np.ndarray) -> None:
        if isinstance(self._rng, list):
            # per test: its rows of each step, in step order, from its own generator
            view = out.reshape(out.shape[0], self.K, self.n)
            for k, g in enumerate(self._rng):
                view[:, k, :] = g.standard_normal((out.shape[0], self.n))
        else:
            self._rng.standard_normal(out=out)


class LTIBlock(Block):
    """Discrete state-space model per row: x_{n+1} = A_d x_n + B_d u_n, y_{n+1} = C_d x_{n+1}
    + D_d u_n (u held over the step). Rows may have models of different orders (padded)."""

    kernel = _lti_kernel

    def __init__(self, K: int, n: int, models: Sequence[tuple[np.ndarray, np.ndarray,
                                                              np.ndarray, float]]):
        """``models``: one (A_d, B_d, C_d, D_d) per row, or one for all rows."""
        R = K * n
        if len(models) == 1:
            models = list(models) * R
        if len(models) != R:
            raise ValueError(f"{len(models)} models given for {R} rows")
        m = max(1, max(np.atleast_2d(a).shape[0] if np.size(a) else 0 for a, *_ in models))
        params = np.zeros((R, 2 + m * m + 2 * m))
        for r, (A, B, C, D) in enumerate(models):
            ns = np.atleast_2d(A).shape[0] if np.size(A) else 0
            params[r, 0] = ns
            if ns:
                params[r, 1:1 + m * m].reshape(m, m)[:ns, :ns] = A
                params[r, 1 + m * m:1 + m * m + ns] = np.ravel(B)
                params[r, 1 + m * m + m:1 + m * m + m + ns] = np.ravel(C)
            params[r, 1 + m * m + 2 * m] = float(D)
        super().__init__(K, n, params, np.zeros((R, 2 * m)))
        self.order = m


def lag_alpha(dt: float, time_constant: float) -> float:
    """α = 1 − e^(−ΔT/τ) of :class:`LagBlock` (1 for τ = 0)."""
    return 1.0 - math.exp(-dt / time_constant) if time_constant > 0 else 1.0
