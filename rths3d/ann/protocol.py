"""The paper's ANN protocol (Table 4), reproduced and extended on sweep tables.

1. Train on the contact tests driven by the 1-D LTI transfer system (the paper's vRTHS) with
   feature sets 1, 2 and 3: ρ on the training and test sets (paper: 99.5/99.3 %, 99.3/99.1 %,
   98.9/98.9 %).
2. Apply the set-2 network to the same tests driven by the MuJoCo Stewart platform (our
   analogue of the paper's real bench, 98 %).
3. Apply the contact-trained networks to the linear two-mass system of Table 2 (paper: 0–69 %).
4. Extension: train on many system families with one family left out, test on that family.

Every ρ (eq. 15) is reported for each of the ensemble's trainings (≥ 5): median and worst.
With ``split_seeds`` (several 70/15/15 splits) the median and worst run over all trainings of
all splits, and the ensemble ρ is the median of the splits' ensembles: one 15 % test set of
~40 heavy-tailed samples moves ρ by several percent from split to split, so a single split is
a noisy figure.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .estimator import FidelityANN, combine_members
from .scores import log10_rho, mse, pearson_rho

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
    members_log: list[float] = field(default_factory=list)
    """ρ of log10(prediction) vs log10(target) per training (the scale the net is fitted on)."""

    @property
    def r_log_median(self) -> float:
        return float(np.median(self.members_log)) if self.members_log else float("nan")

    @property
    def r_log_worst(self) -> float:
        return float(np.min(self.members_log)) if self.members_log else float("nan")

    def as_dict(self) -> dict[str, Any]:
        return dict(self.__dict__)


def _members_rho(model: FidelityANN, X: Any, y: np.ndarray
                 ) -> tuple[list[float], float, float, list[float]]:
    outs = model.predict_members(X, warn=False)
    mean = combine_members(outs, model.combine)
    return ([pearson_rho(o, y) for o in outs], pearson_rho(mean, y), mse(mean, y),
            [log10_rho(o, y) for o in outs])


def fit_and_score(X: Any, y: np.ndarray, system: str, features: int, *, seed: int = 0,
                  n_trainings: int = 5, topologies: Sequence[Sequence[int]] | None = None,
                  note: str = "", transform: str = "log", bypass: bool = True,
                  progress: bool = False) -> tuple[FidelityANN, ProtocolRow]:
    """Train on (X, y) (70/15/15) and report the training and *test-set* ρ over trainings.

    ``progress``: a bar per fit, labelled with the system, the feature set and the split.
    """
    label = f"{system}, set {features}, split {seed}" if progress else False
    model = FidelityANN(topologies=topologies, n_trainings=n_trainings, seed=seed,
                        transform=transform, bypass=bypass).fit(X, y, progress=label)
    sc = model.scores(X, y)
    rt, rte = sc["members_r_train"], sc["members_r_test"]
    te = model.indices["test"]
    outs = model.predict_members(X, warn=False)[:, te]
    yt = np.asarray(y, dtype=float)[te]
    row = ProtocolRow(system, features, len(model.indices["train"]), len(te),
                      float(np.median(rt)), float(np.min(rt)), float(np.median(rte)),
                      float(np.min(rte)), sc["r_test"], sc["mse_test"],
                      model.topology.label(), note, list(rte), [log10_rho(o, yt) for o in outs])
    return model, row


def fit_and_score_splits(X: Any, y: np.ndarray, system: str, features: int, *,
                         split_seeds: Sequence[int] = (0, 1, 2, 3, 4), n_trainings: int = 5,
                         topologies: Sequence[Sequence[int]] | None = None, note: str = "",
                         transform: str = "log", bypass: bool = True, progress: bool = False
                         ) -> tuple[list[FidelityANN], ProtocolRow]:
    """:func:`fit_and_score` over several splits (one seed each), pooled into one row.

    ρ median / worst over all trainings of all splits (each on its own test set); the
    ensemble ρ and the MSE are the medians over the splits; ``net`` lists the chosen
    topologies.
    """
    models, rows = [], []
    for s in split_seeds:
        m, r = fit_and_score(X, y, system, features, seed=int(s), n_trainings=n_trainings,
                             topologies=topologies, note=note, transform=transform,
                             bypass=bypass, progress=progress)
        models.append(m)
        rows.append(r)
    return models, _pool(rows, trained=True, note=note)


def _pool(rows: Sequence[ProtocolRow], trained: bool, note: str) -> ProtocolRow:
    if len(rows) == 1:
        return rows[0]
    r0 = rows[0]
    ev = [v for r in rows for v in r.members]
    tr_med = [r.r_train_median for r in rows if r.r_train_median is not None]
    tr_min = [r.r_train_worst for r in rows if r.r_train_worst is not None]
    nets = sorted({r.topology for r in rows}, key=lambda t: (len(t), t))
    return ProtocolRow(r0.system, r0.features, r0.n_train, r0.n_eval,
                       float(np.median(tr_med)) if trained and tr_med else None,
                       float(np.min(tr_min)) if trained and tr_min else None,
                       float(np.median(ev)), float(np.min(ev)),
                       float(np.median([r.r_ensemble for r in rows])),
                       float(np.median([r.mse for r in rows])), ",".join(nets),
                       f"{note}; {len(rows)} splits" if note else f"{len(rows)} splits", ev,
                       [v for r in rows for v in r.members_log])


def apply_and_score(model: FidelityANN | Sequence[FidelityANN], X: Any, y: np.ndarray,
                    system: str, features: int, note: str = "") -> ProtocolRow:
    """Apply a trained ensemble to new data; ρ of each training on all given samples.

    Several models (one per split, from :func:`fit_and_score_splits`) pool their trainings.
    """
    if not isinstance(model, FidelityANN):
        return _pool([apply_and_score(m, X, y, system, features, note) for m in model],
                     trained=False, note=note)
    members, r_ens, err, logs = _members_rho(model, X, y)
    return ProtocolRow(system, features, len(model.indices["train"]), len(y), None, None,
                       float(np.median(members)), float(np.min(members)), r_ens, err,
                       model.topology.label(), note, members, logs)


def in_range(model: FidelityANN | Sequence[FidelityANN], X: Any) -> np.ndarray:
    """Rows of X inside every range of the data given to fit (the paper kept only such linear
    samples)."""
    if not isinstance(model, FidelityANN):
        model = model[0]
    x = X.to_numpy(dtype=float) if hasattr(X, "to_numpy") else np.asarray(X, dtype=float)
    return ~model.raw_range.outside(x).any(axis=1)


def rows_to_markdown(rows: Sequence[ProtocolRow]) -> str:
    """The results as a Markdown table (ρ in %, median / worst over trainings)."""

    def pct(v: float | None) -> str:
        return "–" if v is None or not np.isfinite(v) else f"{100 * v:.1f}"

    lines = ["| system | set | n train | n eval | ρ train (median / worst) % | "
             "ρ eval (median / worst) % | ρ ensemble % | ρ log10 eval (median / worst) % | MSE | "
             "net | note |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(
            f"| {r.system} | {r.features} | {r.n_train} | {r.n_eval} | "
            f"{pct(r.r_train_median)} / {pct(r.r_train_worst)} | "
            f"{pct(r.r_eval_median)} / {pct(r.r_eval_worst)} | {pct(r.r_ensemble)} | "
            f"{pct(r.r_log_median)} / {pct(r.r_log_worst)} | {r.mse:.2g} | {r.topology} | "
            f"{r.note} |")
    return "\n".join(lines)


def reproduce(contact_lti: Any, contact_stewart: Any | None = None, linear: Any | None = None,
              families: Any | None = None, *, left_out: str = "linear",
              n_trainings: int = 5, seed: int = 0,
              topologies: Sequence[Sequence[int]] | None = None,
              feature_sets: Sequence[int] = (1, 2, 3), transform: str = "log",
              split_seeds: Sequence[int] | None = None, bypass: bool = True,
              stewart_in_range: bool = True, progress: bool = False,
              models_out: dict[str, list[FidelityANN]] | None = None,
              extra: Sequence[str] = ()) -> list[ProtocolRow]:
    """Run the whole protocol on sweep tables (DataFrames) and return the result rows.

    ``contact_lti``: the paper's contact tests with the 1-D LTI transfer (training data);
    ``contact_stewart``: the same tests on the MuJoCo Stewart platform; ``linear``: the
    Table-2 linear system; ``families``: a multi-family table whose family ``left_out`` is
    held out of training and used for testing (the Table-2 tests are then also tested).
    ``split_seeds``: train on each of these 70/15/15 splits and pool (default: ``seed`` only).
    ``stewart_in_range``: also score the Stewart tests whose features all lie inside the
    ranges of the data given to fit (the paper kept only such samples of the linear system),
    when some do not.
    ``progress``: a progress bar for every training run (they take minutes to hours on the
    large sweeps).
    ``models_out``: a dict that receives the trained estimators, one per split seed, under
    ``"contact_set<N>"`` and ``"families_set<N>"`` (N = feature set), for plots and reuse.
    ``extra``: test parameters added to every feature set as inputs (e.g. ``experiment.h0``,
    see :func:`rths3d.dataset.training_data`); the system names then end in ``+ <names>``,
    and the linear and families parts run only on tables that hold those parameters.
    """
    from ..dataset.table import PARAM, has_params, training_data

    plus = (" + " + ", ".join(e.removeprefix(PARAM) for e in extra)) if extra else ""
    if linear is not None and not has_params(linear, extra):
        linear = None
    if families is not None and not has_params(families, extra):
        families = None
    seeds = tuple(split_seeds) if split_seeds else (seed,)

    def train(X: Any, y: np.ndarray, system: str, fs: int, note: str
              ) -> tuple[list[FidelityANN], ProtocolRow]:
        return fit_and_score_splits(X, y, system, fs, split_seeds=seeds,
                                    n_trainings=n_trainings, topologies=topologies,
                                    note=note, transform=transform, bypass=bypass,
                                    progress=progress)

    rows: list[ProtocolRow] = []
    models: dict[int, list[FidelityANN]] = {}
    for fs in feature_sets:
        X, y, _ = training_data(contact_lti, fs, extra=extra)
        model, row = train(X, y, "contact, 1-D LTI transfer (vRTHS)" + plus, fs,
                           "trained here; ρ eval = test set")
        models[fs] = model
        if models_out is not None:
            models_out[f"contact_set{fs}"] = model
        rows.append(row)
    if contact_stewart is not None:
        for fs in feature_sets:
            X, y, _ = training_data(contact_stewart, fs, extra=extra)
            rows.append(apply_and_score(models[fs], X, y,
                                        "contact, MuJoCo Stewart platform" + plus,
                                        fs, note="LTI-trained net applied to all samples"))
            keep = in_range(models[fs], X)
            if stewart_in_range and 2 < keep.sum() < len(y):
                rows.append(apply_and_score(
                    models[fs], X[keep], y[keep], "Stewart, inside the training ranges" + plus,
                    fs,
                    note=f"{int(keep.sum())} of {len(y)} samples: no feature extrapolated"))
    if linear is not None:
        for fs in feature_sets:
            X, y, _ = training_data(linear, fs, extra=extra)
            keep = in_range(models[fs], X)
            rows.append(apply_and_score(models[fs], X, y, "linear Table 2 (contact-trained)",
                                        fs, note=f"all samples ({int(keep.sum())} in range)"))
    if families is not None:
        for fs in feature_sets:
            X, y, _ = training_data(families, fs, exclude=[left_out], extra=extra)
            model, row = train(X, y, f"families without {left_out!r}", fs,
                               "test set of the training families")
            if models_out is not None:
                models_out[f"families_set{fs}"] = model
            rows.append(row)
            Xo, yo, _ = training_data(families, fs, families=[left_out], extra=extra)
            if len(yo) > 2:
                rows.append(apply_and_score(model, Xo, yo, f"family {left_out!r} (left out)",
                                            fs, note="never seen in training"))
            if linear is not None:
                Xl, yl, _ = training_data(linear, fs, extra=extra)
                rows.append(apply_and_score(model, Xl, yl, "linear Table 2 (families-trained)",
                                            fs, note=f"{left_out!r} family left out"))
    return rows
