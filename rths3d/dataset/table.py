"""The sweep table's columns, and the paper's three feature sets (Table 3).

Column families of a sweep table (one row per test):

``test_id``, ``family``, ``scene``, ``transfer``, ``seed``
    identity of the test.
``status``, ``reason``
    ``ok`` or ``stopped`` (unstable / out of limits, with the reason) or ``error``.
``param.<dotted key>``
    the swept scene and transfer-system settings (SI units, as in the scene TOML).
``feature.<name>``
    indicators available without a reference solution (Table 3 rows; names from
    :func:`rths3d.metrics.feature_row`) and the surrogate inputs ``e_rel_ref_hat``,
    ``e_rel_ref_hat_std``, ``surrogate_validation`` (:mod:`rths3d.metrics.fidelity`).
``target.<name>``
    reference errors (need the reference solution): ``e_rel_ref`` (the ANN target,
    eq. 1 with z^r), ``e_mre_ref``, ``e_peak_ref``, ``e_rel_ref_f``.
``measure.<name>``
    every other measure of the record, among them the other surrogate estimates
    (``e_mre_ref_hat``, ``e_peak_ref_hat``, ``e_rel_ref_f_hat``, ``surrogate_members``) and
    the bench load ``stroke_peak`` (m),
    ``velocity_peak`` (m/s) and ``force_peak`` (N) that :func:`within_ratings` compares
    with a bench's ratings.
``comp_name``, ``comp_mode``, ``comp_<coef>_final``, ``comp_<coef>_final.<channel>``
    the test's compensator (``transfer.compensation``), where it acted (``interface`` or
    ``legs``) and its coefficients at the end of the test (at its stop, for a stopped
    one) per channel (interface DOF or ``leg0``…``leg5``) and as the mean over the channels
    (units of the coefficient: ATS a1 in s, a2 in s², RLS lead in s, …; see
    docs/compensation.md). NaN where a compensator has no such coefficient.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..errors import ConfigError
from ..metrics.features import FEATURE_SETS, SET_1, SET_2, SET_3, TARGETS
from ..metrics.features import feature_names as _feature_names

FEATURE = "feature."
TARGET = "target."
PARAM = "param."
MEASURE = "measure."
RATINGS: dict[str, tuple[str, str]] = {
    "stroke": ("stroke_peak", "m"), "velocity": ("velocity_peak", "m/s"),
    "force": ("force_peak", "N"),
}
"""Bench rating → (bench-load measure it bounds, unit); the names of :class:`SafetyLimits`."""
DEFAULT_TARGET = "e_rel_ref"
COMP = "comp_"
__all__ = ["COMP", "DEFAULT_TARGET", "FEATURE", "FEATURE_SETS", "PARAM", "SET_1", "SET_2",
           "SET_3", "TARGET", "TARGETS", "compensator_columns", "feature_names", "has_params",
           "input_column", "param_column", "parse_features", "parse_ratings", "training_data",
           "within_ratings"]


def parse_feature_sets(text: str, field: str = "--features") -> tuple[int, ...]:
    """``'1,3'`` → ``(1, 3)``: Table-3 feature sets, each once, in the order given; a
    ConfigError naming ``field`` for anything else."""
    try:
        sets = tuple(dict.fromkeys(int(v) for v in text.split(",") if v.strip()))
    except ValueError:
        sets = ()
    if not sets or not set(sets) <= set(FEATURE_SETS):
        raise ConfigError(field, text, "comma-separated feature sets 1, 2, 3")
    return sets


def feature_names(feature_set: int | Sequence[str]) -> tuple[str, ...]:
    """Feature names of Table-3 set 1, 2 or 3, or a subset of Table 3 given by name (an
    error names the ``features`` option)."""
    return _feature_names(feature_set, field="features")


def parse_features(text: str, field: str = "--features") -> int | tuple[str, ...]:
    """``'2'`` → ``2`` (a Table-3 set); ``'e_rel_track,zeta'`` → those features, in the
    order given; a set number or ``surrogate`` inside a list expands to its names
    (``'2,surrogate'``: set 2 and the surrogate inputs, a physics-informed set); a
    ConfigError naming ``field`` for anything else."""
    from ..metrics.features import SURROGATE

    text = text.strip()
    if text.isdigit():
        _feature_names(int(text), field=field)  # 1, 2 or 3, else the error
        return int(text)
    names: list[str] = []
    for tok in (n.strip() for n in text.split(",")):
        if not tok:
            continue
        if tok.isdigit():
            names += _feature_names(int(tok), field=field)
        elif tok == "surrogate":
            names += SURROGATE
        else:
            names.append(tok)
    return _feature_names(names, field=field)


def compensator_columns(record: Any) -> dict[str, Any]:
    """The compensator columns of a test's row (module docstring) from its record: the
    name and mode from ``meta["transfer_meta"]["compensator"]`` (else the scene
    parameters), the final coefficients from the last sample of its ``comp.<coef>.<channel>``
    columns."""
    meta = record.meta or {}
    cm = (meta.get("transfer_meta") or {}).get("compensator") or {}
    params = meta.get("params") or {}
    out: dict[str, Any] = {
        COMP + "name": str(cm.get("name", params.get("transfer.compensation", "none"))),
        COMP + "mode": str(cm.get("compensate", params.get("transfer.compensate",
                                                            "interface")))}
    per: dict[str, list[float]] = {}
    for col, values in record.columns.items():
        if not col.startswith("comp.") or not len(values):
            continue
        coef, _, channel = col[5:].partition(".")
        v = float(values[-1])
        v = v if math.isfinite(v) else math.nan
        out[f"{COMP}{coef}_final.{channel}"] = v
        per.setdefault(coef, []).append(v)
    for coef, vs in per.items():
        out[f"{COMP}{coef}_final"] = float(np.mean(vs))
    return out


def param_column(name: str) -> str:
    """Table column of a test parameter: ``experiment.h0`` → ``param.experiment.h0``."""
    return name if name.startswith(PARAM) else PARAM + name


def has_params(frame: Any, names: Sequence[str]) -> bool:
    """Whether a sweep table holds every named test parameter (``experiment.h0`` or
    ``param.experiment.h0``)."""
    return all(param_column(n) in frame.columns for n in names)


def input_column(name: str) -> str:
    """Table column of a model input: a measure ``e_rel_track`` → ``feature.e_rel_track``; a
    test parameter keeps its column name (``param.experiment.h0``)."""
    return name if name.startswith(PARAM) else FEATURE + name


def training_data(frame: Any, feature_set: int | Sequence[str], target: str = DEFAULT_TARGET,
                  families: list[str] | None = None, exclude: list[str] | None = None,
                  extra: Sequence[str] = ()) -> tuple[Any, np.ndarray, Any]:
    """Features X (DataFrame, columns = feature names), target y and the kept rows.

    ``feature_set``: a Table-3 set (1, 2, 3) or a list of Table-3 feature names.

    Keeps tests with status ``ok`` and finite features and target; optionally only the
    given families or all but the excluded ones. ``extra`` adds test parameters known before
    the test as inputs beyond the Table-3 set, e.g. ``experiment.h0`` (the contact gap, m):
    their X columns keep the table's name (``param.experiment.h0``).
    """
    from pandas.api.types import is_bool_dtype, is_numeric_dtype

    names = list(feature_names(feature_set))
    for e in extra:
        p = param_column(e)
        if p not in frame.columns:
            have = [c.removeprefix(PARAM) for c in frame.columns if c.startswith(PARAM)]
            raise ConfigError("extra", e, "not a parameter column of this table (it has: "
                              f"{', '.join(have) or 'none'})")
        if not (is_numeric_dtype(frame[p]) or is_bool_dtype(frame[p])):
            raise ConfigError("extra", e, "must be a numeric parameter (an input of the net)")
        if p not in names:
            names.append(p)
    cols = [input_column(n) for n in names]
    missing = [c for c in cols + [TARGET + target] if c not in frame.columns]
    if missing:
        raise ConfigError("table", missing[0], "column missing (is this a sweep table?)")
    rows = frame
    if "status" in rows.columns:
        rows = rows[rows["status"] == "ok"]
    for field, value in (("--family", families), ("--exclude", exclude)):
        if value and "family" not in rows.columns:
            raise ConfigError(field, value[0] if len(value) == 1 else list(value),
                              "table has no 'family' column")
    if families:
        known = set(frame["family"].astype(str))  # the table's, finished tests or not
        unknown = [f for f in families if f not in known]
        if unknown:
            raise ConfigError("--family", unknown[0], "no such family in the table (families: "
                              f"{', '.join(sorted(known))})")
        rows = rows[rows["family"].isin(families)]
    if exclude:
        rows = rows[~rows["family"].isin(exclude)]
    x = rows[cols].to_numpy(dtype=float)
    y = rows[TARGET + target].to_numpy(dtype=float)
    ok = np.isfinite(x).all(axis=1) & np.isfinite(y)
    rows = rows[ok]
    X = rows[cols].copy()
    X.columns = names
    return X, y[ok], rows


def parse_ratings(text: str, field: str = "--ratings") -> dict[str, float]:
    """``'velocity=0.2,force=200'`` → ``{"velocity": 0.2, "force": 200.0}`` (SI: m, m/s, N);
    a ConfigError naming ``field`` for an unknown rating or a value that is not > 0."""
    out: dict[str, float] = {}
    for item in (v.strip() for v in text.split(",")):
        if not item:
            continue
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep or name not in RATINGS:
            raise ConfigError(field, item, "expected NAME=VALUE with NAME one of "
                              f"{', '.join(RATINGS)} (e.g. velocity=0.2 for 0.2 m/s)")
        try:
            v = float(value)
        except ValueError:
            v = math.nan
        if not (math.isfinite(v) and v > 0):
            raise ConfigError(f"{field} {name}", value.strip(),
                              f"must be a number > 0 ({RATINGS[name][1]})")
        out[name] = v
    if not out:
        raise ConfigError(field, text, "give at least one of "
                          f"{', '.join(f'{k}=VALUE' for k in RATINGS)}")
    return out


def within_ratings(frame: Any, ratings: dict[str, float]) -> Any:
    """The rows whose bench load stays within every rating: the tests a bench with these
    ratings would have run to the end (the paper's condition on its tests: "the maximum force
    of the used FTS was not exceeded and [...] the tests stayed within the limits of actuator
    stroke and maximum velocity").

    ``ratings`` maps ``stroke`` (m), ``velocity`` (m/s) and ``force`` (N) to limits, as
    :func:`parse_ratings` returns them; a row passes when ``measure.<name>_peak`` ≤ the
    rating (a test without the measure, e.g. one stopped at its first sample, does not). A
    multi-DOF row holds its dominant DOF's peaks (see :func:`rths3d.compute_measures`).
    A table swept, or partly swept, before these measures existed raises a ConfigError that
    says so, rather than silently dropping its older tests.
    """
    keep = np.ones(len(frame), dtype=bool)
    # without a status column every row counts as finished
    finished = ((frame["status"] == "ok").to_numpy() if "status" in frame.columns
                else np.ones(len(frame), dtype=bool))
    for name, limit in ratings.items():
        if name not in RATINGS:
            raise ConfigError("ratings", name, f"one of {', '.join(RATINGS)}")
        col = MEASURE + RATINGS[name][0]
        again = "sweep it again into a new folder"
        if col not in frame.columns:
            raise ConfigError("ratings", name, f"the table has no {col!r} column (swept "
                              f"before the bench-load measures existed: {again})")
        peak = frame[col].to_numpy(dtype=float)
        n_old = int((finished & np.isnan(peak)).sum())
        if n_old:
            raise ConfigError("ratings", name, f"{n_old} finished tests have no {col!r} "
                              f"(resumed from a sweep older than the bench-load measures: "
                              f"{again})")
        keep &= peak <= limit
    return frame[keep]
