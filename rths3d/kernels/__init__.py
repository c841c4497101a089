"""The compiled-kernel machinery of the package: numba's settings, kernels as first-class
functions, the signal-block chains, and the typing of the big range kernels' arguments.

- :mod:`~rths3d.kernels.compiler`: :data:`njit`, :data:`inline_njit`, :func:`block_kernel`,
  :func:`ready`, :func:`kernel_tuple` — how every per-step kernel is compiled and held;
- :mod:`~rths3d.kernels.chain`: :class:`Block`, :class:`Chain`, :func:`run_chain`,
  :func:`run_blocks` — the block machinery the effects' physics (:mod:`rths3d.effects.blocks`),
  the transfer systems' actuator and sensor chains and the platform's set-point chain run on;
- :mod:`~rths3d.kernels.layout`: :class:`AnyLayout` — one compiled specialisation per
  structure of a range kernel's arguments.

Nothing here knows a transfer system, a part or an effect: it is the bottom layer the
numerical substructure, the platform, the safety checks and the loop compile with.
"""

from .chain import Block, Chain, padded_kernels, run_blocks, run_chain
from .compiler import (
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
from .layout import AnyLayout, kernel_type

__all__ = ["BLOCK_SIG", "F1", "F2", "AnyLayout", "Block", "Chain", "KernelTuple", "block_kernel",
           "inline_njit", "kernel_tuple", "kernel_type", "njit", "padded_kernels", "ready",
           "run_blocks", "run_chain"]
