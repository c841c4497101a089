"""Learning curve: how the fidelity ANN's accuracy grows with the number of training tests.

The paper names more (and more varied) data as the cure for its network's limits. Whether
more tests of the *same* system would still help, or the Table-3 features are exhausted, is
read off a learning curve: one fixed, held-out test set, nets trained on nested subsets of the
remaining tests of growing size, and on each the test ρ (eq. 15) and the spread of the
prediction error on the log scale. A residual that keeps falling with the training size means
data (and capacity) are the limit; a flat one means the features are.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from ..errors import ConfigError
from .estimator import FidelityANN, combine_members
from .scores import pearson_rho


@dataclass(frozen=True)
class LearningPoint:
    """One training size of a learning curve (ρ as fractions, residuals in decades)."""

    n_train: int
    """Training samples (the validation samples for early stopping come on top)."""
    n_val: int
    r_test_ensemble: float
    """ρ (eq. 15) of the ensemble mean on the fixed test set."""
    r_test_median: float
    """Median ρ of the single trainings on the test set."""
    r_train_ensemble: float
    """ρ of the ensemble mean on its own training samples."""
    log_residual_test: float
    """Standard deviation of log10(prediction / target) on the test set (decades);
    0.043 decades ≈ 10 % relative error."""
    log_residual_train: float
    topology: str
    seconds: float
    """Wall time of the fit (s), topology search included."""

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def learning_curve(X: Any, y: Any, sizes: Sequence[int], *, n_test: int | None = None,
                   val_fraction: float = 0.15, seed: int = 0, n_trainings: int = 5,
                   topologies: Sequence[Sequence[int]] | None = None, transform: str = "log",
                   bypass: bool = True, progress: bool = False) -> list[LearningPoint]:
    """Train :class:`FidelityANN` ensembles on nested subsets of growing size.

    ``X`` (N, d) features, ``y`` (N,) targets (e_rel,ref > 0 for the log scale). A random
    ``n_test`` samples (default 15 % of N) are held out once and score every point; each
    size in ``sizes`` (training + validation samples, increasing) takes the first that many
    of the remaining samples in one seeded random order, so every subset contains the smaller
    ones, and keeps ``val_fraction`` of them for early stopping.
    """
    x = X.to_numpy(dtype=float) if hasattr(X, "to_numpy") else np.asarray(X, dtype=float)
    t = np.asarray(y, dtype=float).ravel()
    n = t.size
    if x.ndim != 2 or x.shape[0] != n:
        raise ConfigError("X", list(x.shape), f"must be (N, d) with N = {n} (one row per target)")
    n_te = int(round(0.15 * n)) if n_test is None else int(n_test)
    if not 2 < n_te < n:
        raise ConfigError("n_test", n_te, f"must lie in 3 … {n - 1}")
    if not 0.0 < val_fraction < 1.0:
        raise ConfigError("val_fraction", val_fraction, "must lie in (0, 1)")
    sizes = [int(s) for s in sizes]
    pool_n = n - n_te
    for s in sizes:
        if not 2 / val_fraction <= s <= pool_n:
            raise ConfigError("sizes", s, f"each size must lie in {int(np.ceil(2 / val_fraction))}"
                                          f" … {pool_n} (the samples left after the test set)")
    if sizes != sorted(sizes):
        raise ConfigError("sizes", sizes, "must increase")
    order = np.random.default_rng(seed).permutation(n)
    test, pool = order[:n_te], order[n_te:]
    points = []
    for s in sizes:
        sub = pool[:s]
        n_val = max(1, int(round(val_fraction * s)))
        idx = {"train": sub[n_val:], "val": sub[:n_val], "test": test}
        t0 = time.perf_counter()
        model = FidelityANN(topologies=topologies, n_trainings=n_trainings, seed=seed,
                            transform=transform, bypass=bypass).fit(x, t, indices=idx,
                                                                    progress=progress)
        seconds = time.perf_counter() - t0
        outs = model.predict_members(x, warn=False)
        ens = combine_members(outs, model.combine)
        tr = idx["train"]
        points.append(LearningPoint(
            n_train=int(tr.size), n_val=n_val,
            r_test_ensemble=pearson_rho(ens[test], t[test]),
            r_test_median=float(np.median([pearson_rho(o[test], t[test]) for o in outs])),
            r_train_ensemble=pearson_rho(ens[tr], t[tr]),
            log_residual_test=_log_residual(ens[test], t[test]),
            log_residual_train=_log_residual(ens[tr], t[tr]),
            topology=model.topology.label(), seconds=seconds))
    return points


def _log_residual(a: np.ndarray, t: np.ndarray) -> float:
    """Standard deviation of log10(a / t) (decades); predictions ≤ 0 clamped to 10⁻⁶."""
    if np.any(t <= 0):
        return float("nan")
    return float(np.std(np.log10(np.maximum(a, 1e-6) / t)))


__all__ = ["LearningPoint", "learning_curve"]
