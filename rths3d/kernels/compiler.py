"""The project's numba settings and the typing of compiled functions held by compiled loops.

:data:`njit` (on-disk cache, no GIL) and :data:`inline_njit` compile every per-step kernel of
the package; :func:`block_kernel` and :func:`ready` make a kernel of one fixed signature a
first-class function that a compiled caller can hold (the blocks of a chain, a part model, a
compensator); :func:`kernel_tuple` types a tuple of such kernels once per tuple rather than on
every call. :mod:`rths3d.kernels.layout` types the big range kernels' arguments;
:mod:`rths3d.kernels.chain` is the block machinery built on these.
"""

from __future__ import annotations

import threading
import warnings
from collections.abc import Sequence
from typing import Any

import numba
from numba import typeof, types
from numba.extending import typeof_impl

__all__ = ["BLOCK_SIG", "F1", "F2", "KernelTuple", "block_kernel", "inline_njit",
           "kernel_tuple", "njit", "ready"]

# chains call their blocks' kernels as first-class functions (one compiled caller for every
# sequence of blocks); numba still labels that feature experimental
warnings.filterwarnings("ignore", category=numba.NumbaExperimentalFeatureWarning)

njit = numba.njit(cache=True, nogil=True)
"""numba's compiler with the project's settings (on-disk cache, no GIL)."""
inline_njit = numba.njit(cache=True, nogil=True, inline="always")
"""The same for small per-step helpers, inlined into their compiled callers."""

F2 = types.float64[:, ::1]
F1 = types.float64[::1]
BLOCK_SIG = types.void(F2, F2, F1, F1, F1)
"""Signature of every block kernel: (params, state, u, y, w). Part models use the same
shape: (params, state, z_from, z_to, F)."""


def block_kernel(fn: Any) -> Any:
    """``fn`` as a block kernel, compiled for :data:`BLOCK_SIG` on first use
    (:func:`ready`): loading a compiled kernel from the on-disk cache costs ≈ 0.1 s, and
    importing the library (every command line call, every sweep worker) loaded all of them
    whether it stepped a block or not."""
    return numba.njit(cache=True, nogil=True)(fn)


_READY = threading.Lock()


def ready(kernel: Any, signature: Any = BLOCK_SIG) -> Any:
    """``kernel`` (a :func:`block_kernel`, or another kernel of one fixed signature)
    compiled for ``signature`` and closed to others, as a kernel with its signature given
    up front is: one machine code, a first-class function the compiled chains can hold.
    Every user of a kernel calls this first (a block's constructor does)."""
    if not kernel.signatures:
        # threads build blocks at once (the diagnosis' replays): one compiles, the others
        # find it compiled (compile() after disable_compile() raises)
        with _READY:
            if not kernel.signatures:
                kernel.compile(signature)
                kernel.disable_compile()
    return kernel


class KernelTuple(tuple):
    """Kernels of one signature handed to a compiled range loop, typed once per distinct
    tuple of kernels (:func:`kernel_tuple`). numba types a plain tuple of dispatchers as
    first-class functions by inspecting each kernel on every call of the loop (≈ 0.5 ms per
    call: 8 % of a 10 s one-DOF test); the type depends only on the kernels."""


_KERNEL_TYPES: dict[tuple, Any] = {}


@typeof_impl.register(KernelTuple)
def _typeof_kernel_tuple(val: KernelTuple, c: Any) -> Any:
    key = tuple(val)  # the kernels themselves (kept alive by the key)
    ty = _KERNEL_TYPES.get(key)
    if ty is None:
        ty = _KERNEL_TYPES[key] = typeof(tuple(val), c.purpose)
    return ty


def kernel_tuple(kernels: Sequence[Any]) -> KernelTuple:
    """``kernels`` (compiled for one signature, :func:`ready`) as the compiled loop's
    argument, typed once (:class:`KernelTuple`); a loop takes it as it takes a tuple."""
    return KernelTuple(kernels)
