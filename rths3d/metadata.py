"""What a record says about its test: the metadata the loop writes (docs/records.md)."""

from __future__ import annotations

import functools
import math
from importlib.metadata import PackageNotFoundError, version
from typing import Any

import numpy as np

from .config import Scene
from .experiment import make_part
from .numerical import (
    NumericalSubstructure,
    coupled_fastest_eigenfrequency,
    fastest_eigenfrequency,
    interface_delay_margin,
)
from .scene import scene_to_dict

__all__ = ["record_meta"]


@functools.lru_cache(maxsize=1)
def _versions() -> dict[str, str]:
    out = {}
    for pkg in ("rths3d", "mujoco", "numpy", "scipy", "numba"):
        try:
            out[pkg] = version(pkg)
        except PackageNotFoundError:
            out[pkg] = "unknown"
    return out


def record_meta(scene: Scene, num: NumericalSubstructure, k: int,
          transfer_meta: dict[str, Any]) -> dict[str, Any]:
    """The record metadata of test k (see docs/records.md)."""
    part = make_part(scene.experiment)
    k_exp, m_exp = part.interface_matrices()
    M, K = num.M[k], num.Kmat[k]
    # delay margin of the delayed interface loop with the part as it is built (a mass behind
    # its spring, contact open); recorded only when a delay can destabilise the test
    margin = {}
    try:
        tau_cr, wc, pm = interface_delay_margin(M, num.C[k], K, num.gamma, m_exp,
                                                part.damping_matrix(), k_exp)
    except (ValueError, np.linalg.LinAlgError):
        tau_cr = math.inf
    if math.isfinite(tau_cr):
        margin = {"phase_margin": pm, "crossover": wc, "delay_margin": tau_cr}
    return {
        "scene": scene.name, "params": scene.params(), "transfer": scene.transfer.kind,
        "dt": scene.dt, "dofs": list(scene.dofs), "versions": dict(_versions()),
        "numerical": num.meta(k), "experiment": part.meta(),
        "omega_num_max": fastest_eigenfrequency(M, K),
        "omega_dyn_max": coupled_fastest_eigenfrequency(M, K, num.gamma, m_exp, k_exp),
        "transfer_meta": transfer_meta, **margin, "status": "ok", "reason": "",
        # the whole scene, effects included: the record knows its bench (rths3d diagnose)
        "scene_def": scene_to_dict(scene),
    }
