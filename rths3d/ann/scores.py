"""Performance of a net: Pearson correlation ρ (paper eq. 15) and mean squared error."""

from __future__ import annotations

import numpy as np


def pearson_rho(a: np.ndarray, t: np.ndarray) -> float:
    """ρ(a, t) = cov(a, t) / (σ_a σ_t), paper eq. (15); NaN when either is constant.

    ``a`` net outputs, ``t`` targets (same units, here the relative RMS reference error).
    """
    a = np.asarray(a, dtype=float).ravel()
    t = np.asarray(t, dtype=float).ravel()
    if a.size != t.size:
        raise ValueError(f"pearson_rho: {a.size} outputs vs {t.size} targets")
    if a.size < 2:
        return float("nan")
    da = a - a.mean()
    dt = t - t.mean()
    den = np.sqrt(np.dot(da, da) * np.dot(dt, dt))
    return float(np.dot(da, dt) / den) if den > 0 else float("nan")


def mse(a: np.ndarray, t: np.ndarray) -> float:
    """Mean squared error ⟨(a − t)²⟩ in squared target units."""
    a = np.asarray(a, dtype=float).ravel()
    t = np.asarray(t, dtype=float).ravel()
    return float(np.mean((a - t) ** 2))
