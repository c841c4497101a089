"""How much do the Table-3 features know? A fast probe with gradient-boosted trees.

Before training nets for an hour, ask a cheaper learner whether an input could help at all:
fit gradient-boosted trees (scikit-learn's ``HistGradientBoostingRegressor``; scikit-learn is
*not* a dependency of rths3d, install it for this example) to log10 e_rel,ref of one sweep
table, given a Table-3 feature set alone and with test parameters added, and compare Pearson ρ
(eq. 15) on held-out tests, on the linear scale as in the paper. Inputs are compressed as the
fidelity ANN compresses them (``transform="log"``). This is the probe behind "What the paper's
features miss: the loading" and "Seven features chosen on our data" in docs/ann.md.

Usage: ``python examples/43_feature_probe.py TABLE [--features 1,2,3] [--extra
'experiment.h0;experiment.h0,excitation.frequency,excitation.overtravel'] [--named
'e_rel_track,zeta;...'] [--forward K] [--ratings velocity=0.2] [--test 0.15] [--seed 0]``.
``--extra`` is a ';'-separated list of groups, each a ','-separated list of parameter names;
every group is tried on top of each feature set. ``--named`` adds rows for ';'-separated
groups of Table-3 feature names (a set of one's own). ``--forward K`` runs a greedy forward
selection over the 15 Table-3 features instead: K steps, each adding the feature that raises
the held-out ρ most (the paper chose its set 3 by sensitivity; this asks which K features
carry most). ``--ratings`` keeps the tests a bench with these ratings completes. A row keeps
the tests whose inputs are all finite, so compare rows of one table whose parameters every
test has (as in a single-family sweep). Prints a Markdown table and one JSON line.
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
    ap.add_argument("--named", default="",
                    help="';'-separated groups of ','-separated Table-3 feature names")
    ap.add_argument("--forward", type=int, default=0,
                    help="greedy forward selection of this many Table-3 features")
    ap.add_argument("--ratings", default=None, help="bench ratings, e.g. velocity=0.2 (m/s)")
    ap.add_argument("--test", type=float, default=0.15, help="held-out fraction (0 … 0.5)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the split")
    args = ap.parse_args()

    from rths3d.dataset import parse_feature_sets, parse_features, parse_ratings
    from rths3d.dataset.table import SET_1
    from rths3d.errors import ConfigError

    # argument errors before the (slow) imports and the table
    if not 0.0 < args.test <= 0.5:
        raise ConfigError("--test", args.test, "must lie in (0, 0.5]")
    if not 0 <= args.forward <= len(SET_1):
        raise ConfigError("--forward", args.forward, f"must lie in 0 … {len(SET_1)}")
    sets = parse_feature_sets(args.features)
    named = [parse_features(g, "--named") for g in args.named.split(";") if g.strip()]
    limits = parse_ratings(args.ratings) if args.ratings else {}
    groups = [tuple(n.strip() for n in g.split(",") if n.strip())
              for g in args.extra.split(";") if g.strip()]
    try:
        from sklearn.ensemble import HistGradientBoostingRegressor
    except ImportError:
        from rths3d.errors import MissingDependency

        raise MissingDependency("scikit-learn", "the feature probe", "probe") from None
    import numpy as np

    from rths3d.ann.estimator import Compress
    from rths3d.ann.scores import pearson_rho
    from rths3d.dataset import read_table, training_data, within_ratings

    frame = read_table(args.table)
    if limits:
        frame = within_ratings(frame, limits)
    # the rows to probe: each set alone and with each group of parameters, then each named
    # group; --forward chooses its rows as it goes
    runs = [] if args.forward else ([(s, e) for s in sets for e in [(), *groups]]
                                    + [(n, ()) for n in named])
    for inputs, extra in runs:  # name errors before the first fit, not after it
        training_data(frame.iloc[:1], inputs, extra=extra)

    def probe(inputs, extra=()) -> dict:
        """ρ of the trees on the training and the held-out tests, given these inputs."""
        X, y, _ = training_data(frame, inputs, extra=extra)
        x = X.to_numpy(dtype=float)
        idx = np.random.default_rng(args.seed).permutation(len(y))
        n_train = int((1.0 - args.test) * len(y))
        train, test = idx[:n_train], idx[n_train:]
        comp = Compress.fit(x[train], y[train], "log")
        trees = HistGradientBoostingRegressor(max_iter=3000, learning_rate=0.05,
                                              max_leaf_nodes=63, early_stopping=True,
                                              random_state=0)
        trees.fit(comp.x(x[train]), comp.y(y[train]))
        pred = comp.y_inv(trees.predict(comp.x(x)))
        return {"n_train": int(len(train)), "n_test": int(len(test)),
                "r_train": pearson_rho(pred[train], y[train]),
                "r_test": pearson_rho(pred[test], y[test])}

    rows = []
    if args.forward:
        chosen: list[str] = []
        for _ in range(args.forward):
            tried = {f: probe(chosen + [f]) for f in SET_1 if f not in chosen}
            best = max(tried, key=lambda f: tried[f]["r_test"])
            chosen.append(best)
            rows.append({"set": ",".join(chosen), "extra": [], **tried[best]})
            print(f"{len(chosen)}: + {best}: ρ test {100 * tried[best]['r_test']:.1f} %",
                  file=sys.stderr, flush=True)
    for inputs, extra in runs:
        label = inputs if isinstance(inputs, int) else ",".join(inputs)
        rows.append({"set": label, "extra": list(extra), **probe(inputs, extra)})
        print(f"set {label} + {', '.join(extra) or '–'}: ρ test "
              f"{100 * rows[-1]['r_test']:.1f} %", file=sys.stderr, flush=True)

    print("| set | added parameters | n train | n test | ρ train % | ρ test % |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['set']} | {', '.join(r['extra']) or '–'} | {r['n_train']} | "
              f"{r['n_test']} | {100 * r['r_train']:.1f} | {100 * r['r_test']:.1f} |")
    print(json.dumps({"table": str(args.table), "ratings": limits, "probe": rows}))


if __name__ == "__main__":
    import sys

    from rths3d.errors import RthsError

    try:
        main()
    except RthsError as exc:  # a user mistake (flag, file, output folder): no traceback
        print(f"error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None
