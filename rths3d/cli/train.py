"""CLI commands: ``train`` (fit the fidelity ANN on a sweep table) and ``predict``."""

from __future__ import annotations

from pathlib import Path

import typer

from ..figures import png_path
from ._app import app, json_line, warn_implausible
from ._output import Keeper, check_file


@app.command()
def train(
    tables: list[Path] = typer.Argument(..., metavar="table",
                                        help="Sweep table (.parquet/.csv) or sweep output "
                                             "folder; several are joined into one data set "
                                             "(a test in two of them is kept once)."),
    features: str = typer.Option(..., "--features",
                                 help="Table-3 feature set: 1, 2 or 3, or feature names, "
                                      "e.g. 'e_rel_track,zeta,hsem_s' (a set chosen on your "
                                      "data); a set and 'surrogate' may be listed: "
                                      "'2,surrogate' adds the surrogate estimate "
                                      "(physics-informed)."),
    out: Path = typer.Option(..., "--out", help="Model file to write (.json)."),
    as_json: bool = typer.Option(False, "--json", help="Print the scores as one JSON line."),
    topologies: str = typer.Option(None, "--topologies",
                                   help="Candidate hidden layers, e.g. '5;10;5,5' "
                                        "(default: a search over 1–2 layers)."),
    trainings: int = typer.Option(5, "--trainings", help="Trainings per topology (paper: 5)."),
    seed: int = typer.Option(0, "--seed", help="Seed of the split and initialisations."),
    family: list[str] = typer.Option(None, "--family", help="Train only on these families."),
    exclude: list[str] = typer.Option(None, "--exclude", help="Leave these families out."),
    extra: list[str] = typer.Option(None, "--extra",
                                    help="A test parameter as a further input, e.g. "
                                         "experiment.h0 (repeatable; beyond Table 3)."),
    target: str = typer.Option("e_rel_ref", "--target", help="Target column (`target.<name>`)."),
    ratings: str = typer.Option(None, "--ratings",
                                help="Keep only the tests a bench with these ratings would "
                                     "have completed, e.g. 'velocity=0.2,force=200' (m/s, N; "
                                     "also stroke in m)."),
    plot: Path = typer.Option(None, "--plot", help="Write regression/prediction plots (PNG)."),
    transform: str = typer.Option("log", "--transform",
                                  help="log (default: compress heavy-tailed features and "
                                       "target first) or linear (the paper's [-1, 1] map)."),
    combine: str = typer.Option("median", "--combine",
                                help="How the ensemble combines its trainings per test: "
                                     "median (default), mean or trimmed (mean without the "
                                     "lowest and highest)."),
    bypass: bool = typer.Option(True, "--bypass/--no-bypass",
                                help="Linear input-output weights besides the hidden layers "
                                     "(extrapolates along the trend); --no-bypass: the "
                                     "paper's plain FNN."),
) -> None:
    """Train the fidelity ANN (LM, early stopping, 70/15/15, topology search, 5 trainings).

    Prints ρ (paper eq. 15) on the training, validation and test sets and the MSE.
    """
    import warnings

    from ..dataset.store import join_tables, read_table
    from ..dataset.table import PARAM, parse_features, parse_ratings, training_data, within_ratings
    from ..errors import ConfigError

    if transform not in ("log", "linear"):
        raise ConfigError("--transform", transform, "must be log or linear")
    chosen = parse_features(features)
    limits = parse_ratings(ratings) if ratings is not None else {}
    check_file(out, "--out")
    if plot:
        check_file(png_path(plot), "--plot")
    keeper = Keeper()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UserWarning)
        frame = join_tables([read_table(t) for t in tables])
    for w in caught:
        typer.echo(f"note: {w.message}", err=True)
    if limits:
        frame = within_ratings(frame, limits)
    X, y, _rows = training_data(frame, chosen, target, family or None, exclude or None,
                                extra=extra or ())
    if len(y) < 10:
        raise ConfigError("table", f"{len(y)} usable rows", "need at least 10 finished tests")
    from ..ann import FidelityANN, parse_topologies  # torch: after the cheap checks
    from ..ann.scores import median_worst

    model = FidelityANN(topologies=parse_topologies(topologies), n_trainings=trainings,
                        seed=seed, transform=transform, bypass=bypass, combine=combine)
    model.target_name = target
    model.fit(X, y, progress=not as_json)
    # a model the target refuses now is kept in a temporary folder (the error says where)
    saved = keeper.write(model.save, out, "--out")
    sc = model.scores(X, y)
    res = {"r_train": sc["r_train"], "r_val": sc["r_val"], "r_test": sc["r_test"],
           "mse": sc["mse"], "mse_test": sc["mse_test"], "topology": sc["topology"],
           "n_samples": int(len(y)),
           "features": chosen if isinstance(chosen, int) else list(chosen), "model": str(saved),
           "extra": [c for c in X.columns if c.startswith(PARAM)],
           "combine": model.combine,
           "r_test_members": median_worst(sc["members_r_test"]),
           "r_train_members": median_worst(sc["members_r_train"]),
           "search": [{"hidden": list(s.hidden), "mean_val_mse": s.mean_val_mse}
                      for s in model.search]}
    if plot:
        from ..ann.plots import save_figures

        mean, std = model.predict(X, return_std=True, warn=False)
        title = (f"feature set {chosen}" if isinstance(chosen, int)
                 else f"features {', '.join(chosen)}")
        tr, te = model.indices["train"], model.indices["test"]
        keeper.write(lambda p: save_figures(p, {"training": (y[tr], mean[tr]),
                                                "test": (y[te], mean[te])},
                                            spread={"test": std[te]}, title=title),
                     png_path(plot), "--plot")
    if as_json:
        typer.echo(json_line(res))
    else:
        typer.echo(f"topology {'x'.join(map(str, res['topology']))}  "
                   f"ρ train {res['r_train']:.4f}  val {res['r_val']:.4f}  "
                   f"test {res['r_test']:.4f}  MSE {res['mse']:.3g}  "
                   f"({len(y)} tests) → {saved}")
    keeper.finish()


