"""Moved to :mod:`rths3d.platform.calibrate.kinematic` (calibration and identification apart
from the simulation); this name still imports the same module, with a DeprecationWarning."""

import sys
import warnings

from .calibrate import kinematic as _moved

warnings.warn("rths3d.platform.calibration moved to rths3d.platform.calibrate.kinematic",
              DeprecationWarning, stacklevel=2)
sys.modules[__name__] = _moved
