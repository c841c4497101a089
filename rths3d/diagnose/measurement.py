"""Measurements in: load a record file and check the channels the diagnosis needs."""

from __future__ import annotations

import os
import warnings

import numpy as np

from ..effects.library import OUTPUTS
from ..errors import RecordError
from ..plausibility import implausible
from ..record import Record

COMMAND = "z_cmd.z"
"""Commanded interface displacement (m): the input replayed through the model."""

MIN_DURATION = 1.0
"""Shortest measurement the diagnosis accepts (s): it needs training and validation blocks."""


def check_measurement(rec: Record, source: str = "measurement") -> tuple[str, ...]:
    """Check a record for diagnosis; returns the measured output channels present.

    Raises :class:`RecordError` naming the column, the value and the limit for a missing
    command, no measured channel, implausible units, a constant channel or a record too short.
    """
    if COMMAND not in rec.columns:
        raise RecordError(f"{source}: missing column {COMMAND!r} (commanded displacement, m); "
                          "the diagnosis replays it through the model")
    channels = tuple(c for c in OUTPUTS if c in rec.columns)
    if not channels:
        raise RecordError(f"{source}: no measured channel; expected at least one of "
                          + ", ".join(OUTPUTS))
    if rec.duration < MIN_DURATION:
        raise RecordError(f"{source}: duration {rec.duration:.3g} s is too short "
                          f"(at least {MIN_DURATION:g} s needed)")
    # the model's parameters are fitted in SI units: an implausible record is refused
    issues = implausible(rec, (COMMAND, *channels))
    if issues:
        raise RecordError(f"{source}: {issues[0]}")
    for name in (COMMAND, "z_meas.z"):
        x = rec.columns.get(name)
        if x is not None and np.ptp(x) == 0.0:
            raise RecordError(f"{source}: column {name!r} is constant ({x[0]:.6g} m); "
                              "nothing to diagnose")
    return channels


def load_measurement(path: str | os.PathLike) -> tuple[Record, tuple[str, ...], list[str]]:
    """Load and check a measurement file (Parquet or CSV in the record schema).

    Returns (record, measured channels, warnings raised while loading, e.g. resampling).
    """
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rec = Record.load(path)
    channels = check_measurement(rec, str(path))
    return rec, channels, [str(w.message) for w in caught]
