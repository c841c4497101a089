"""Moved to :mod:`rths3d.community` (the community benchmark problems; "bench" names the
physical bench, :mod:`rths3d.bench`). This name and its submodules still import, with a
DeprecationWarning."""

import importlib
import sys
import warnings

from ..community import *  # noqa: F403
from ..community import __all__  # noqa: F401

_SUBMODULES = ("compensated", "config", "kernels", "marths", "marths.calibration",
               "marths.criteria", "marths.data", "marths.engine", "marths.kernels",
               "marths.model", "marths.opensees_frame", "marths.plant", "marths.plots",
               "marths.stewart", "marths.summary", "plant", "plots", "published", "scene",
               "simulate", "stability", "structure")

for _name in _SUBMODULES:
    sys.modules[f"{__name__}.{_name}"] = importlib.import_module(f"rths3d.community.{_name}")
from ..community import marths  # noqa: E402, F401

warnings.warn("rths3d.rthsbench moved to rths3d.community", DeprecationWarning, stacklevel=2)
