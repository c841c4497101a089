"""The fidelity estimator: topology search, an ensemble of LM-trained nets, save/load.

:class:`FidelityANN` follows the paper's procedure: inputs X (features, e.g. a Table-3 set)
and target y (the relative RMS reference error e_rel,ref, eq. 1 with z^r) are normalised to
[−1, 1]; the samples are split 70/15/15 once and the indices stored; every candidate topology
(hidden layers × neurons) is trained ``n_trainings`` times (5 in the paper) from different
random initialisations with Levenberg–Marquardt and validation early stopping; the topology
with the smallest mean MSE is kept. Its ``n_trainings`` nets form an ensemble: the prediction
is their median (default; ``combine="mean"`` or ``"trimmed"`` as alternatives) and the spread
(standard deviation across nets) comes with it.

Why the median: one net that goes wild on some inputs (a rare combination of features, far
from the training data) pulls a mean with it, and the ensemble then scores below most of its
members (seen: ρ 0.906 for the mean of five nets whose median member read 0.949). For an odd
number of members the median is one member's prediction per sample, and for every sample its
error is no larger than the median over the members of their errors on that sample: if the
median lies above the target, at least half of the members lie at or above it, each with an
error at least as large. Fewer than half of the members going wild cannot move it.

The topology is picked on the mean *validation* MSE (normalised scale); the paper picks on
the mean MSE after training. Using validation data keeps the test set untouched and does not
reward nets that overfit.
"""

from __future__ import annotations

import contextlib
import json
import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch

from ..errors import ConfigError
from .network import DTYPE, Topology, forward
from .normalize import MinMax, split_indices
from .scores import mse, pearson_rho
from .training import LMConfig, TrainResult, train_lm

FORMAT = "rths3d-fidelity-ann/1"
DEFAULT_TOPOLOGIES: tuple[tuple[int, ...], ...] = ((2,), (5,), (10,), (20,), (5, 5), (10, 10))


def parse_topologies(text: str | None, field: str = "--topologies"
                     ) -> tuple[tuple[int, ...], ...] | None:
    """Candidate hidden layers from text: ``'5;10;5,5'`` or ``'10x10;20x20'`` (``;`` between
    candidates, ``,`` or ``x`` between layers). Empty or None: None (the default search)."""
    if not text:
        return None
    out = []
    for part in text.split(";"):
        try:
            widths = tuple(int(w) for w in part.replace("x", ",").split(",") if w.strip())
        except ValueError as exc:
            raise ConfigError(field, text, "write e.g. '5;10;5,5'") from exc
        if not widths or min(widths) < 1:
            raise ConfigError(field, text, "every width must be >= 1")
        out.append(widths)
    return tuple(out)


TRANSFORMS = ("linear", "log")
COMBINES = ("median", "mean", "trimmed")
"""How the ensemble combines its members: per-sample median (default), mean, or trimmed mean
(the mean after dropping the lowest and the highest member)."""


def combine_members(outs: np.ndarray, how: str = "median") -> np.ndarray:
    """Combine member outputs (n_members, N) into one prediction per sample; NaN members
    (non-finite inputs) give NaN."""
    if how == "median":
        return np.median(outs, axis=0)
    if how == "mean":
        return outs.mean(axis=0)
    if how == "trimmed":
        if outs.shape[0] < 3:
            return outs.mean(axis=0)
        return np.sort(outs, axis=0)[1:-1].mean(axis=0)
    raise ConfigError("combine", how, f"one of {', '.join(COMBINES)}")


