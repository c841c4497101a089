"""Surrogate reference: the experimental part identified from the test's own record.

See :mod:`.estimator` for the procedure, :mod:`.base` for the model classes' common form,
:mod:`.running` for the per-step running RMS, :mod:`.online` for ẑ^r one step at a time.
"""

from .arx import ARX
from .base import LagModel, LagPart, Switch
from .estimator import (
    CANDIDATES,
    Identification,
    SurrogateConfig,
    SurrogateReference,
    fidelity_columns,
    identify,
    surrogate_reference,
)
from .online import OnlineReference
from .running import WINDOW, RunningRMS, running_rms
from .switched import SwitchedARX

__all__ = ["ARX", "CANDIDATES", "Identification", "LagModel", "LagPart", "OnlineReference",
           "RunningRMS",
           "SurrogateConfig", "SurrogateReference", "Switch", "SwitchedARX", "WINDOW",
           "fidelity_columns", "identify", "running_rms", "surrogate_reference"]
