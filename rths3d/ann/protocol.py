"""The paper's ANN protocol (Table 4), reproduced and extended on sweep tables.

1. Train on the contact tests driven by the 1-D LTI transfer system (the paper's vRTHS) with
   feature sets 1, 2 and 3: ρ on the training and test sets (paper: 99.5/99.3 %, 99.3/99.1 %,
   98.9/98.9 %).
2. Apply the set-2 network to the same tests driven by the MuJoCo Stewart platform (our
   analogue of the paper's real bench, 98 %).
3. Apply the contact-trained networks to the linear two-mass system of Table 2 (paper: 0–69 %).
4. Extension: train on many system families with one family left out, test on that family.

Every ρ (eq. 15) is reported for each of the ensemble's trainings (≥ 5): median and worst.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .estimator import FidelityANN
from .scores import mse, pearson_rho

PAPER_TABLE4: tuple[dict[str, Any], ...] = (
    {"system": "vRTHS with contact", "features": "1", "r_train": 0.995, "r_test": 0.993,
     "mse": 4.1e-4},
    {"system": "vRTHS with contact", "features": "2", "r_train": 0.993, "r_test": 0.991,
     "mse": 5e-4},
    {"system": "vRTHS with contact", "features": "3", "r_train": 0.989, "r_test": 0.989,
     "mse": 5.8e-4},
    {"system": "RTHS with contact (real bench)", "features": "2", "r_train": None,
     "r_test": 0.98, "mse": None},
    {"system": "linear vRTHS (never seen)", "features": "1 and 2", "r_train": None,
     "r_test": (0.0, 0.69), "mse": None},
)
"""The paper's Table 4 (ρ as fractions; MSE in target units²)."""


@dataclass
class ProtocolRow:
    """One line of the results table: ρ over the ensemble's trainings (median, worst)."""

    system: str
    features: int
    n_train: int
    n_eval: int
    r_train_median: float | None
    r_train_worst: float | None
    r_eval_median: float
    r_eval_worst: float
    r_ensemble: float
    mse: float
    topology: str
    note: str = ""
    members: list[float] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        return dict(self.__dict__)


def _members_rho(model: FidelityANN, X: Any, y: np.ndarray) -> tuple[list[float], float, float]:
    outs = model.predict_members(X, warn=False)
    mean = outs.mean(axis=0)
    return [pearson_rho(o, y) for o in outs], pearson_rho(mean, y), mse(mean, y)


def fit_and_score(X: Any, y: np.ndarray, system: str, features: int, *, seed: int = 0,
                  n_trainings: int = 5, topologies: Sequence[Sequence[int]] | None = None,
                  note: str = "", transform: str = "linear") -> tuple[FidelityANN, ProtocolRow]:
    """Train on (X, y) (70/15/15) and report the training and *test-set* ρ over trainings."""
    model = FidelityANN(topologies=topologies, n_trainings=n_trainings, seed=seed,
                        transform=transform).fit(X, y)
    sc = model.scores(X, y)
    rt, rte = sc["members_r_train"], sc["members_r_test"]
    row = ProtocolRow(system, features, len(model.indices["train"]), len(model.indices["test"]),
                      float(np.median(rt)), float(np.min(rt)), float(np.median(rte)),
                      float(np.min(rte)), sc["r_test"], sc["mse_test"],
                      model.topology.label(), note, list(rte))
    return model, row


def apply_and_score(model: FidelityANN, X: Any, y: np.ndarray, system: str, features: int,
                    note: str = "") -> ProtocolRow:
    """Apply a trained ensemble to new data; ρ of each training on all given samples."""
    members, r_ens, err = _members_rho(model, X, y)
    return ProtocolRow(system, features, len(model.indices["train"]), len(y), None, None,
                       float(np.median(members)), float(np.min(members)), r_ens, err,
                       model.topology.label(), note, members)


