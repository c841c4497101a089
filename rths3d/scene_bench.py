"""Moved to :mod:`rths3d.scene.bench` (the scene description's package); this name still
imports, with a DeprecationWarning."""

import warnings

from .scene.bench import *  # noqa: F403
from .scene.bench import __all__  # noqa: F401

warnings.warn("rths3d.scene_bench moved to rths3d.scene.bench", DeprecationWarning, stacklevel=2)
