"""rths3d: virtual real-time hybrid substructure testing on a MuJoCo Stewart platform.

The package reads like the data flow: scene → numerical substructure ⇄ transfer system ⇄
experimental part → record → metrics → dataset → ANN; record + model → diagnosis. The
viewer (:mod:`rths3d.viz`) and the command line (:mod:`rths3d.cli`) sit beside the core and
are not imported here.

The names below are the small public API; each is imported on first use, so ``import
rths3d`` stays cheap (MuJoCo and torch load only when needed).

>>> import rths3d
>>> scene = rths3d.load_scene("scenes/paper_contact.toml")          # doctest: +SKIP
>>> result = rths3d.run(scene, transfer="stewart")                   # doctest: +SKIP
>>> rths3d.compute_measures(result.record)["e_rel_ref"]              # doctest: +SKIP
"""

from __future__ import annotations

import importlib
from typing import Any

from .errors import ConfigError, RecordError, RthsError, SafetyStop
from .record import DOFS, Record, RecordBuffer

__version__ = "0.1.0"

# public name → module that defines it (data flow order)
_LAZY: dict[str, str] = {
    # scene and loop
    "Scene": "rths3d.scene",
    "load_scene": "rths3d.scene",
    "run": "rths3d.loop",
    "run_batch": "rths3d.loop",
    "RunResult": "rths3d.loop",
    "LoopControl": "rths3d.loop",
    "reference_solution": "rths3d.reference",
    "LinearSubstructure": "rths3d.numerical",
    "interface_delay_margin": "rths3d.numerical",
    "build_transfer": "rths3d.transfer",
    # platform
    "StewartGeometry": "rths3d.platform",
    "ActuatorConfig": "rths3d.platform",
    "PlatformConfig": "rths3d.platform",
    "PlatformSim": "rths3d.platform",
    "PlatformBatch": "rths3d.platform",
    "track": "rths3d.platform",
    "load_heave_tf": "rths3d.platform",
    # metrics
    "compute_measures": "rths3d.metrics",
    "feature_row": "rths3d.metrics",
    "FEATURE_SETS": "rths3d.metrics",
    "j_criteria": "rths3d.metrics.criteria",
    # data and learning
    "load_spec": "rths3d.dataset",
    "run_sweep": "rths3d.dataset",
    "FidelityANN": "rths3d.ann",
    # diagnosis
    "Diagnosis": "rths3d.diagnose",
    "load_measurement": "rths3d.diagnose",
    # community benchmark
    "BenchmarkConfig": "rths3d.community",
    "run_case": "rths3d.community",
}

__all__ = [
    "DOFS",
    "ConfigError",
    "Record",
    "RecordBuffer",
    "RecordError",
    "RthsError",
    "SafetyStop",
    "__version__",
    *_LAZY,
]


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'rths3d' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
