"""Where the maRTHS benchmark's data live and how they are read.

The structural matrices of the 29-DOF reference frame (a SAP2000 export) and the three
ground-motion records are not redistributed with rths3d: they are read at run time from the
benchmark folder (holding ``data/reference_K.csv``, ``data/reference_M.csv`` and
``data/ground_motion_<name>.csv``). The folder is found, in order, from the ``path``
argument, the environment variable ``RTHS3D_MARTHS_DIR``, or
``../shared/external/marths-benchmark`` beside the repository. Everything else (damping,
partitioning, specimen, plant, kinematics, RoDeAC) is built from the numbers the benchmark
states in plain text (:mod:`.model`, :mod:`.plant`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import ConfigError
from ...lti import GroundMotion, load_ground_motion
from ..config import benchmark_folder, canonical_name

__all__ = ["ENV_VAR", "RECORDS", "data_dir", "load_record", "load_reference_matrices",
           "record_name"]

ENV_VAR = "RTHS3D_MARTHS_DIR"
RECORDS = ("ElCentro", "Kobe", "Morgan")
"""The benchmark's ground motions (EQ_sw = 1, 2, 3)."""


def data_dir(path: str | Path | None = None) -> Path:
    """The maRTHS benchmark folder (holding ``data/``); ConfigError naming the places tried."""
    return benchmark_folder(path, ENV_VAR, "marths-benchmark", "data/reference_K.csv",
                            "--data" if path else "maRTHS data",
                            "data/reference_{K,M}.csv and data/ground_motion_<name>.csv")


def record_name(name: str) -> str:
    """Canonical record name for ``name`` (case and separators ignored)."""
    return canonical_name(name, RECORDS, "record")


def load_record(name: str, intensity: float = 0.4, path: str | Path | None = None
                ) -> GroundMotion:
    """Ground motion ``name`` (m/s²) scaled by ``intensity`` (the benchmark's EQ_intensity)."""
    r = record_name(name)
    return load_ground_motion(data_dir(path) / "data" / f"ground_motion_{r}.csv",
                              scale=intensity, name=r)


def load_reference_matrices(path: str | Path | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The reference frame's stiffness K (N/m, N, N·m/rad) and mass M (kg), 29×29, in
    SAP2000 equation order 1…29."""
    d = data_dir(path) / "data"
    K = np.loadtxt(d / "reference_K.csv", delimiter=",")
    M = np.loadtxt(d / "reference_M.csv", delimiter=",")
    if K.shape != (29, 29) or M.shape != (29, 29):
        raise ConfigError("maRTHS data", (K.shape, M.shape), "K and M must be 29×29")
    return K, M
