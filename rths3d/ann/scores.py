"""Performance of a net: Pearson correlation ρ (paper eq. 15) and mean squared error."""

from __future__ import annotations

from typing import Any

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


def log10_rho(a: np.ndarray, t: np.ndarray) -> float:
    """ρ on the log10 scale (predictions ≤ 0 clamped to 10⁻⁶; NaN for targets ≤ 0)."""
    a = np.asarray(a, dtype=float).ravel()
    t = np.asarray(t, dtype=float).ravel()
    if np.any(t <= 0):
        return float("nan")
    return pearson_rho(np.log10(np.maximum(a, 1e-6)), np.log10(t))


def median_worst(values: Any) -> dict[str, float]:
    """``{"median", "worst"}`` of scores (ρ: worst is the smallest), NaNs left out."""
    v = np.asarray([x for x in values if np.isfinite(x)], dtype=float)
    if v.size == 0:
        return {"median": float("nan"), "worst": float("nan")}
    return {"median": float(np.median(v)), "worst": float(np.min(v))}
