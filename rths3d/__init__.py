"""rths3d: virtual real-time hybrid substructure testing on a MuJoCo Stewart platform.

The package reads like the data flow: scene → numerical substructure ⇄ transfer system ⇄
experimental part → record → metrics → dataset → ANN; record + model → diagnosis. The
viewer (:mod:`rths3d.viz`) and the command line (:mod:`rths3d.cli`) sit beside the core.
"""

from .errors import ConfigError, RecordError, RthsError, SafetyStop
from .record import DOFS, Record, RecordBuffer

__version__ = "0.1.0"

__all__ = [
    "DOFS",
    "ConfigError",
    "Record",
    "RecordBuffer",
    "RecordError",
    "RthsError",
    "SafetyStop",
    "__version__",
]