@dataclass(frozen=True)
class Compress:
    """Optional compression of heavy-tailed columns before the [−1, 1] normalisation.

    For ``transform="log"``: a column that is > 0 in all training samples becomes log10(x); any
    other column becomes asinh(x / s) with s its median |x| (linear near 0, logarithmic in the
    tails, sign kept). The target is log10(y) when all training targets are > 0. Reference
    errors and most indicators span decades (e_rel,ref from 10⁻³ to 0.4 in the paper's grid);
    a linear map to [−1, 1] squeezes most samples into a corner.
    """

    log_cols: tuple[bool, ...]
    scale: tuple[float, ...]
    log_y: bool

    @classmethod
    def fit(cls, x: np.ndarray, y: np.ndarray, kind: str) -> Compress:
        d = x.shape[1]
        if kind == "linear":
            return cls((False,) * d, (0.0,) * d, False)
        pos = (x > 0).all(axis=0)
        med = np.median(np.abs(x), axis=0)
        scale = np.where(pos, 0.0, np.where(med > 0, med, 1.0))
        return cls(tuple(bool(p) for p in pos), tuple(float(v) for v in scale),
                   bool((y > 0).all()))

    def x(self, x: np.ndarray) -> np.ndarray:
        out = np.array(x, dtype=float, copy=True)
        for j, (lg, sc) in enumerate(zip(self.log_cols, self.scale, strict=True)):
            if lg:
                # nonpositive inputs lie outside the fit data's range anyway (warned); clamp
                out[:, j] = np.log10(np.maximum(out[:, j], 1e-300))
            elif sc > 0:
                out[:, j] = np.arcsinh(out[:, j] / sc)
        return out

    def y(self, y: np.ndarray) -> np.ndarray:
        return np.log10(y) if self.log_y else np.asarray(y, dtype=float)

    def y_inv(self, z: np.ndarray) -> np.ndarray:
        return 10.0 ** z if self.log_y else z


class ExtrapolationWarning(UserWarning):
    """Inputs lie outside the ranges of the data given to fit (the network extrapolates).

    The ranges span every sample given to :meth:`FidelityANN.fit` (training, validation and
    test together, as MATLAB's ``mapminmax`` on the whole data), not the training subset.
    """


class NonFiniteInputWarning(UserWarning):
    """Inputs hold NaN or inf: the predictions of those samples are NaN."""


@dataclass(frozen=True)
class TopologyScore:
    """Result of training one topology ``n`` times: mean and spread of the MSEs.

    MSE on the normalised scale (targets in [−1, 1]).
    """

    hidden: tuple[int, ...]
    n_weights: int
    mean_val_mse: float
    std_val_mse: float
    mean_train_mse: float
    mean_epochs: float


