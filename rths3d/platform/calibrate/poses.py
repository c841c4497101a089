"""Pose tables and pose selection for a kinematic calibration
(:class:`~rths3d.platform.calibrate.kinematic.KinematicCalibration`): :func:`load_pose_table` reads
measured poses and encoder lengths from a file, :func:`select_poses` plans the poses that
identify the 42 parameters best."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ...errors import ConfigError
from ..geometry import StewartGeometry
from .kinematic import DOFS, N_PARAMETERS, _check_data, identification_jacobian

__all__ = ["load_pose_table", "select_poses"]


def load_pose_table(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray]:
    """Measured poses (N, 6) and encoder lengths (N, 6) from a CSV or Parquet file.

    Columns ``pose_meas.x`` … ``pose_meas.rz`` (absolute measured pose relative to home, m
    and rad) and ``leg_len.0`` … ``leg_len.5`` (encoder lengths, m); other columns (a
    ``rths3d`` record's) are ignored. Raises :class:`ConfigError` naming the file, the column
    and the row of the first problem.
    """
    import pandas as pd

    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in (".csv", ".parquet"):
        raise ConfigError(str(p), suffix or "no suffix", "must be a .csv or .parquet file")
    if not p.is_file():
        raise ConfigError(str(p), None, "", message=f"{p}: no such file")
    try:
        frame = pd.read_csv(p) if suffix == ".csv" else pd.read_parquet(p)
    except Exception as exc:  # pandas/pyarrow raise many types for a malformed file
        msg = " ".join(str(exc).split())[:200]
        raise ConfigError(str(p), None, "", message=f"{p}: unreadable: {msg}") from None
    cols = [f"pose_meas.{d}" for d in DOFS] + [f"leg_len.{i}" for i in range(6)]
    missing = [c for c in cols if c not in frame.columns]
    if missing:
        raise ConfigError(f"{p}: column {missing[0]}", None, "", message=(
            f"{p}: column {missing[0]!r} missing (need pose_meas.x … pose_meas.rz in m/rad "
            "and leg_len.0 … leg_len.5 in m)"))
    data = np.empty((len(frame), 12))
    for j, c in enumerate(cols):
        v = pd.to_numeric(frame[c], errors="coerce").to_numpy(dtype=float)
        bad = np.flatnonzero(~np.isfinite(v) | ((v <= 0) if c.startswith("leg_len") else False))
        if bad.size:
            k = int(bad[0])
            what = "a length > 0 m" if c.startswith("leg_len") else "a finite number"
            raise ConfigError(f"{p}: column {c}", frame[c].iloc[k], "", message=(
                f"{p}: column {c!r} row {k}: {frame[c].iloc[k]!r} is not {what}"))
        data[:, j] = v
    if len(frame) < 7:
        raise ConfigError(f"{p}", len(frame), "", message=(
            f"{p}: {len(frame)} rows; need at least 7 poses (7 parameters per leg)"))
    return data[:, :6], data[:, 6:]


def select_poses(geom: StewartGeometry, candidates: np.ndarray, n: int,
                 first: np.ndarray | None = None) -> np.ndarray:
    """Indices of ``n`` poses of ``candidates`` (M, 6) that identify the 42 parameters best.

    Greedy D-optimal design: each step adds the candidate that most increases
    ``log det(JᵀJ)`` of the identification Jacobian (rank-6 update by the matrix determinant
    lemma), after the poses ``first`` (k, 6) already planned, if any. Check the candidates
    against the workspace first (:func:`~rths3d.platform.kinematics.check_workspace`).
    """
    C, _ = _check_data(candidates)
    if not (isinstance(n, int | np.integer) and 1 <= n <= C.shape[0]):
        raise ConfigError("n", n, f"must be an integer in [1, {C.shape[0]}] (the candidates)")
    J = identification_jacobian(geom, C).reshape(C.shape[0], 6, N_PARAMETERS)
    M = np.eye(N_PARAMETERS) * 1e-9  # keeps the start invertible; far below one pose's info
    if first is not None:
        Jf = identification_jacobian(geom, _check_data(first)[0])
        M += Jf.T @ Jf
    Minv = np.linalg.inv(M)
    taken = np.zeros(C.shape[0], dtype=bool)
    chosen: list[int] = []
    eye = np.eye(6)
    for _ in range(int(n)):
        JM = J @ Minv  # (M, 6, 42)
        gain = np.linalg.slogdet(eye + JM @ J.transpose(0, 2, 1))[1]
        gain[taken] = -np.inf
        k = int(np.argmax(gain))
        chosen.append(k)
        taken[k] = True
        # Woodbury: (M + JᵀJ)⁻¹ = M⁻¹ − M⁻¹Jᵀ (I + J M⁻¹ Jᵀ)⁻¹ J M⁻¹
        Jk, JMk = J[k], JM[k]
        Minv = Minv - JMk.T @ np.linalg.solve(eye + JMk @ Jk.T, JMk)
    return np.array(chosen)
