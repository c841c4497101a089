"""Honest scores of a trained ensemble on a table: per group, per member, in and out of range.

One ρ pooled over a table whose groups differ (families of systems, transfer systems) can
read far below every group's own ρ (0.71 for a table whose families read 0.94–0.98), or
above it; and an ensemble can hide a member that fails. :func:`score_report` therefore gives,
overall and for every group of a column (``family`` by default):

- ``n``: tests scored (finite target and prediction);
- ``r`` (eq. 15, linear scale, the ensemble) and ``r_log10`` (log10 prediction against log10
  target; NaN when a target is ≤ 0);
- ``members``: median and worst ρ over the ensemble's members (``members_log10`` likewise);
- ``share_outside``: share of the tests with some input outside the ranges of the data the
  model was fitted on, and ``r_in_range`` / ``n_in_range`` on the others.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .estimator import FidelityANN, combine_members
from .protocol import in_range
from .scores import log10_rho, median_worst, mse, pearson_rho


def scores_of(pred: np.ndarray, outs: np.ndarray | None, y: np.ndarray,
              inside: np.ndarray) -> dict[str, Any]:
    """The scores of one group (see the module docstring). ``outs``: member outputs
    (n_members, N) or None for a single predictor."""
    ok = np.isfinite(pred) & np.isfinite(y)
    p, t, ins = pred[ok], y[ok], inside[ok]
    res: dict[str, Any] = {"n": int(ok.sum()), "r": pearson_rho(p, t) if p.size > 1 else
                           float("nan"), "r_log10": log10_rho(p, t),
                           "mse": mse(p, t) if p.size else float("nan")}
    if outs is not None:
        o = outs[:, ok]
        res["members"] = median_worst([pearson_rho(m, t) for m in o])
        res["members_log10"] = median_worst([log10_rho(m, t) for m in o])
    res["share_outside"] = float(1.0 - ins.mean()) if ins.size else float("nan")
    res["n_in_range"] = int(ins.sum())
    res["r_in_range"] = pearson_rho(p[ins], t[ins]) if ins.sum() > 1 else float("nan")
    return res


def score_report(model: FidelityANN, X: Any, y: np.ndarray, groups: Any = None
                 ) -> dict[str, Any]:
    """Scores of ``model`` on (X, y), overall and per value of ``groups`` (one label per
    sample, e.g. the table's ``family`` column), as in the module docstring."""
    y = np.asarray(y, dtype=float).ravel()
    outs = model.predict_members(X, warn=False)
    pred = combine_members(outs, model.combine)
    inside = in_range(model, X)
    res = scores_of(pred, outs, y, inside)
    if groups is not None:
        g = np.asarray(groups).astype(str)
        res["groups"] = {str(v): scores_of(pred[g == v], outs[:, g == v], y[g == v],
                                           inside[g == v]) for v in sorted(set(g))}
    return res
