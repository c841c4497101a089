"""Signal blocks and chains: the machinery every per-step signal effect runs on.

A block acts on R channel rows (K tests × n channels, row ``k·n + j``) one interface step ΔT
at a time. It holds ``params`` (R, P) and ``state`` (R, S) float arrays and a numba kernel

    kernel(params, state, u, y, w)      # u, y, w: (R,) input, output, standard-normal draw

that maps the step's input rows ``u`` to the outputs ``y`` (``w`` is used only by noise).
The same kernel serves the compiled loop (:mod:`rths3d.stepping`), the Python loop (a block
is callable on (K, n) arrays) and whole recorded signals (:func:`run_blocks`, used by the
diagnosis to apply an effect to a replay). A :class:`Chain` applies blocks in order; its
kernels are called as first-class functions by one compiled caller (:func:`run_chain`), so a
new block needs no new loop code. The blocks themselves (delay, lag, gain, offset, noise,
LTI, rate limit, play) are the effects' physics: :mod:`rths3d.effects.blocks`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, ClassVar

import numpy as np

from .compiler import block_kernel, njit, ready

__all__ = ["Block", "Chain", "padded_kernels", "run_blocks", "run_chain"]


class Block:
    """Base class: a stateful per-step signal block over R = K·n rows (see module docstring).

    Subclasses set :attr:`kernel` (a numba function), fill ``params`` and ``state0`` in their
    constructor and may set :attr:`uses_noise`.
    """

    kernel: ClassVar[Any]
    uses_noise: ClassVar[bool] = False

    def __init__(self, K: int, n: int, params: np.ndarray, state0: np.ndarray):
        ready(type(self).kernel)
        self.K, self.n = int(K), int(n)
        self.params = np.ascontiguousarray(params, dtype=float)
        self.state0 = np.ascontiguousarray(state0, dtype=float)
        self.state = self.state0.copy()
        self._y = np.zeros((self.K, self.n))
        self._w = np.zeros(self.K * self.n)

    @property
    def rows(self) -> int:
        return self.K * self.n

    def reset(self) -> None:
        self.state[:] = self.state0

    def draw(self, out: np.ndarray) -> None:
        """Fill ``out`` (steps, R) with the standard-normal draws of the next steps (noise
        blocks; others leave it as it is)."""

    def __call__(self, u: np.ndarray) -> np.ndarray:
        """One step on (K, n) inputs; returns the (K, n) outputs (a buffer of the block)."""
        w = self._w
        if self.uses_noise:
            self.draw(w[None, :])
        type(self).kernel(self.params, self.state, np.ascontiguousarray(u).reshape(-1),
                          self._y.reshape(-1), w)
        return self._y


@block_kernel
def _pass_kernel(p, s, u, y, w):
    for r in range(u.shape[0]):
        y[r] = u[r]


@njit
def run_chain(fns, ps, ss, u, y, w):
    """Apply the block kernels ``fns`` in order to the rows ``u`` (outputs in ``y``)."""
    fns[0](ps[0], ss[0], u, y, w)
    for i in range(1, len(fns)):
        fns[i](ps[i], ss[i], y, y, w)


_EMPTY = np.zeros((0, 0))


def padded_kernels(fns: tuple, params: tuple, states: tuple) -> tuple[tuple, tuple, tuple]:
    """A chain's kernels and their arguments padded with pass-through blocks to 1, 4, 8, …
    blocks: a compiled caller is specialised per number of blocks (≈ 40 s of compilation
    each for the platform's range kernels), and a pass-through block costs one copy of the
    rows per step (run_chain hands it y → y, bit for bit)."""
    ready(_pass_kernel)
    n = len(fns)
    m = 1 if n <= 1 else max(4, 1 << (n - 1).bit_length())
    pad = m - n
    return (fns + (_pass_kernel,) * pad, params + (_EMPTY,) * pad,
            states + (_EMPTY,) * pad)


class Chain:
    """Blocks applied in order (an actuator or sensor chain), callable on (K, n) arrays.

    ``fns``, ``params``, ``states``: the kernels and their argument tuples, for the compiled
    loop (an empty chain holds one pass-through kernel). At most one block may draw noise
    (its draws are the chain's ``w``).
    """

    def __init__(self, K: int, n: int, blocks: Sequence[Block]):
        self.K, self.n = int(K), int(n)
        self.blocks = list(blocks)
        noisy = [b for b in self.blocks if b.uses_noise]
        if len(noisy) > 1:
            raise ValueError("a chain takes at most one noise block")
        self.noise = noisy[0] if noisy else None
        if self.blocks:
            self.fns = tuple(type(b).kernel for b in self.blocks)
            self.params = tuple(b.params for b in self.blocks)
            self.states = tuple(b.state for b in self.blocks)
        else:
            self.fns, self.params, self.states = (ready(_pass_kernel),), (_EMPTY,), (_EMPTY,)
        self._y = np.zeros((self.K, self.n))
        self._w = np.zeros(self.K * self.n)

    @property
    def empty(self) -> bool:
        return not self.blocks

    def reset(self) -> None:
        for b in self.blocks:
            b.reset()

    def kernel_group(self) -> tuple:
        """The chain as a compiled kernel takes it: its blocks' kernels, parameters and
        states padded to a fixed count (:func:`padded_kernels`), the noise work array (R,)
        and whether the chain is empty."""
        return (*padded_kernels(self.fns, self.params, self.states), self._w, self.empty)

    def draw(self, out: np.ndarray) -> None:
        """Fill ``out`` (steps, R) with the noise draws of the next steps (if any)."""
        if self.noise is not None:
            self.noise.draw(out)

    def __call__(self, u: np.ndarray) -> np.ndarray:
        if not self.blocks:
            return u
        if self.noise is not None:
            self.noise.draw(self._w[None, :])
        # from Python: one direct call per block (passing the tuple of kernels to
        # run_chain costs its typing, ~0.5 ms, on every call; the compiled loop passes it
        # once per run)
        y = self._y.reshape(-1)
        x = np.ascontiguousarray(u).reshape(-1)
        for f, p, s in zip(self.fns, self.params, self.states, strict=True):
            f(p, s, x, y, self._w)
            x = y
        return self._y


@njit
def _run_signal(fns, ps, ss, u, y, w):
    for n in range(u.shape[0]):
        run_chain(fns, ps, ss, u[n], y[n], w[n % w.shape[0]])


def run_blocks(blocks: Sequence[Block], u: np.ndarray) -> np.ndarray:
    """Apply fresh blocks to a whole signal ``u`` ((N,) or (N, rows)), step by step, in
    one compiled call; returns the output signal of the same shape."""
    x = np.asarray(u, dtype=float)
    flat = x.reshape(len(x), -1)
    R = flat.shape[1]
    chain = Chain(1, R, blocks)
    chain.reset()
    w = np.zeros((1, R))
    if chain.noise is not None:
        w = np.empty((len(x), R))
        chain.draw(w)
    y = np.empty_like(flat)
    _run_signal(chain.fns, chain.params, chain.states, np.ascontiguousarray(flat), y, w)
    return y.reshape(x.shape)
