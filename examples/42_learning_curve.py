"""Learning curve of the fidelity ANN: does more data of the same system still help?

Trains the paper's network (LM, early stopping, 5 trainings) on nested subsets of growing size
of one or more sweep tables, scores each on one fixed held-out test set, and plots test and
training ρ (eq. 15) and the test residual of log10(prediction / target) against the number of
training tests. A residual that keeps falling means data (and net capacity) limit the
prediction; a flat one means the Table-3 features do.

Usage: ``python examples/42_learning_curve.py TABLE [TABLE ...] [--features 1,2,3]
[--sizes 2000,8000,32000] [--topologies 20x20] [--trainings 5] [--test N] [--out DIR]``, e.g. on the
sweep of ``scenes/sweeps/table1_lti_large.toml``. Prints one JSON line per point and writes
``learning_curve.png`` and ``learning_curve.json`` in DIR.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("tables", nargs="+", type=Path, help="sweep tables (Parquet)")
    ap.add_argument("--features", default="1,2,3", help="Table-3 feature sets, e.g. 1,3")
    ap.add_argument("--sizes", default="2000,8000,32000",
                    help="training + validation tests per point, increasing")
    ap.add_argument("--topologies", default="20x20", help="candidate hidden layers")
    ap.add_argument("--trainings", type=int, default=5)
    ap.add_argument("--test", type=int, default=None,
                    help="held-out test tests (default: 15 %% of the stable tests)")
    ap.add_argument("--out", type=Path, default=Path("learning_curve_out"))
    args = ap.parse_args()
    from rths3d.figures import check_output

    check_output(args.out, "--out", folder=True)

    from rths3d.ann import learning_curve, parse_topologies
    from rths3d.ann.plots import save_learning_curve
    from rths3d.dataset import join_tables, parse_feature_sets, read_table, training_data
    from rths3d.errors import ConfigError

    topologies = parse_topologies(args.topologies)
    sets = parse_feature_sets(args.features)
    try:
        sizes = [int(s) for s in args.sizes.split(",")]
    except ValueError:
        raise ConfigError("--sizes", args.sizes, "comma-separated integers") from None
    # the same parameter point in two tables is the same test: join_tables counts it once
    frame = join_tables([read_table(t) for t in args.tables])
    curves, rows = {}, []
    for fs in sets:
        X, y, _ = training_data(frame, fs)
        pts = learning_curve(X, y, sizes, n_test=args.test, n_trainings=args.trainings,
                             topologies=topologies, progress=True)
        curves[f"set {fs}"] = pts
        for p in pts:
            row = {"features": fs, **p.as_dict()}
            rows.append(row)
            print(json.dumps(row), flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "learning_curve.json").write_text(json.dumps(rows, indent=1))
    save_learning_curve(args.out / "learning_curve.png", curves,
                        title=f"fidelity ANN on {', '.join(t.stem for t in args.tables)}")
    print(f"written: {args.out / 'learning_curve.png'}")


if __name__ == "__main__":
    import sys

    from rths3d.errors import RthsError

    try:
        main()
    except RthsError as exc:  # a user mistake (flag, file, output folder): no traceback
        print(f"error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None
