"""Training data at scale: sweep specs → batches on local cores or Dask → one Parquet table.

:func:`load_spec` reads a sweep (TOML), :func:`run_sweep` runs it resumably; see
:mod:`.table` for the columns and the paper's feature sets.
"""

from .execute import batches_of, run_sweep
from .spec import Family, SweepSpec, enumerate_tests, load_spec, parse_spec
from .store import join_tables, read_table
from .table import (
    FEATURE_SETS,
    feature_names,
    parse_feature_sets,
    parse_features,
    parse_ratings,
    training_data,
    within_ratings,
)

__all__ = ["FEATURE_SETS", "Family", "SweepSpec", "batches_of", "enumerate_tests",
           "feature_names", "join_tables", "load_spec", "parse_feature_sets", "parse_features",
           "parse_spec", "parse_ratings", "read_table", "run_sweep", "training_data",
           "within_ratings"]
