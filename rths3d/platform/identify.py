"""Moved to :mod:`rths3d.platform.calibrate.heave` (calibration and identification apart
from the simulation); this name still imports the same module, with a DeprecationWarning."""

import sys
import warnings

from .calibrate import heave as _moved

warnings.warn("rths3d.platform.identify moved to rths3d.platform.calibrate.heave",
              DeprecationWarning, stacklevel=2)
sys.modules[__name__] = _moved
