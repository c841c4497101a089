"""Statistics of a benchmark's perturbed trials: one place for the tables both community
benchmarks report (``rths3d benchmark rths``, with or without a compensator)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

__all__ = ["J_KEYS", "trial_stats"]

J_KEYS = tuple(f"J{i}" for i in range(1, 10))
"""The evaluation criteria J1–J9 of the RTHS benchmark (Silva et al.)."""

_STATS = {"median": np.median, "mean": np.mean, "std": np.std, "min": np.min, "max": np.max}


def trial_stats(rows: Sequence[Mapping[str, float]], stats: Sequence[str],
                keys: Sequence[str] = J_KEYS, digits: int = 3) -> dict[str, dict[str, float]]:
    """``{stat: {key: value}}`` over the trials' table rows (each a mapping key → criterion
    value), for each of ``stats`` (median, mean, std — the population's —, min, max), rounded
    to ``digits`` as the tables print them."""
    J = np.array([[r[k] for k in keys] for r in rows], dtype=float)
    return {s: {k: round(float(v), digits) for k, v in zip(keys, _STATS[s](J, axis=0),
                                                           strict=True)}
            for s in stats}
