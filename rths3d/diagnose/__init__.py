"""Model versus measurement: replay, localise residuals, find the missing physical effect.

Typical use::

    from rths3d.diagnose import Diagnosis, load_measurement
    rec, channels, warnings = load_measurement("bench_run.parquet")
    diag = Diagnosis(rec)          # the bench of the record's metadata
    result = diag.run()            # ranked candidates, verdict, confounded pairs
    if result.proposal:
        diag.add(result.proposal.effect)   # accept → refit → waterfall step
"""

from .bench import resolve_bench
from .engine import Candidate, Diagnosis, RoundResult, default_candidates
from .measurement import check_measurement, load_measurement
from .synth import hide_effects, measure

__all__ = ["Candidate", "Diagnosis", "RoundResult", "check_measurement", "default_candidates",
           "hide_effects", "load_measurement", "measure", "resolve_bench"]
