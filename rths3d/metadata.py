"""What a record says about its test: the metadata the loop writes (docs/records.md)."""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
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
from .numerical.modal import interface_delay_margins_1dof
from .scene import scene_to_dict

__all__ = ["record_meta", "record_metas"]


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
                transfer_meta: dict[str, Any], *, part: Any = None,
                margin: tuple[float, float, float] | None = None) -> dict[str, Any]:
    """The record metadata of test k (see docs/records.md). ``part`` (the test's part, built
    from ``scene.experiment``) and ``margin`` (its (τ_cr, ω_c, PM) of
    :func:`~rths3d.numerical.interface_delay_margin`) when the caller has them
    (:func:`record_metas`)."""
    part = make_part(scene.experiment) if part is None else part
    k_exp, m_exp = part.interface_matrices()
    # a substructure that is not linear M, C, K (an OpenSees model) gives its linear model
    linearised = getattr(num, "linearised", None)
    M, C, K, G = linearised(k) if linearised is not None else \
        (num.M[k], num.C[k], num.Kmat[k], num.gamma)
    # delay margin of the delayed interface loop with the part as it is built (a mass behind
    # its spring, contact open); recorded only when a delay can destabilise the test
    if margin is None:
        try:
            margin = interface_delay_margin(M, C, K, G, m_exp, part.damping_matrix(), k_exp)
        except (ValueError, np.linalg.LinAlgError):
            margin = (math.inf, math.nan, math.nan)
    tau_cr, wc, pm = (float(x) for x in margin)
    extra = {"phase_margin": pm, "crossover": wc, "delay_margin": tau_cr} \
        if math.isfinite(tau_cr) else {}
    return {
        "scene": scene.name, "params": scene.params(), "transfer": scene.transfer.kind,
        "dt": scene.dt, "dofs": list(scene.dofs), "versions": dict(_versions()),
        "numerical": num.meta(k), "experiment": part.meta(),
        "omega_num_max": fastest_eigenfrequency(M, K),
        "omega_dyn_max": coupled_fastest_eigenfrequency(M, K, G, m_exp, k_exp),
        "transfer_meta": transfer_meta, **extra, "status": "ok", "reason": "",
        # the whole scene, effects included: the record knows its bench (rths3d diagnose)
        "scene_def": scene_to_dict(scene),
    }


def record_metas(scenes: Sequence[Scene], num: NumericalSubstructure,
                 transfer_metas: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """:func:`record_meta` of K tests stepped together: each distinct part built once, and
    the delay margins of one-DOF tests (one DOF on each side) computed for all of them at
    once (:func:`~rths3d.numerical.interface_delay_margins_1dof`)."""
    parts: dict[Any, Any] = {}
    keys = []
    for s in scenes:
        key: Any = s.experiment
        try:
            hash(key)
        except TypeError:  # a configuration with a list in it: its own part
            key = id(s.experiment)
        keys.append(key)
        if key not in parts:
            parts[key] = make_part(s.experiment)
    margins: list[tuple[float, float, float] | None] = [None] * len(scenes)
    if num.n == 1 and np.shape(num.gamma) == (1, 1) and len(scenes) > 1:
        of_part = {key: (part.interface_matrices(), part.damping_matrix())
                   for key, part in parts.items()}
        mats = [of_part[key] for key in keys]
        if all(np.size(me) == 1 for (_, me), _ in mats):
            ke = [float(np.ravel(kx)[0]) for (kx, _), _ in mats]
            me = [float(np.ravel(mx)[0]) for (_, mx), _ in mats]
            ce = [float(np.ravel(cx)[0]) for _, cx in mats]
            tau, wc, pm = interface_delay_margins_1dof(
                num.M[:, 0, 0], num.C[:, 0, 0], num.Kmat[:, 0, 0], num.gamma[0][0], me, ce,
                ke)
            margins = [None if math.isnan(t) else (t, w, p)
                       for t, w, p in zip(tau, wc, pm, strict=True)]
    return [record_meta(s, num, k, transfer_metas[k], part=parts[keys[k]],
                        margin=margins[k]) for k, s in enumerate(scenes)]
