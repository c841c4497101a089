"""Sensitivity of a trained net to each input feature (the paper's two methods).

Mean replacement: set one feature to its mean in every sample and measure how much the MSE of
the prediction grows. Permutation: shuffle one feature across samples (breaking its relation to
the target, keeping its distribution) and measure the growth, averaged over repeats. A feature
the net relies on raises the MSE; an irrelevant one leaves it unchanged. Both measure
independent contributions only (interdependent features share the blame).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .estimator import FidelityANN, _as_matrix
from .scores import mse


def _baseline(model: FidelityANN, X: Any, y: Any) -> tuple[np.ndarray, np.ndarray, float]:
    x, _ = _as_matrix(X, model.feature_names or None, expect=model.feature_names)
    t = np.asarray(y, dtype=float).ravel()
    return x, t, mse(model.predict(x, warn=False), t)


def sensitivity_mean(model: FidelityANN, X: Any, y: Any) -> dict[str, float]:
    """MSE increase (target units²) when each feature is replaced by its mean, per feature."""
    x, t, base = _baseline(model, X, y)
    out = {}
    for j, name in enumerate(model.feature_names):
        xm = x.copy()
        xm[:, j] = x[:, j].mean()
        out[name] = mse(model.predict(xm, warn=False), t) - base
    return out


def sensitivity_permutation(model: FidelityANN, X: Any, y: Any, n_repeats: int = 10,
                            seed: int = 0) -> dict[str, float]:
    """Mean MSE increase (target units²) when each feature is randomly permuted."""
    x, t, base = _baseline(model, X, y)
    rng = np.random.default_rng(seed)
    out = {}
    for j, name in enumerate(model.feature_names):
        inc = []
        for _ in range(n_repeats):
            xp = x.copy()
            xp[:, j] = x[rng.permutation(x.shape[0]), j]
            inc.append(mse(model.predict(xp, warn=False), t) - base)
        out[name] = float(np.mean(inc))
    return out


def rank(importance: dict[str, float]) -> list[str]:
    """Feature names from most to least important."""
    return sorted(importance, key=lambda k: importance[k], reverse=True)
