"""Calling the big range kernels through few compiled specialisations.

numba compiles one machine-code specialisation per exact argument type, and an array's type
includes its layout (C-contiguous or any) and whether it is read-only. The range kernels of
the platform (:func:`rths3d.platform.compiled.run_range`,
:func:`rths3d.platform.closed.closed_range`) take some sixty arrays in nested tuples, views
whose flags depend on the batch and the caller: a (K, n) column view is strided for K > 1 but
flagged contiguous for K = 1 (NumPy ignores the stride of a length-1 axis), an (N, K, ·)
series is strided when a thread steps a chunk of the tests and contiguous when it steps them
all, a broadcast command series is read-only. Each combination cost a fresh specialisation of
≈ 40 s of compilation on a cold cache; a user's first runs and a clean CI run paid it about
ten times per kernel.

:class:`AnyLayout` types the arguments so that those views share one specialisation per
*structure* of the arguments (how many blocks a chain holds, which optional groups are
present): every array is typed writable and of any layout, except in a group of compiled
functions and their arguments (a chain's block kernels with their parameter and state
arrays, whose compiled signatures want contiguous arrays; those are contiguous by
construction and keep their types). A kernel that needs a contiguous array's rows as one
vector takes them with :func:`rths3d.platform.compiled.flat`, which checks the strides.
An any-layout index costs a stride multiplication, which these kernels, dominated by
MuJoCo's step, do not notice (``benchmarks/platform_loop.py``, ``benchmarks/vrths_loop.py``).
Read-only arrays (a broadcast command series) are typed writable too: numba no longer
guards them, so a range kernel must not write its inputs; the kernels of this project were
compiled with those arrays read-only before they were called this way, which proves they
do not.
"""

from __future__ import annotations

from typing import Any

from numba import typeof, types

__all__ = ["AnyLayout", "kernel_type"]


def _is_function(t: types.Type) -> bool:
    return isinstance(t, types.FunctionType | types.Dispatcher)


def _calls_functions(t: types.BaseTuple) -> bool:
    """Whether the tuple type ``t`` is a group of compiled functions and their arguments
    (a chain: its kernels, or a tuple of them, beside their parameter and state arrays)."""
    return any(_is_function(x) or (isinstance(x, types.BaseTuple) and len(x.types) > 0
                                   and all(_is_function(y) for y in x.types))
               for x in t.types)


def kernel_type(t: types.Type) -> types.Type:
    """The numba type :class:`AnyLayout` compiles an argument of type ``t`` as (module
    docstring)."""
    if isinstance(t, types.Array):
        return t.copy(layout="A", readonly=False)
    if isinstance(t, types.BaseTuple) and not isinstance(t, types.BaseNamedTuple):
        if _calls_functions(t):  # arguments of compiled signatures: as they are
            return t
        return types.BaseTuple.from_types([kernel_type(x) for x in t.types])
    return t


class AnyLayout:
    """A numba dispatcher called through :func:`kernel_type` signatures (module docstring).

    ``entry(*args)`` is the compiled function for the arguments' structure (compiled, or
    loaded from the on-disk cache, on first use); calling the object is
    ``entry(*args)(*args)``. Callers that call often with arguments of one structure keep
    the entry and call it directly (typing the arguments costs tens of µs)."""

    def __init__(self, dispatcher: Any):
        self.dispatcher = dispatcher
        self._entries: dict[tuple, Any] = {}
        self.__doc__ = dispatcher.__doc__
        self.__name__ = dispatcher.__name__

    def entry(self, *args: Any) -> Any:
        sig = tuple(kernel_type(typeof(a)) for a in args)
        fn = self._entries.get(sig)
        if fn is None:
            fn = self._entries[sig] = self.dispatcher.compile(sig)
        return fn

    def __call__(self, *args: Any) -> Any:
        return self.entry(*args)(*args)
