"""Model versus measurement: replay, localise residuals, find the missing physical effect.

Typical use::

    from rths3d.diagnose import Diagnosis, load_measurement
    rec, channels, warnings = load_measurement("bench_run.parquet")
    diag = Diagnosis(rec)
    result = diag.run()            # ranked candidates, noise_only, confounded pairs
    if result.proposal:
        diag.add(result.proposal.effect)   # accept → refit → waterfall step
"""

from .bench import BenchConfig, BenchModel, load_bench, resolve_scene
from .engine import Candidate, Diagnosis, RoundResult
from .measurement import check_measurement, load_measurement
from .stewart import StewartBenchModel, make_model
from .synth import multisine, synthetic_measurement

__all__ = ["BenchConfig", "BenchModel", "load_bench", "resolve_scene", "StewartBenchModel",
           "make_model", "Candidate", "Diagnosis", "RoundResult",
           "check_measurement", "load_measurement", "multisine", "synthetic_measurement"]