class FidelityANN:
    """Feed-forward net ensemble predicting the test fidelity (scikit-learn style).

    Parameters
    ----------
    topologies:
        Candidate hidden-layer widths, e.g. ``((5,), (10, 10))``. One candidate skips the
        search. Default: :data:`DEFAULT_TOPOLOGIES`.
    n_trainings:
        Trainings per topology from different random initialisations (paper: 5); the chosen
        topology's trainings are the ensemble.
    split:
        Train/validation/test fractions (paper: 0.70/0.15/0.15).
    seed:
        Seeds the split and the weight initialisations (deterministic).
    lm:
        Levenberg–Marquardt settings (``max_fail=6`` early stopping as MATLAB).
    transform:
        ``"log"`` (default: heavy-tailed columns and the target compressed first, see
        :class:`Compress`; test ρ 87–96 % instead of 60–87 % on the paper's 280 contact
        tests) or ``"linear"`` (the paper: features and target mapped linearly to [−1, 1]).
    combine:
        How the ensemble's members are combined per sample: ``"median"`` (default, robust
        to a minority of wild members), ``"mean"`` (the earlier default) or ``"trimmed"``.
    bypass:
        Direct input → output weights besides the hidden layers (default; see
        :class:`~rths3d.ann.network.Topology`): the net stays a linear model plus saturating
        corrections, so it extrapolates along the trend instead of flattening at the edge of
        the training range (the LTI-trained net on the Stewart tests, whose errors reach 5× the
        training maximum). ``False``: the paper's plain FNN.
    """

    def __init__(self, topologies: Sequence[Sequence[int]] | None = None, n_trainings: int = 5,
                 split: tuple[float, float, float] = (0.70, 0.15, 0.15), seed: int = 0,
                 lm: LMConfig = LMConfig(), transform: str = "log", bypass: bool = True,
                 combine: str = "median"):
        if n_trainings < 1:
            raise ConfigError("n_trainings", n_trainings, "must be >= 1")
        if transform not in TRANSFORMS:
            raise ConfigError("transform", transform, f"one of {', '.join(TRANSFORMS)}")
        if combine not in COMBINES:
            raise ConfigError("combine", combine, f"one of {', '.join(COMBINES)}")
        self.combine = combine
        self.transform = transform
        self.bypass = bool(bypass)
        self.compress: Compress | None = None
        self.raw_range: MinMax | None = None
        self.topologies = tuple(tuple(int(h) for h in t)
                                for t in (topologies or DEFAULT_TOPOLOGIES))
        self.n_trainings = int(n_trainings)
        self.split = tuple(split)
        self.seed = int(seed)
        self.lm = lm
        self.feature_names: list[str] = []
        self.target_name = "e_rel_ref"
        self.x_scale: MinMax | None = None
        self.y_scale: MinMax | None = None
        self.indices: dict[str, np.ndarray] = {}
        self.n_samples: int | None = None
        self.topology: Topology | None = None
        self.members: list[torch.Tensor] = []
        self.search: list[TopologyScore] = []
        self.trainings: list[TrainResult] = []
        self.info: dict[str, Any] = {}

    # ------------------------------------------------------------------ fit
    def fit(self, X: Any, y: Any, feature_names: Sequence[str] | None = None,
            indices: dict[str, np.ndarray] | None = None, progress: bool | str = False
            ) -> FidelityANN:
        """Search the topology and train the ensemble on X (N, d) → y (N,).

        ``X`` may be a pandas DataFrame (its column names become the feature names).
        ``indices`` (keys ``train``, ``val``, ``test``: disjoint, non-empty integer row
        numbers) fixes the split; otherwise a random 70/15/15 split by ``seed`` is drawn and
        stored. The normalisation and the extrapolation ranges are those of all of X (every
        set, as MATLAB's ``mapminmax`` on the whole data). ``progress``: a bar over the
        trainings (a string labels it).
        """
        x, names = _as_matrix(X, feature_names)
        t = np.asarray(y, dtype=float).ravel()
        if t.size != x.shape[0]:
            raise ConfigError("y", t.size, f"must have one target per sample ({x.shape[0]})")
        if not np.all(np.isfinite(t)):
            raise ConfigError("y", "NaN/inf", "targets must be finite")
        self.feature_names = names
        self.raw_range = MinMax.fit(x, "X")
        self.compress = Compress.fit(x, t, self.transform)
        xc, tc = self.compress.x(x), self.compress.y(t)
        self.x_scale = MinMax.fit(xc, "X")
        self.y_scale = MinMax.fit(tc[:, None], "y")
        xn = self.x_scale.transform(xc)
        tn = self.y_scale.transform(tc[:, None])[:, 0]
        self.indices = (_check_indices(indices, x.shape[0]) if indices is not None else
                        split_indices(x.shape[0], self.split, self.seed))
        self.n_samples = int(x.shape[0])
        tr, va = self.indices["train"], self.indices["val"]
        results: dict[tuple[int, ...], list[TrainResult]] = {}
        self.search = []
        jobs = [(h, k) for h in self.topologies for k in range(self.n_trainings)]
        bar = None
        if progress:
            from tqdm import tqdm

            bar = tqdm(total=len(jobs), unit="net",
                       desc=progress if isinstance(progress, str) else "training")
        for h, k in jobs:
            topo = Topology(x.shape[1], h, self.bypass)
            r = train_lm(topo, xn[tr], tn[tr], xn[va], tn[va],
                         seed=self.seed * 1000 + 17 * k + 1, config=self.lm)
            results.setdefault(h, []).append(r)
            if bar is not None:
                bar.update(1)
        if bar is not None:
            bar.close()
        for h, rs in results.items():
            v = np.array([r.val_mse for r in rs])
            self.search.append(TopologyScore(h, rs[0].topology.n_weights, float(v.mean()),
                                             float(v.std()),
                                             float(np.mean([r.train_mse for r in rs])),
                                             float(np.mean([r.epochs for r in rs]))))
        best = min(self.search, key=lambda s: s.mean_val_mse)
        self.trainings = results[best.hidden]
        self.topology = self.trainings[0].topology
        self.members = [r.weights for r in self.trainings]
        self.info = {"epochs": [r.epochs for r in self.trainings],
                     "stop": [r.stop for r in self.trainings],
                     "seconds": float(sum(r.seconds for rs in results.values() for r in rs))}
        return self

    # ------------------------------------------------------------------ predict
    def _check_fitted(self) -> None:
        if self.topology is None or self.x_scale is None or self.y_scale is None:
            raise ConfigError("model", "unfitted", "call fit() or load() first")

    def predict_members(self, X: Any, warn: bool = True) -> np.ndarray:
        """Outputs of every ensemble member in target units, shape (n_members, N).

        One sample may be given as a 1-D row of the ``n_in`` inputs (``X.iloc[0]``). Samples
        with NaN or inf inputs get NaN (with a :class:`NonFiniteInputWarning`); inputs outside
        the ranges of the data given to fit raise an :class:`ExtrapolationWarning`.
        """
        self._check_fitted()
        if self.topology.n_in > 1 and np.ndim(X) == 1:
            # a 1-D input is one sample's row here, not N samples of a single feature
            X = X.to_frame().T if hasattr(X, "to_frame") else np.asarray(X, dtype=float)[None]
        x, _ = _as_matrix(X, self.feature_names if self.feature_names else None,
                          expect=self.feature_names)
        if x.shape[1] != self.topology.n_in:
            raise ConfigError("X", x.shape, f"needs {self.topology.n_in} feature columns")
        bad = ~np.isfinite(x)
        if warn:
            out = self.raw_range.outside(x) & ~bad
            if out.any():
                warnings.warn(
                    f"{int(out.any(axis=1).sum())} of {x.shape[0]} sample(s) lie outside the "
                    f"ranges of {self._names(out)} in the data given to fit: the network "
                    "extrapolates", ExtrapolationWarning, stacklevel=3)
            if bad.any():
                rows = np.flatnonzero(bad.any(axis=1))
                shown = ", ".join(map(str, rows[:10])) + (", …" if rows.size > 10 else "")
                warnings.warn(
                    f"{rows.size} of {x.shape[0]} sample(s) have NaN/inf inputs (rows {shown}; "
                    f"columns {self._names(bad)}): their predictions are NaN",
                    NonFiniteInputWarning, stacklevel=3)
        xn = torch.as_tensor(self.x_scale.transform(self.compress.x(x)), dtype=DTYPE)
        with torch.no_grad():
            outs = np.stack([forward(self.topology, w, xn).numpy() for w in self.members])
        outs = self.compress.y_inv(self.y_scale.inverse(outs[..., None])[..., 0])
        # an inf input can saturate to a finite output, which would pass for a prediction
        outs[:, bad.any(axis=1)] = np.nan
        return outs

    def _names(self, mask: np.ndarray) -> str:
        cols = np.flatnonzero(mask.any(axis=0))
        return ", ".join(self.feature_names[c] if self.feature_names else str(c) for c in cols)

    def predict(self, X: Any, return_std: bool = False, warn: bool = True
                ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """Ensemble prediction (target units; members combined by ``combine``, the median by
        default); with ``return_std`` also the spread.

        The spread is the standard deviation across the ensemble members (same units): how
        much the trainings disagree, a warning sign where it is large.
        """
        outs = self.predict_members(X, warn=warn)
        pred = combine_members(outs, self.combine)
        if return_std:
            return pred, outs.std(axis=0)
        return pred

    # ------------------------------------------------------------------ scores
    def scores(self, X: Any, y: Any) -> dict[str, Any]:
        """ρ (eq. 15) and MSE on the stored train/val/test sets and on all samples.

        Keys ``r_train``, ``r_val``, ``r_test``, ``r_all`` (the ensemble), ``mse`` (all
        samples, target units²), ``mse_<set>``, and per-member ρ lists ``members_r_<set>``
        (for the median and worst over trainings). X and y must be the samples given to fit:
        the stored sets are their row numbers. Samples with a non-finite target or prediction
        are left out.
        """
        self._check_fitted()
        t = np.asarray(y, dtype=float).ravel()
        outs = self.predict_members(X, warn=False)
        n = self.n_samples
        if n is None:  # a model saved before n_samples was stored: bound the indices at least
            n = max((int(v.max()) + 1 for v in self.indices.values() if v.size), default=0)
            n = max(n, t.size)
        if t.size != n or outs.shape[1] != n:
            raise ConfigError("scores", f"{outs.shape[1]} samples, {t.size} targets",
                              f"needs the {n} samples given to fit (the stored train/val/test "
                              "sets are their row numbers)")
        mean = combine_members(outs, self.combine)
        finite = np.isfinite(t) & np.isfinite(mean)
        res: dict[str, Any] = {}
        sets = dict(self.indices)
        sets["all"] = np.arange(t.size)
        for name, idx in sets.items():
            idx = idx[finite[idx]]
            res[f"r_{name}"] = pearson_rho(mean[idx], t[idx])
            res[f"mse_{name}"] = mse(mean[idx], t[idx])
            res[f"members_r_{name}"] = [pearson_rho(o[idx], t[idx]) for o in outs]
        res["mse"] = res["mse_all"]
        res["topology"] = list(self.topology.hidden)
        return res

    # ------------------------------------------------------------------ persistence
    def to_dict(self) -> dict[str, Any]:
        """Everything needed to predict again: weights, normalisation, the ranges of the data
        given to fit, names, split."""
        self._check_fitted()
        return {
            "format": FORMAT,
            "feature_names": self.feature_names,
            "target_name": self.target_name,
            "n_in": self.topology.n_in,
            "hidden": list(self.topology.hidden),
            "bypass": self.topology.bypass,
            "x_range": self.x_scale.to_dict(),
            "raw_range": self.raw_range.to_dict(),
            "transform": self.transform,
            "compress": {"log_cols": list(self.compress.log_cols),
                         "scale": list(self.compress.scale), "log_y": self.compress.log_y},
            "y_range": self.y_scale.to_dict(),
            "indices": {k: v.tolist() for k, v in self.indices.items()},
            "n_samples": self.n_samples,
            "members": [w.tolist() for w in self.members],
            "search": [s.__dict__ | {"hidden": list(s.hidden)} for s in self.search],
            "settings": {"topologies": [list(t) for t in self.topologies],
                         "n_trainings": self.n_trainings, "split": list(self.split),
                         "transform": self.transform, "bypass": self.bypass,
                         "seed": self.seed, "combine": self.combine},
            "info": self.info,
        }

    def save(self, path: str | os.PathLike) -> Path:
        """Write the model as JSON (atomic: temp file + rename). Floats round-trip exactly.

        ConfigError (field ``path``) when the file cannot be written; no temp file is left.
        """
        path = Path(path)
        text = json.dumps(self.to_dict())
        tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp.write_text(text)
            os.replace(tmp, path)
        except OSError as exc:
            with contextlib.suppress(OSError):  # nothing to remove when the folder is a file
                tmp.unlink(missing_ok=True)
            raise ConfigError("path", str(path),
                              f"cannot write the model: {exc.strerror or exc}") from exc
        return path

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> FidelityANN:
        """The model of :meth:`to_dict`; ConfigError (field ``model…``) if it is damaged."""
        if not isinstance(d, dict):
            raise ConfigError("model", type(d).__name__, "must be a JSON object")
        if d.get("format") != FORMAT:
            raise ConfigError("model.format", d.get("format"), f"expected {FORMAT!r}")
        missing = [k for k in _REQUIRED if k not in d]
        if missing:
            raise ConfigError(f"model.{missing[0]}", None, "required key of a model file")
        try:
            m = cls._from_dict(d)
        except ConfigError:
            raise
        except (KeyError, TypeError, ValueError, IndexError, AttributeError) as exc:
            # hand-edited or truncated files: name the problem instead of a traceback
            what = (f"missing key {exc}" if isinstance(exc, KeyError)
                    else f"{type(exc).__name__}: {exc}")
            raise ConfigError("model", what, "malformed",
                              message=f"model: malformed ({what})") from exc
        _check_model(m)
        return m

    @classmethod
    def _from_dict(cls, d: dict[str, Any]) -> FidelityANN:
        s = d.get("settings", {})
        m = cls(topologies=s.get("topologies"), n_trainings=s.get("n_trainings", 5),
                split=tuple(s.get("split", (0.7, 0.15, 0.15))), seed=s.get("seed", 0),
                transform=d.get("transform", "linear"), bypass=bool(d.get("bypass", False)),
                # models saved before the median ensemble keep the mean they were scored with
                combine=s.get("combine", "mean"))
        m.feature_names = list(d["feature_names"])
        m.target_name = d.get("target_name", "e_rel_ref")
        m.topology = Topology(int(d["n_in"]), tuple(d["hidden"]), bool(d.get("bypass", False)))
        m.x_scale = MinMax.from_dict(d["x_range"])
        m.raw_range = MinMax.from_dict(d.get("raw_range", d["x_range"]))
        c = d.get("compress")
        m.compress = (Compress(tuple(c["log_cols"]), tuple(c["scale"]), bool(c["log_y"]))
                      if c else Compress.fit(np.zeros((1, m.topology.n_in)), np.zeros(1),
                                             "linear"))
        m.y_scale = MinMax.from_dict(d["y_range"])
        m.indices = {k: np.asarray(v, dtype=int) for k, v in d["indices"].items()}
        m.n_samples = None if d.get("n_samples") is None else int(d["n_samples"])
        m.members = [torch.as_tensor(w, dtype=DTYPE) for w in d["members"]]
        m.search = [TopologyScore(**(e | {"hidden": tuple(e["hidden"])}))
                    for e in d.get("search", [])]
        m.info = d.get("info", {})
        return m

    @classmethod
    def load(cls, path: str | os.PathLike) -> FidelityANN:
        """Read a model written by :meth:`save`; ConfigError if missing or not a model."""
        path = Path(path)
        if not path.is_file():
            raise ConfigError("model", str(path), "file does not exist")
        try:
            d = json.loads(path.read_text())
        except (OSError, ValueError) as exc:
            raise ConfigError("model", str(path), f"not a readable model file: {exc}") from exc
        try:
            return cls.from_dict(d)
        except ConfigError as exc:
            raise ConfigError("model", str(path), f"not a valid model file: {exc}") from exc


_REQUIRED = ("feature_names", "n_in", "hidden", "x_range", "y_range", "indices", "members")


def _check_model(m: FidelityANN) -> None:
    """Shapes of a loaded model agree, so that a damaged file fails here, not in predict."""
    n_in = m.topology.n_in
    if len(m.feature_names) != n_in:
        raise ConfigError("model.feature_names", len(m.feature_names), f"must name {n_in} inputs")
    if not m.members:
        raise ConfigError("model.members", 0, "needs at least one trained net")
    for w in m.members:
        if w.ndim != 1 or w.numel() != m.topology.n_weights:
            raise ConfigError("model.members", tuple(w.shape),
                              f"each net needs {m.topology.n_weights} weights for "
                              f"topology {m.topology.label()} with {n_in} inputs")
    ranges = {"x_range": m.x_scale, "raw_range": m.raw_range, "y_range": m.y_scale}
    for name, r in ranges.items():
        size = 1 if name == "y_range" else n_in
        if r.lo.shape != (size,) or r.hi.shape != (size,):
            raise ConfigError(f"model.{name}", (r.lo.shape, r.hi.shape),
                              f"lo and hi need {size} value(s)")
    c = m.compress
    if len(c.log_cols) != n_in or len(c.scale) != n_in:
        raise ConfigError("model.compress", len(c.log_cols), f"needs {n_in} columns")


def _check_indices(indices: Any, n: int) -> dict[str, np.ndarray]:
    """A given split: exactly train/val/test, each non-empty integer row numbers in [0, n),
    pairwise disjoint (a sample in two sets would leak into validation or test)."""
    if not isinstance(indices, dict) or set(indices) != {"train", "val", "test"}:
        keys = sorted(indices) if isinstance(indices, dict) else type(indices).__name__
        raise ConfigError("indices", keys, "exactly the keys train, val, test")
    out = {}
    for k in ("train", "val", "test"):
        v = np.asarray(indices[k])
        if v.ndim != 1 or v.size == 0:
            raise ConfigError(f"indices[{k!r}]", v.shape, "a non-empty 1-D set of row numbers")
        if v.dtype.kind not in "iu":
            raise ConfigError(f"indices[{k!r}]", str(v.dtype), "row numbers must be integers")
        if v.min() < 0 or v.max() >= n:
            raise ConfigError(f"indices[{k!r}]", int(v.min() if v.min() < 0 else v.max()),
                              f"row numbers must lie in [0, {n})")
        out[k] = v.astype(int)
    for a, b in (("train", "val"), ("train", "test"), ("val", "test")):
        both = np.intersect1d(out[a], out[b])
        if both.size:
            raise ConfigError("indices", int(both[0]), f"row in both {a} and {b}")
    return out


def _as_matrix(X: Any, names: Sequence[str] | None,
               expect: Sequence[str] | None = None) -> tuple[np.ndarray, list[str]]:
    """X as a float (N, d) matrix and its feature names (DataFrame columns when given)."""
    if hasattr(X, "columns") and hasattr(X, "to_numpy"):
        cols = [str(c) for c in X.columns]
        if expect:
            missing = [c for c in expect if c not in cols]
            if missing:
                raise ConfigError("features", missing[0],
                                  f"column missing (the model needs {', '.join(expect)})")
            X = X[list(expect)]
            cols = list(expect)
        x = X.to_numpy(dtype=float)
        return x, cols
    x = np.asarray(X, dtype=float)
    if x.ndim == 1:
        x = x[:, None]
    if x.ndim != 2:
        raise ConfigError("X", x.shape, "must be 2-D (samples × features)")
    if names is not None and len(names) != x.shape[1]:
        raise ConfigError("feature_names", len(names), f"must name all {x.shape[1]} columns")
    return x, list(names) if names is not None else [f"x{i}" for i in range(x.shape[1])]
