"""Moved to :mod:`rths3d.kernels.layout` (the compiled-kernel machinery's package); this name
still imports, with a DeprecationWarning."""

import warnings

from .kernels.layout import AnyLayout, kernel_type

__all__ = ["AnyLayout", "kernel_type"]

warnings.warn("rths3d.jit moved to rths3d.kernels.layout (or import from rths3d.kernels)",
              DeprecationWarning, stacklevel=2)
