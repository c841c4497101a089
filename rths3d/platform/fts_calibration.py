"""Moved to :mod:`rths3d.platform.calibrate.fts` (calibration and identification apart
from the simulation); this name still imports the same module, with a DeprecationWarning."""

import sys
import warnings

from .calibrate import fts as _moved

warnings.warn("rths3d.platform.fts_calibration moved to rths3d.platform.calibrate.fts",
              DeprecationWarning, stacklevel=2)
sys.modules[__name__] = _moved
