"""The paper's ANN protocol (Table 4), reproduced and extended.

1. Run the sweeps: 280 contact tests with the 1-D LTI transfer (training data), the same 280
   parameter points on the MuJoCo Stewart platform, the Table-2 linear system, and many
   system families (for leave-one-family-out training).
2. Train the fidelity ANN (LM, early stopping, 70/15/15, topology search, 5 trainings) with
   feature sets 1, 2 and 3 and apply it as the paper did.
3. Print the results table next to the paper's Table 4 and write regression plots.

Usage: ``python examples/41_paper_protocol.py [--out DIR] [--workers N] [--quick]
[--trainings N] [--transform linear|log]
[--contact paper280_lti|contact1400_lti|table1_lti|table1_lti_paper|table1_lti_large]
[--families families_xl|families_xl+families_xl_more|families_large|families_wide|families|none]
[--splits N] [--topologies 10x10;20x20]
[--no-bypass] [--sets 1,2,3] [--extra experiment.h0,excitation.frequency]
[--ratings velocity=0.2,force=200]``.
Sweeps are resumable: re-running reuses finished tests in DIR. ``--ratings`` keeps the tests a
bench with those ratings (m, m/s, N) would have completed, as the paper chose its tests within
its FTS range and its actuator's stroke and velocity.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SWEEPS = REPO / "scenes" / "sweeps"


def sweep(name: str, out: Path, workers: int | None, quick: bool):
    from rths3d.dataset import load_spec, run_sweep

    spec = load_spec(SWEEPS / f"{name}.toml")
    if quick:  # fewer tests per family, shorter runs
        fams = tuple(replace(f, subset=min(f.subset or 10**9, 60)) for f in spec.families)
        spec = replace(spec, families=fams, name=f"{spec.name}_quick")
    return run_sweep(spec, out / spec.name, workers=workers, progress=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("protocol_out"))
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--quick", action="store_true", help="small sweeps (a smoke run)")
    ap.add_argument("--trainings", type=int, default=5)
    ap.add_argument("--transform", choices=("linear", "log"), default="log",
                    help="linear: the paper's [-1, 1] map; log: compress heavy tails first")
    ap.add_argument("--contact", default="paper280_lti",
                    help="training sweep of contact tests (paper280_lti, contact1400_lti, "
                         "table1_lti, table1_lti_paper or table1_lti_large)")
    ap.add_argument("--families", default="families_large",
                    help="multi-family sweep for leave-one-family-out training; '+' joins "
                         "sweeps into one table (families_xl: six kinds, 16480 tests; "
                         "families_xl+families_xl_more: four times its training families; "
                         "families_large: a quarter of families_xl; families_wide: six kinds, "
                         "1720 tests; families: four; none: skip the leave-one-family-out "
                         "rows)")
    ap.add_argument("--topologies", default=None,
                    help="candidate hidden layers, e.g. '10x10;20x20' (default: the "
                         "estimator's 2;5;10;20;5x5;10x10); larger nets for the full grid "
                         "(30x30, or three layers: 20x20x20)")
    ap.add_argument("--splits", type=int, default=1,
                    help="train on N 70/15/15 splits (seeds 0..N-1) and pool the ρ figures")
    ap.add_argument("--no-bypass", action="store_true",
                    help="the paper's plain FNN (no linear input-output bypass)")
    ap.add_argument("--sets", default="1,2,3",
                    help="feature sets to train, e.g. '1' (one set per run on long studies; "
                         "the plots use set 2 when trained, else the first)")
    ap.add_argument("--extra", default="",
                    help="test parameters added to every feature set as inputs, e.g. "
                         "'experiment.h0,excitation.frequency,excitation.overtravel' (the "
                         "loading the paper leaves out; Table-2 and family rows need them too)")
    ap.add_argument("--ratings", default="",
                    help="bench ratings every table is cut to, e.g. 'velocity=0.2,force=200' "
                         "(m/s, N; also stroke in m): only tests whose peak command velocity, "
                         "interface force and stroke stay within them are used")
    args = ap.parse_args()

    from rths3d.ann import parse_topologies
    from rths3d.ann.plots import save_figures
    from rths3d.ann.protocol import PAPER_TABLE4, reproduce, rows_to_markdown
    from rths3d.dataset import parse_feature_sets, parse_ratings, within_ratings

    topologies = parse_topologies(args.topologies)  # before the sweeps: fail fast
    ratings = parse_ratings(args.ratings) if args.ratings.strip() else {}
    sets = tuple(sorted(parse_feature_sets(args.sets, "--sets")))
    extra = tuple(e.strip() for e in args.extra.split(",") if e.strip())
    fs = 2 if 2 in sets else sets[0]  # the set drawn in the figures

    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    lti = sweep(args.contact, out, args.workers, args.quick)
    stewart = sweep("paper280_stewart", out, args.workers, args.quick)
    linear = sweep("table2_linear", out, args.workers, args.quick)
    families = None
    if args.families != "none":
        from rths3d.dataset import join_tables

        families = join_tables([sweep(name.strip(), out, args.workers, args.quick)
                                for name in args.families.split("+")])

    if ratings:  # the tests this bench would have completed
        lti, stewart, linear = (within_ratings(t, ratings) for t in (lti, stewart, linear))
        families = None if families is None else within_ratings(families, ratings)

    models: dict = {}
    rows = reproduce(lti, stewart, linear, families, left_out="linear",
                     n_trainings=args.trainings, seed=0, transform=args.transform,
                     split_seeds=tuple(range(args.splits)), bypass=not args.no_bypass,
                     topologies=topologies, feature_sets=sets, models_out=models,
                     progress=True, extra=extra)
    table = rows_to_markdown(rows)
    print(table)
    print("\nThe paper's Table 4:")
    for r in PAPER_TABLE4:
        print(f"  {r['system']}, set {r['features']}: ρ train {r['r_train']}, "
              f"ρ test {r['r_test']}, MSE {r['mse']}")
    tag = (f"{args.contact}_{args.families}_{args.transform}" + ("_plain" if args.no_bypass else "")
           + (f"_{args.splits}splits" if args.splits > 1 else "")
           + (f"_{args.topologies.replace(';', '-')}" if args.topologies else "")
           + ("" if sets == (1, 2, 3) else "_set" + "".join(map(str, sets)))
           + ("_plus-" + "-".join(e.rsplit(".", 1)[-1] for e in extra) if extra else "")
           + ("_ratings-" + "-".join(f"{k}{v:g}" for k, v in ratings.items()) if ratings
              else ""))
    (out / f"table4_{tag}.md").write_text(table + "\n")
    (out / f"table4_{tag}.json").write_text(json.dumps([r.as_dict() for r in rows], indent=1))

    # regression + prediction plots like the paper's Figs. 6-9: the set-2 (else first set's)
    # ensemble that the protocol trained on split seed 0
    from rths3d.dataset import training_data
    from rths3d.dataset.table import has_params

    X, y, _ = training_data(lti, fs, extra=extra)
    model = models[f"contact_set{fs}"][0]
    mean, std = model.predict(X, return_std=True, warn=False)
    tr, te = model.indices["train"], model.indices["test"]
    save_figures(out / f"fig6_7_contact_lti_set{fs}.png",
                 {"training": (y[tr], mean[tr]), "test": (y[te], mean[te])},
                 spread={"test": std[te]}, title=f"contact, 1-D LTI transfer, feature set {fs}")
    Xs, ys, _ = training_data(stewart, fs, extra=extra)
    ms, ss = model.predict(Xs, return_std=True, warn=False)
    save_figures(out / f"fig8_stewart_set{fs}.png", {"Stewart platform": (ys, ms)},
                 spread={"Stewart platform": ss}, title="LTI-trained net on the Stewart tests")
    if has_params(linear, extra):
        Xl, yl, _ = training_data(linear, fs, extra=extra)
        ml, sl = model.predict(Xl, return_std=True, warn=False)
        save_figures(out / f"fig9_linear_set{fs}.png", {"linear Table 2": (yl, ml)},
                     spread={"linear Table 2": sl},
                     title="contact-trained net on the linear system")
    if f"families_set{fs}" not in models:
        print(f"\nwritten: {out / f'table4_{tag}.md'}, plots in {out}")
        return
    # the paper's cure: a net trained on the other families, on the never-seen family
    fam_model = models[f"families_set{fs}"][0]
    Xo, yo, _ = training_data(families, fs, families=["linear"])
    mo, so = fam_model.predict(Xo, return_std=True, warn=False)
    save_figures(out / f"fig10_left_out_linear_set{fs}.png", {"left-out linear family": (yo, mo)},
                 spread={"left-out linear family": so},
                 title="net trained on the other families, never-seen linear family")
    print(f"\nwritten: {out / f'table4_{tag}.md'}, plots in {out}")


if __name__ == "__main__":
    import sys

    from rths3d.errors import RthsError

    try:
        main()
    except RthsError as exc:  # a user mistake (flag, file, output folder): no traceback
        print(f"error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None