def in_range(model: FidelityANN, X: Any) -> np.ndarray:
    """Rows of X inside every training range (the paper kept only such linear samples)."""
    x = X.to_numpy(dtype=float) if hasattr(X, "to_numpy") else np.asarray(X, dtype=float)
    return ~model.raw_range.outside(x).any(axis=1)


def rows_to_markdown(rows: Sequence[ProtocolRow]) -> str:
    """The results as a Markdown table (ρ in %, median / worst over trainings)."""

    def pct(v: float | None) -> str:
        return "–" if v is None or not np.isfinite(v) else f"{100 * v:.1f}"

    lines = ["| system | set | n train | n eval | ρ train (median / worst) % | "
             "ρ eval (median / worst) % | ρ ensemble % | MSE | net | note |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(
            f"| {r.system} | {r.features} | {r.n_train} | {r.n_eval} | "
            f"{pct(r.r_train_median)} / {pct(r.r_train_worst)} | "
            f"{pct(r.r_eval_median)} / {pct(r.r_eval_worst)} | {pct(r.r_ensemble)} | "
            f"{r.mse:.2g} | {r.topology} | {r.note} |")
    return "\n".join(lines)


def reproduce(contact_lti: Any, contact_stewart: Any | None = None, linear: Any | None = None,
              families: Any | None = None, *, left_out: str = "linear",
              n_trainings: int = 5, seed: int = 0,
              topologies: Sequence[Sequence[int]] | None = None,
              feature_sets: Sequence[int] = (1, 2, 3), transform: str = "linear"
              ) -> list[ProtocolRow]:
    """Run the whole protocol on sweep tables (DataFrames) and return the result rows.

    ``contact_lti``: the paper's contact tests with the 1-D LTI transfer (training data);
    ``contact_stewart``: the same tests on the MuJoCo Stewart platform; ``linear``: the
    Table-2 linear system; ``families``: a multi-family table whose family ``left_out`` is
    held out of training and used for testing (the Table-2 tests are then also tested).
    """
    from ..dataset.table import training_data

    rows: list[ProtocolRow] = []
    models: dict[int, FidelityANN] = {}
    for fs in feature_sets:
        X, y, _ = training_data(contact_lti, fs)
        model, row = fit_and_score(X, y, "contact, 1-D LTI transfer (vRTHS)", fs, seed=seed,
                                   n_trainings=n_trainings, topologies=topologies,
                                   note="trained here; ρ eval = test set",
                                   transform=transform)
        models[fs] = model
        rows.append(row)
    if contact_stewart is not None:
        for fs in feature_sets:
            X, y, _ = training_data(contact_stewart, fs)
            rows.append(apply_and_score(models[fs], X, y, "contact, MuJoCo Stewart platform",
                                        fs, note="LTI-trained net applied to all samples"))
    if linear is not None:
        for fs in feature_sets:
            X, y, _ = training_data(linear, fs)
            keep = in_range(models[fs], X)
            rows.append(apply_and_score(models[fs], X, y, "linear Table 2 (contact-trained)",
                                        fs, note=f"all samples ({int(keep.sum())} in range)"))
    if families is not None:
        for fs in feature_sets:
            X, y, _ = training_data(families, fs, exclude=[left_out])
            model, row = fit_and_score(X, y, f"families without {left_out!r}", fs, seed=seed,
                                       n_trainings=n_trainings, topologies=topologies,
                                       note="test set of the training families",
                                       transform=transform)
            rows.append(row)
            Xo, yo, _ = training_data(families, fs, families=[left_out])
            if len(yo) > 2:
                rows.append(apply_and_score(model, Xo, yo, f"family {left_out!r} (left out)",
                                            fs, note="never seen in training"))
            if linear is not None:
                Xl, yl, _ = training_data(linear, fs)
                rows.append(apply_and_score(model, Xl, yl, "linear Table 2 (families-trained)",
                                            fs, note=f"{left_out!r} family left out"))
    return rows
