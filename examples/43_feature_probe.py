"""How much do the Table-3 features know? A fast probe with gradient-boosted trees.

Before training nets for an hour, ask a cheaper learner whether an input could help at all:
fit gradient-boosted trees (scikit-learn's ``HistGradientBoostingRegressor``; scikit-learn is
*not* a dependency of rths3d, install it for this example) to log10 e_rel,ref of one sweep
table, given a Table-3 feature set alone and with test parameters added, and compare Pearson ρ
(eq. 15) on held-out tests, on the linear scale as in the paper. Inputs are compressed as the
fidelity ANN compresses them (``transform="log"``). This is the probe behind "What the paper's
features miss: the loading" in docs/ann.md.

Usage: ``python examples/43_feature_probe.py TABLE [--features 1,2,3] [--extra
'experiment.h0;experiment.h0,excitation.frequency,excitation.overtravel'] [--test 0.15]
[--seed 0]``. ``--extra`` is a ';'-separated list of groups, each a ','-separated list of
parameter names; every group is tried on top of each feature set. A row keeps the tests whose
inputs are all finite, so compare rows of one table whose parameters every test has (as in a
single-family sweep). Prints a Markdown table and one JSON line.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("table", type=Path, help="sweep table (Parquet)")
    ap.add_argument("--features", default="1,2,3", help="Table-3 feature sets, e.g. 1,3")
    ap.add_argument("--extra", default="experiment.h0",
                    help="';'-separated groups of ','-separated parameter names")
    ap.add_argument("--test", type=float, default=0.15, help="held-out fraction (0 … 0.5)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the split")
    args = ap.parse_args()

    from rths3d.errors import ConfigError, RthsError

    try:
        from sklearn.ensemble import HistGradientBoostingRegressor
    except ImportError:
        sys.exit("this probe needs scikit-learn (not an rths3d dependency): "
                 "pip install scikit-learn")
    import numpy as np

    from rths3d.ann.estimator import Compress
    from rths3d.ann.scores import pearson_rho
    from rths3d.dataset import parse_feature_sets, read_table, training_data

    try:
        if not 0.0 < args.test <= 0.5:
            raise ConfigError("--test", args.test, "must lie in (0, 0.5]")
        sets = parse_feature_sets(args.features)
        groups = [tuple(n.strip() for n in g.split(",") if n.strip())
                  for g in args.extra.split(";") if g.strip()]
        frame = read_table(args.table)
        for s in sets:  # name errors before the first fit, not after it
            for extra in groups or [()]:
                training_data(frame.iloc[:1], s, extra=extra)
        rows = []
        for s in sets:
            for extra in [(), *groups]:
                X, y, _ = training_data(frame, s, extra=extra)
                x = X.to_numpy(dtype=float)
                idx = np.random.default_rng(args.seed).permutation(len(y))
                n_train = int((1.0 - args.test) * len(y))
                train, test = idx[:n_train], idx[n_train:]
                comp = Compress.fit(x[train], y[train], "log")
                trees = HistGradientBoostingRegressor(
                    max_iter=3000, learning_rate=0.05, max_leaf_nodes=63,
                    early_stopping=True, random_state=0)
                trees.fit(comp.x(x[train]), comp.y(y[train]))
                pred = comp.y_inv(trees.predict(comp.x(x)))
                rows.append({"set": s, "extra": list(extra), "n_train": int(len(train)),
                             "n_test": int(len(test)),
                             "r_train": pearson_rho(pred[train], y[train]),
                             "r_test": pearson_rho(pred[test], y[test])})
                print(f"set {s} + {', '.join(extra) or '–'}: ρ test "
                      f"{100 * rows[-1]['r_test']:.1f} %", file=sys.stderr, flush=True)
    except RthsError as exc:
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(2)

    print("| set | added parameters | n train | n test | ρ train % | ρ test % |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['set']} | {', '.join(r['extra']) or '–'} | {r['n_train']} | "
              f"{r['n_test']} | {100 * r['r_train']:.1f} | {100 * r['r_test']:.1f} |")
    print(json.dumps({"table": str(args.table), "probe": rows}))


if __name__ == "__main__":
    import sys

    from rths3d.errors import RthsError

    try:
        main()
    except RthsError as exc:  # a user mistake (flag, file, output folder): no traceback
        print(f"error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None
