"""Records: the one thing that crosses from simulation (or a real bench) to analysis.

Schema (SI units throughout; documented for users who bring their own measurements):

``t``
    time in s, strictly increasing, uniformly sampled (a non-uniform record is resampled
    with a warning when loaded).
``<signal>.<dof>``
    one column per interface degree of freedom. Interface DOFs are named
    ``x, y, z`` (translations of the platform top, m) and ``rx, ry, rz`` (rotations about the
    MuJoCo world axes, rad). The interface signals are

    ============  ==========================================================  ==========
    ``z_cmd``     commanded interface displacement z (numerical output)        m or rad
    ``z_meas``    achieved (measured) interface displacement z'                m or rad
    ``f_meas``    measured restoring force F'_m of the experimental part       N or N·m
    ``f_ext``     external force on the numerical substructure F_ext^NUM       N or N·m
    ``z_ref``     reference interface displacement z^r                         m or rad
    ============  ==========================================================  ==========

    Sign convention: ``f_meas`` is the force the transfer system exerts on the experimental
    part (its restoring force), gravity preload removed; it enters the numerical substructure
    as ``M ẍ + C ẋ + K x = f_ext − Γ f_meas``. A positive ``f_meas`` resists a positive ``z``.
``pose_cmd.<dof>``, ``pose_meas.<dof>``
    commanded and measured 6-DOF platform pose relative to home (m, rad).
``leg_cmd.<i>``, ``leg_len.<i>``, ``leg_force.<i>``
    commanded and measured leg lengths (m) and actuator forces (N), i = 0…5.
``fts.<c>``
    raw force-torque sensor wrench, c in ``fx, fy, fz`` (N) and ``tx, ty, tz`` (N·m), in the
    sensor frame, as the sensor reports it (weight of the payload included).

A single-DOF record may use the bare names ``t, z_cmd, z_meas, f_meas, f_ext, z_ref``;
they are read as DOF ``z``. Metadata (scene, parameters, dt, versions, status and stop
reason) travel in the Parquet schema metadata, or in a ``<file>.meta.json`` beside a CSV.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import warnings
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .errors import RecordError

DOFS: tuple[str, ...] = ("x", "y", "z", "rx", "ry", "rz")
"""All interface DOF names, in platform order."""

INTERFACE_SIGNALS: tuple[str, ...] = ("z_cmd", "z_meas", "f_meas", "f_ext", "z_ref")
"""Per-DOF interface signals of a record."""

WRENCH_COMPONENTS: tuple[str, ...] = ("fx", "fy", "fz", "tx", "ty", "tz")

_META_KEY = b"rths3d"
MIN_SAMPLES = 8
"""Shortest record accepted (samples), except a stopped test's (meta ``status`` other than
``"ok"``), which may end at any sample: a saved partial record can always be read back."""


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


@dataclass
class Record:
    """A uniformly sampled record of one test.

    Parameters
    ----------
    t:
        Sample times (s), shape (N,).
    columns:
        Column name → 1-D array of length N (names as in the module docstring, without ``t``).
    meta:
        Free-form JSON-serialisable metadata.
    """

    t: np.ndarray
    columns: dict[str, np.ndarray]
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.t = np.asarray(self.t, dtype=float)
        n = self.t.shape[0]
        cols = {}
        for name, values in self.columns.items():
            arr = np.asarray(values, dtype=float).reshape(-1)
            if arr.shape[0] != n:
                raise RecordError(
                    f"column {name!r} has {arr.shape[0]} samples, t has {n}: all columns "
                    "must have the same length"
                )
            cols[_canonical(name)] = arr
        self.columns = cols

    # ------------------------------------------------------------------ access
    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.t.shape[0])

    @property
    def dt(self) -> float:
        """Sample interval (s)."""
        return float(self.t[1] - self.t[0]) if self.n > 1 else float("nan")

    @property
    def duration(self) -> float:
        """Duration covered by the samples (s)."""
        return float(self.t[-1] - self.t[0]) if self.n else 0.0

    @property
    def dofs(self) -> tuple[str, ...]:
        """Interface DOFs present, in platform order (from ``z_cmd`` or ``z_meas`` columns)."""
        found = set()
        for name in self.columns:
            sig, _, dof = name.partition(".")
            if sig in INTERFACE_SIGNALS and dof in DOFS:
                found.add(dof)
        return tuple(d for d in DOFS if d in found)

    def has(self, signal: str, dofs: Sequence[str] | None = None) -> bool:
        """True if ``signal`` exists for every DOF in ``dofs`` (default: all record DOFs)."""
        dofs = self.dofs if dofs is None else dofs
        return bool(dofs) and all(f"{signal}.{d}" in self.columns for d in dofs)

    def signal(self, signal: str, dofs: Sequence[str] | None = None) -> np.ndarray:
        """Interface signal as an (N, ndof) array, columns in ``dofs`` order."""
        dofs = self.dofs if dofs is None else tuple(dofs)
        missing = [f"{signal}.{d}" for d in dofs if f"{signal}.{d}" not in self.columns]
        if missing:
            raise RecordError(f"record has no column {missing[0]!r} (columns: "
                              f"{', '.join(sorted(self.columns)) or 'none'})")
        return np.column_stack([self.columns[f"{signal}.{d}"] for d in dofs])

    def group(self, prefix: str) -> dict[str, np.ndarray]:
        """All columns ``prefix.<suffix>`` as suffix → array (e.g. ``group('leg_len')``)."""
        p = prefix + "."
        return {k[len(p):]: v for k, v in self.columns.items() if k.startswith(p)}

    def slice(self, start: int, stop: int) -> Record:
        """Samples ``start:stop`` as a new record (metadata shared)."""
        return Record(self.t[start:stop], {k: v[start:stop] for k, v in self.columns.items()},
                      dict(self.meta))

    # ------------------------------------------------------------------ I/O
    def to_frame(self):  # -> pandas.DataFrame
        import pandas as pd

        data = {"t": self.t}
        data.update(self.columns)
        return pd.DataFrame(data)

    def save(self, path: str | os.PathLike, *, bare: bool = False) -> Path:
        """Write the record atomically as Parquet (``.parquet``) or CSV (``.csv``).

        ``bare=True`` writes a single-DOF record with the bare column names.
        """
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        frame = self.to_frame()
        if bare:
            if len(self.dofs) != 1:
                raise RecordError("bare column names need a single-DOF record")
            d = self.dofs[0]
            frame = frame.rename(columns={f"{s}.{d}": s for s in INTERFACE_SIGNALS})
        meta = json.dumps(self.meta, default=_json_default)
        tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
        suffix = path.suffix.lower()
        if suffix not in (".parquet", ".csv"):
            raise RecordError(f"record file {str(path)!r}: unknown format {suffix!r} "
                              "(use .parquet or .csv)")
        side = path.with_name(path.name + ".meta.json")
        side_tmp = side.with_name(f".{side.name}.tmp{os.getpid()}")
        try:
            if suffix == ".parquet":
                import pyarrow as pa
                import pyarrow.parquet as pq

                table = pa.Table.from_pandas(frame, preserve_index=False)
                md = dict(table.schema.metadata or {})
                md[_META_KEY] = meta.encode()
                pq.write_table(table.replace_schema_metadata(md), tmp)
            else:
                frame.to_csv(tmp, index=False, float_format="%.17g")
                side_tmp.write_text(meta)
                os.replace(side_tmp, side)
            os.replace(tmp, path)
        except BaseException:
            # a failed write (disk full, folder gone) leaves no partial file behind
            for t in (tmp, side_tmp):
                with contextlib.suppress(OSError):
                    t.unlink(missing_ok=True)
            raise
        return path

    @classmethod
    def load(cls, path: str | os.PathLike, *, resample: bool = True) -> Record:
        """Read a Parquet or CSV record and check it against the schema.

        Raises :class:`RecordError` naming the file, column and row for a missing ``t``,
        NaNs, non-increasing time or a record shorter than ``MIN_SAMPLES`` (unless its
        metadata says it stopped: ``status`` other than ``"ok"``). A non-uniform
        time base is resampled (linear interpolation) with a warning unless
        ``resample=False``, in which case it is an error.
        """
        path = Path(path)
        if not path.exists():
            raise RecordError(f"record file {str(path)!r} does not exist")
        if path.is_dir():
            raise RecordError(f"record file {str(path)!r} is a folder, not a record file "
                              "(.parquet or .csv)")
        suffix = path.suffix.lower()
        meta: dict[str, Any] = {}
        try:
            if suffix == ".parquet":
                import pyarrow.parquet as pq

                table = pq.read_table(path)
                raw = (table.schema.metadata or {}).get(_META_KEY)
                if raw:
                    meta = json.loads(raw)
                frame = table.to_pandas()
            elif suffix == ".csv":
                import pandas as pd

                frame = pd.read_csv(path)
                side = path.with_name(path.name + ".meta.json")
                if side.exists():
                    meta = json.loads(side.read_text())
            else:
                raise RecordError(f"record file {str(path)!r}: unknown format {suffix!r} "
                                  "(use .parquet or .csv)")
        except RecordError:
            raise
        except Exception as exc:  # unreadable file: say which and why, no traceback
            raise RecordError(f"record file {str(path)!r} could not be read: {exc}") from exc
        return cls.from_columns(
            {str(k): frame[k].to_numpy() for k in frame.columns}, meta, source=str(path),
            resample=resample,
        )

    @classmethod
    def from_columns(cls, data: Mapping[str, Iterable[float]], meta: dict | None = None, *,
                     source: str = "record", resample: bool = True) -> Record:
        """Build a checked record from a mapping of column name → values (``t`` included)."""
        if "t" not in data:
            raise RecordError(f"{source}: missing column 't' (time in s)")
        cols: dict[str, np.ndarray] = {}
        for name, values in data.items():
            try:
                arr = np.asarray(values, dtype=float).reshape(-1)
            except (TypeError, ValueError) as exc:
                raise RecordError(f"{source}: column {name!r} is not numeric") from exc
            bad = np.flatnonzero(~np.isfinite(arr))
            if bad.size:
                raise RecordError(f"{source}: column {name!r} has {bad.size} NaN/inf "
                                  f"value(s), first at row {int(bad[0])}")
            cols[name] = arr
        t = cols.pop("t")
        # a test stopped early (its partial record saved) may be shorter
        stopped = isinstance(meta, Mapping) and meta.get("status", "ok") != "ok"
        if t.size < (1 if stopped else MIN_SAMPLES):
            raise RecordError(f"{source}: {t.size} samples is too short "
                              f"(at least {MIN_SAMPLES} needed)")
        steps = np.diff(t)
        if np.any(steps <= 0):
            row = int(np.flatnonzero(steps <= 0)[0]) + 1
            raise RecordError(f"{source}: column 't' is not strictly increasing at row {row}")
        dt = float(np.median(steps)) if steps.size else 0.0
        if steps.size and np.max(np.abs(steps - dt)) > 1e-6 * max(dt, 1e-12) + 1e-9:
            if not resample:
                raise RecordError(f"{source}: non-uniform sampling (steps from "
                                  f"{steps.min():.6g} s to {steps.max():.6g} s)")
            n = int(math.floor((t[-1] - t[0]) / dt + 1e-9)) + 1
            t_new = t[0] + dt * np.arange(n)
            warnings.warn(f"{source}: non-uniform sampling (steps {steps.min():.6g}–"
                          f"{steps.max():.6g} s) resampled to dt = {dt:.6g} s", stacklevel=2)
            cols = {k: np.interp(t_new, t, v) for k, v in cols.items()}
            t = t_new
        rec = cls(t, cols, dict(meta or {}))
        if not rec.dofs:
            raise RecordError(f"{source}: no interface columns found (expected e.g. "
                              "'z_cmd.z' and 'z_meas.z', or bare 'z_cmd' and 'z_meas')")
        return rec


def _canonical(name: str) -> str:
    """Map bare single-DOF names (``z_cmd``) to ``z_cmd.z``."""
    return f"{name}.z" if name in INTERFACE_SIGNALS else name


class RecordBuffer:
    """Preallocated, append-only sample buffer written by the loop, read by observers.

    The loop writes row ``k`` of ``data`` and then sets ``n = k + 1``; a reader (the live
    viewer, in another thread) only ever reads ``data[:n]``. No allocation happens per step.
    """

    def __init__(self, columns: Sequence[str], capacity: int, meta: dict | None = None):
        if columns[0] != "t":
            raise ValueError("the first buffer column must be 't'")
        self.columns: tuple[str, ...] = tuple(columns)
        self.index: dict[str, int] = {c: i for i, c in enumerate(self.columns)}
        self.data = np.zeros((int(capacity), len(self.columns)))
        self.n = 0
        self.meta: dict[str, Any] = dict(meta or {})

    def to_record(self) -> Record:
        """The samples written so far as a :class:`Record` (copies)."""
        d = self.data[: self.n]
        return Record(d[:, 0].copy(), {c: d[:, i].copy() for i, c in
                                       enumerate(self.columns) if i}, dict(self.meta))
