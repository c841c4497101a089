"""Is a record plausible in SI units? One place for the checks every reader of records uses.

A record written in mm instead of m, with time in ms instead of s, or forces in mN loads and
computes without complaint, and its measures come out wrong by factors of 1000 (a stroke of
5 m, 31 m/s, an FEI delay of 3 s, f_eq of 0.001 Hz). These checks compare a record's peaks
and its sampling interval with what any bench could produce. ``rths3d metrics``,
``predict`` and ``view`` print them as warnings; the diagnosis refuses such a record
(:func:`rths3d.diagnose.measurement.check_measurement`), since it fits physical parameters.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from .record import Record

TRANSLATION_LIMIT = 0.5
"""Largest plausible translation of a bench's interface or platform (m); more is usually mm."""
ROTATION_LIMIT = 1.0
"""Largest plausible rotation (rad, 57°); more is usually degrees."""
FORCE_LIMIT = 1e5
"""Largest plausible interface force (N); more is usually another unit (mN, or N·1000)."""
TORQUE_LIMIT = 1e4
"""Largest plausible interface torque (N·m)."""
LEG_FORCE_LIMIT = 1e6
"""Largest plausible actuator (leg) force (N)."""
LEG_LENGTH_LIMIT = 5.0
"""Largest plausible leg length of a bench's platform (m); more is usually mm."""
MAX_DT = 0.05
"""Longest plausible sampling interval of an RTHS record (s); a hybrid test runs its loop at
hundreds of Hz or more, so an interval of 1 usually means the time is in ms."""

_SIGNALS_M_RAD = ("z_cmd", "z_meas", "z_ref", "pose_cmd", "pose_meas")
_SIGNALS_N = ("f_meas", "f_ext")


def limit_of(column: str) -> tuple[float, str] | None:
    """The plausible limit of ``column``'s absolute value and its unit, or None (unchecked)."""
    signal, _, part = column.partition(".")
    rot = part.startswith("r")
    if signal in _SIGNALS_M_RAD:
        return (ROTATION_LIMIT, "rad") if rot else (TRANSLATION_LIMIT, "m")
    if signal in _SIGNALS_N:
        return (TORQUE_LIMIT, "N·m") if rot else (FORCE_LIMIT, "N")
    if signal == "fts":  # six-axis sensor channels fx fy fz tx ty tz
        return (TORQUE_LIMIT, "N·m") if part.startswith("t") else (FORCE_LIMIT, "N")
    if signal == "leg_force":
        return LEG_FORCE_LIMIT, "N"
    if signal == "leg_len":
        return LEG_LENGTH_LIMIT, "m"
    return None


def implausible(record: Record, columns: Iterable[str] | None = None) -> list[str]:
    """One line per implausible number of ``record``: a column beyond its limit (all
    checked columns, or only ``columns``) or a sampling interval beyond :data:`MAX_DT`.
    Each line names the column (or ``t``), the value and the limit. Empty: plausible."""
    out: list[str] = []
    if record.n > 1 and record.dt > MAX_DT:
        out.append(f"column 't' steps {record.dt:.6g} s per sample, beyond the plausible "
                   f"{MAX_DT:g} s of a hybrid test (time in ms? SI units expected)")
    names = record.columns if columns is None else [c for c in columns if c in record.columns]
    for name in names:
        lim = limit_of(name)
        if lim is None:
            continue
        limit, unit = lim
        x = record.columns[name]
        if not x.size:
            continue
        peak = float(np.max(np.abs(x)))
        if peak > limit:
            hint = {"m": "mm?", "rad": "degrees?"}.get(unit, "another unit?")
            out.append(f"column {name!r} reaches {peak:.6g} {unit}, beyond the plausible "
                       f"limit {limit:g} {unit} ({hint} SI units expected)")
    return out


__all__ = ["FORCE_LIMIT", "LEG_FORCE_LIMIT", "LEG_LENGTH_LIMIT", "MAX_DT", "ROTATION_LIMIT",
           "TORQUE_LIMIT", "TRANSLATION_LIMIT", "implausible", "limit_of"]
