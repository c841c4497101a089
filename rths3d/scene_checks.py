"""Moved to :mod:`rths3d.scene.checks` (the scene description's package); this name still
imports, with a DeprecationWarning."""

import warnings

from .scene.checks import *  # noqa: F403
from .scene.checks import __all__  # noqa: F401

warnings.warn("rths3d.scene_checks moved to rths3d.scene.checks", DeprecationWarning, stacklevel=2)