@app.command()
def predict(
    model: Path = typer.Argument(..., help="Model file written by 'rths3d train'."),
    data: Path = typer.Argument(..., help="Sweep table, or one test record (.parquet/.csv)."),
    as_json: bool = typer.Option(False, "--json", help="Print the results as one JSON line."),
    by: str = typer.Option(None, "--by",
                           help="Score each group of this table column separately (default: "
                                "'family' when the table has one)."),
) -> None:
    """Predict the fidelity (e.g. e_rel,ref) with the ensemble (median of its members) and
    its spread; on a table with targets, ρ overall and per family (or --by column), per
    member (median / worst), the share of tests outside the training ranges and ρ on the
    tests inside them; on a table with the surrogate estimate, its own ρ, the coverage of
    its band and the share flagged unreliable (``surrogate``)."""
    import warnings

    import numpy as np

    from ..dataset.store import read_table
    from ..dataset.table import FEATURE, PARAM, TARGET, input_column
    from ..errors import ConfigError

    if not model.is_file():  # the cheap checks before torch is imported
        raise ConfigError("model", str(model), "file does not exist" if not model.exists()
                          else "is a folder, not a model file")
    frame = read_table(data)
    from ..ann import ExtrapolationWarning, FidelityANN, NonFiniteInputWarning, pearson_rho

    net = FidelityANN.load(model)
    not_scalar: dict[str, tuple[int, ...]] = {}
    if "t" in frame.columns and not any(c.startswith(FEATURE) for c in frame.columns):
        from ..dataset.runner import record_features
        from ..record import Record

        rec = Record.load(data)
        warn_implausible(rec, data)
        status = rec.meta.get("status")
        if status not in (None, "ok"):
            typer.echo(f"warning: the record's status is {status!r} "
                       f"({rec.meta.get('reason') or 'no reason given'}); its features "
                       "describe a test that did not finish", err=True)
        row = {FEATURE + k: v for k, v in record_features(rec).items()}
        # a model with parameter inputs reads them from the record's scene
        params = rec.meta.get("params") or {}
        for k, v in params.items():
            if isinstance(v, int | float):
                row[PARAM + k] = float(v)
        # the record stores numerical.m/c/k as the matrices M/C/K; a sweep's scalar shorthand
        # is their single entry, which exists only for a 1-DOF numerical part
        for big in "MCK":
            col, v = f"{PARAM}numerical.{big.lower()}", params.get(f"numerical.{big}")
            if v is None or col in row:
                continue
            v = np.asarray(v, dtype=float)
            if v.size == 1:
                row[col] = float(v.ravel()[0])
            else:
                not_scalar[col] = v.shape
        import pandas as pd

        frame = pd.DataFrame([row])
    cols = [input_column(n) for n in net.feature_names]
    missing = [c for c in cols if c not in frame.columns]
    if missing:
        if missing[0] in not_scalar:
            raise ConfigError("data", missing[0].removeprefix(PARAM),
                              "the record's numerical part is not a scalar (matrix "
                              f"{not_scalar[missing[0]]}): a model of numerical.m/c/k needs "
                              "a 1-DOF record")
        raise ConfigError("data", missing[0], "feature column missing for this model")
    if "status" in frame.columns:
        frame = frame[frame["status"] == "ok"]
        if frame.empty:
            raise ConfigError("data", str(data), "no test has status ok")
    X = frame[cols].to_numpy(dtype=float)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ExtrapolationWarning)
        warnings.simplefilter("always", NonFiniteInputWarning)
        mean, std = net.predict(X, return_std=True)
    extrap = [str(w.message) for w in caught if issubclass(w.category, ExtrapolationWarning)]
    for w in caught:
        if issubclass(w.category, NonFiniteInputWarning):
            typer.echo(f"warning: {w.message}", err=True)
    res: dict = {"prediction": mean.tolist(), "spread": std.tolist(),
                 "target_name": net.target_name, "extrapolation": extrap}
    if "test_id" in frame.columns:
        res["test_id"] = frame["test_id"].tolist()
    tcol = TARGET + net.target_name
    if by is not None and by not in frame.columns:
        raise ConfigError("--by", by, "not a column of this table (e.g. family, transfer, "
                                      "param.transfer.delay)")
    group_col = by if by is not None else ("family" if "family" in frame.columns else None)
    if tcol in frame.columns:
        from ..ann.report import score_report

        t = frame[tcol].to_numpy(dtype=float)
        # one NaN target or prediction would make ρ and the MSE of the whole table NaN
        ok = np.isfinite(t) & np.isfinite(mean)
        if ok.sum() > 1:
            res["r"] = pearson_rho(mean[ok], t[ok])
            res["mse"] = float(np.mean((mean[ok] - t[ok]) ** 2))
            res["n_scored"] = int(ok.sum())
            rep = score_report(net, X, t, frame[group_col].to_numpy()
                               if group_col is not None else None)
            res["r_log10"] = rep["r_log10"]
            res["members"] = rep["members"]
            res["members_log10"] = rep["members_log10"]
            res["share_outside"] = rep["share_outside"]
            res["r_in_range"] = rep["r_in_range"]
            res["n_in_range"] = rep["n_in_range"]
            if group_col is not None:
                res["by"] = group_col
                res["groups"] = rep["groups"]
    sur = surrogate_scores(frame, net.target_name)
    if sur is not None:
        res["surrogate"] = sur
    if as_json:
        typer.echo(json_line(res))
        return
    for w in extrap:
        typer.echo(f"warning: {w}", err=True)
    ids = res.get("test_id", [str(i) for i in range(len(mean))])
    for i, m, s in zip(ids, mean, std, strict=True):
        typer.echo(f"{i}\t{net.target_name} = {m:.6g} ± {s:.2g}")
    if "r" in res:
        scored = "" if res["n_scored"] == len(mean) else \
            f"  ({res['n_scored']} of {len(mean)} tests with finite target and prediction)"
        typer.echo(f"ρ = {res['r']:.4f}  MSE = {res['mse']:.3g}{scored}")
        typer.echo(f"members ρ median {res['members']['median']:.4f} worst "
                   f"{res['members']['worst']:.4f}; {100 * res['share_outside']:.1f} % of the "
                   f"tests outside the training ranges, ρ in range {res['r_in_range']:.4f} "
                   f"({res['n_in_range']} tests)")
        if sur is not None:
            typer.echo(f"surrogate ê_rel,ref: ρ {sur['r']:.4f} (log10 {sur['r_log10']:.4f}), "
                       f"true value inside its band {100 * sur['coverage']:.1f} %, flagged "
                       f"{100 * sur['flagged']:.1f} %, inside or flagged "
                       f"{100 * sur['coverage_or_flagged']:.1f} % ({sur['n']} tests)")
        for g, r in res.get("groups", {}).items():
            typer.echo(f"  {res['by']} {g}: ρ {r['r']:.4f} (log10 {r['r_log10']:.4f}), "
                       f"members {r['members']['median']:.4f} / {r['members']['worst']:.4f}, "
                       f"{r['n']} tests, {100 * r['share_outside']:.1f} % outside")


