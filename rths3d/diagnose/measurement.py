"""Measurements in: load a record file and check the channels the diagnosis needs.

A measurement is a record (:mod:`rths3d.record`, Parquet or CSV + ``.meta.json``) with the
commanded pose (``pose_cmd.<dof>`` of all six DOFs, or ``z_cmd.<dof>`` of the interface DOFs)
and measured channels, zeroed the way a bench zeroes them (docs/diagnosis.md): ``z_meas``
from the measured rest pose, ``f_meas`` and ``leg_force`` tared at rest, ``pose_meas``
absolute (relative to the nominal home), ``leg_len`` as the encoders read, ``fts`` zeroed
unloaded.
"""

from __future__ import annotations

import os
import warnings

import numpy as np

from ..effects import WRENCH
from ..errors import RecordError
from ..plausibility import implausible
from ..record import DOFS, Record

MEASURED: tuple[str, ...] = (
    *(f"z_meas.{d}" for d in DOFS), *(f"f_meas.{d}" for d in DOFS),
    *(f"pose_meas.{d}" for d in DOFS), *(f"leg_len.{i}" for i in range(6)),
    *(f"leg_force.{i}" for i in range(6)), *(f"fts.{c}" for c in WRENCH))
"""Every measured channel the diagnosis compares (when present and produced by the model)."""

MIN_DURATION = 1.0
"""Shortest measurement the diagnosis accepts (s): it needs training and validation blocks."""


def commands(rec: Record) -> tuple[str, ...]:
    """The command columns the replay uses: ``pose_cmd.*`` (all six) or ``z_cmd.*``."""
    if all(f"pose_cmd.{d}" in rec.columns for d in DOFS):
        return tuple(f"pose_cmd.{d}" for d in DOFS)
    return tuple(f"z_cmd.{d}" for d in DOFS if f"z_cmd.{d}" in rec.columns)


def check_measurement(rec: Record, source: str = "measurement") -> tuple[str, ...]:
    """Check a record for diagnosis; returns the measured channels present.

    Raises :class:`RecordError` naming the column, the value and the limit for a missing
    command, no measured channel, implausible units, a constant command or a record too short.
    """
    cmd = commands(rec)
    if not cmd:
        raise RecordError(f"{source}: missing command columns: need pose_cmd.<dof> (all six) "
                          "or z_cmd.<dof> (m, rad); the diagnosis replays them through the "
                          "bench")
    channels = tuple(c for c in MEASURED if c in rec.columns)
    if not channels:
        raise RecordError(f"{source}: no measured channel; expected some of z_meas.<dof>, "
                          "f_meas.<dof>, pose_meas.<dof>, leg_len.<i>, leg_force.<i>, "
                          "fts.<fx..tz>")
    if rec.duration < MIN_DURATION:
        raise RecordError(f"{source}: duration {rec.duration:.3g} s is too short "
                          f"(at least {MIN_DURATION:g} s needed)")
    # the model's parameters are fitted in SI units: an implausible record is refused
    issues = implausible(rec, (*cmd, *channels))
    if issues:
        raise RecordError(f"{source}: {issues[0]}")
    if all(np.ptp(rec.columns[c]) == 0.0 for c in cmd):
        raise RecordError(f"{source}: the command ({', '.join(cmd)}) is constant; nothing to "
                          "diagnose")
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
