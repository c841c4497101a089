"""Moved to :mod:`rths3d.platform.calibrate.poses` (calibration and identification apart
from the simulation); this name still imports the same module, with a DeprecationWarning."""

import sys
import warnings

from .calibrate import poses as _moved

warnings.warn("rths3d.platform.pose_design moved to rths3d.platform.calibrate.poses",
              DeprecationWarning, stacklevel=2)
sys.modules[__name__] = _moved