def surrogate_scores(frame, target: str = "e_rel_ref") -> dict | None:
    """How the surrogate estimate of a sweep table (``feature.e_rel_ref_hat``, its band
    ``measure.e_rel_ref_hat_lo``/``_hi`` and ``measure.surrogate_flag``) scores against the
    true ``target.e_rel_ref``: ρ (eq. 15, linear and log10) over the tests with both finite,
    ``coverage`` (share whose true value lies in the band), ``flagged`` (share flagged
    unreliable or failed), ``coverage_or_flagged``, ``underestimated_3x_unflagged`` (tests
    whose truth exceeds three times the estimate without a flag), ``nan`` (estimates
    missing among the tests scored), ``n``. None when the table lacks them or the target is
    another one."""
    import numpy as np

    from ..ann import pearson_rho
    from ..dataset.table import FEATURE, MEASURE, TARGET

    cols = (FEATURE + "e_rel_ref_hat", MEASURE + "e_rel_ref_hat_lo",
            MEASURE + "e_rel_ref_hat_hi", MEASURE + "surrogate_flag", TARGET + "e_rel_ref")
    if target != "e_rel_ref" or any(c not in frame.columns for c in cols):
        return None
    est, lo, hi, flag, t = (frame[c].to_numpy(dtype=float) for c in cols)
    have = np.isfinite(t)
    flagged = (flag > 0) | ~np.isfinite(est)
    ok = have & np.isfinite(est)
    if ok.sum() < 2:
        return None
    inside = (t >= lo) & (t <= hi)
    pos = ok & (est > 0) & (t > 0)
    return {"r": pearson_rho(est[ok], t[ok]),
            "r_log10": pearson_rho(np.log10(est[pos]), np.log10(t[pos])) if pos.sum() > 1
            else float("nan"),
            "coverage": float(np.mean(inside[have])),
            "flagged": float(np.mean(flagged[have])),
            "coverage_or_flagged": float(np.mean((inside | flagged)[have])),
            "underestimated_3x_unflagged": int(np.sum(ok & ~flagged & (t > 3 * est))),
            "nan": int(np.sum(have & ~np.isfinite(est))), "n": int(have.sum())}
