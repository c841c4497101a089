"""Leave each family out in turn: does a net trained on the other kinds of system predict it?

The paper's ANN, trained on one system, reached 0–69 % on a never-seen one, and the authors
named the cure: more, and more varied, training data. The protocol (example 41) tests the
cure on one left-out family, ``linear``. This example leaves out every family of a
multi-family sweep in turn: it trains the network (LM, early stopping, 70/15/15, 5
trainings per split) on the other families and applies it to all stable tests of the left-out
one. It prints one Markdown row per family and feature set (ρ, eq. 15, on the linear scale,
median / worst over the trainings, then the ensemble and the log10-scale ρ) and writes
``lofo.md``, ``lofo.json`` and one prediction plot per family in DIR.

Usage: ``python examples/44_leave_one_family_out.py TABLE [TABLE ...] [--features 1,2,3]
[--families linear,kelvin] [--topologies 20x20] [--splits 1] [--trainings 5] [--out DIR]``,
e.g. on the sweep of ``scenes/sweeps/families_xl.toml`` (``rths3d sweep
scenes/sweeps/families_xl.toml --out out/families_xl``; 7 min on 2 workers).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("tables", nargs="+", type=Path,
                    help="multi-family sweep tables or sweep folders (joined into one)")
    ap.add_argument("--features", default="1,2,3", help="Table-3 feature sets, e.g. 1,3")
    ap.add_argument("--families", default=None,
                    help="families to leave out, comma-separated (default: each in turn)")
    ap.add_argument("--topologies", default="20x20", help="candidate hidden layers")
    ap.add_argument("--splits", type=int, default=1, help="70/15/15 splits (seeds 0..N-1)")
    ap.add_argument("--trainings", type=int, default=5, help="trainings per split")
    ap.add_argument("--out", type=Path, default=Path("lofo_out"))
    args = ap.parse_args()
    from rths3d.figures import check_output

    check_output(args.out, "--out", folder=True)

    import numpy as np

    from rths3d.ann import parse_topologies
    from rths3d.ann.plots import save_figures
    from rths3d.ann.protocol import apply_and_score, fit_and_score_splits, rows_to_markdown
    from rths3d.dataset import join_tables, parse_feature_sets, read_table, training_data
    from rths3d.errors import ConfigError

    topologies = parse_topologies(args.topologies)
    sets = parse_feature_sets(args.features)
    if args.splits < 1 or args.trainings < 1:
        raise ConfigError("--splits/--trainings", f"{args.splits} / {args.trainings}", ">= 1")
    frame = join_tables([read_table(t) for t in args.tables])
    if "family" not in frame.columns:
        raise ConfigError("table", "family", "a multi-family sweep table (column 'family')")
    ok = frame[frame["status"] == "ok"] if "status" in frame.columns else frame
    present = sorted(ok["family"].unique())
    if len(present) < 2:
        raise ConfigError("table", f"{len(present)} families", "at least two to leave one out")
    left_outs = present if args.families is None else [
        f.strip() for f in args.families.split(",") if f.strip()]
    for f in left_outs:
        if f not in present:
            raise ConfigError("--families", f, f"one of {', '.join(present)}")

    rows, summary = [], []
    args.out.mkdir(parents=True, exist_ok=True)
    for fam in left_outs:
        for fs in sets:
            X, y, _ = training_data(frame, fs, exclude=[fam])
            models, trained = fit_and_score_splits(
                X, y, f"families without {fam!r}", fs, split_seeds=range(args.splits),
                n_trainings=args.trainings, topologies=topologies, progress=True)
            Xo, yo, _ = training_data(frame, fs, families=[fam])
            applied = apply_and_score(models, Xo, yo, f"{fam!r} left out", fs)
            rows += [trained, applied]
            summary.append({"left_out": fam, "features": fs, "n_train": trained.n_train,
                            "n_left_out": applied.n_eval,
                            "r_test_median": trained.r_eval_median,
                            "r_left_out_median": applied.r_eval_median,
                            "r_left_out_worst": applied.r_eval_worst,
                            "r_left_out_ensemble": applied.r_ensemble,
                            "r_left_out_log10_median": applied.r_log_median})
            print(json.dumps(summary[-1]), flush=True)
            if fs == sets[0]:  # one picture per family: the split-0 ensemble
                mean, std = models[0].predict(Xo, return_std=True, warn=False)
                save_figures(args.out / f"lofo_{fam}_set{fs}.png", {f"{fam} (left out)":
                             (np.asarray(yo, float), mean)}, spread={f"{fam} (left out)": std},
                             title=f"trained on the other families, never-seen {fam!r}, "
                                   f"feature set {fs}")
    table = rows_to_markdown(rows)
    print(table)
    (args.out / "lofo.md").write_text(table + "\n")
    (args.out / "lofo.json").write_text(json.dumps(summary, indent=1))
    print(f"written: {args.out / 'lofo.md'}, plots in {args.out}")


if __name__ == "__main__":
    import sys

    from rths3d.errors import RthsError

    try:
        main()
    except RthsError as exc:  # a user mistake (flag, file, output folder): no traceback
        print(f"error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None
