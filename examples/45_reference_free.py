"""Fidelity without a reference on never-seen systems: one comparison table.

For each family of a multi-family sweep left out in turn (then Table 2 and the Stewart tests,
both never seen), every reference-free estimator of e_rel,ref is trained on the other
families (where it trains at all) and scored on the left-out tests, all on the same tests:

- ``e_rel,track alone``: a straight line of log10 e_rel,ref on log10 e_rel,track, fitted on
  the training families;
- ``ANN set 1 / 2 / 3``: the paper's nets (LM, early stopping, 70/15/15, ``--trainings`` nets,
  median ensemble) on Table-3 sets 1–3;
- ``surrogate``: ê_rel,ref of the surrogate reference (the part identified from each test's
  own record, coupled exactly; no training at all);
- ``surrogate, gated``: ê_rel,ref where the surrogate trusts itself and the e_rel,track line
  where it does not. Trusted: at least two members coupled, their spread ≤ g × ê, and the
  part model's held-out output error ≤ 1; g is chosen on the training families (the value of
  ``--gates`` that scores best there);
- ``physics-informed ANN``: the nets on set 1 plus the surrogate inputs (ê_rel,ref, its
  spread, the part model's held-out error).

ρ (eq. 15) on the linear scale and between log10 values; for nets the median and worst over
the trainings and the ensemble. Table 2 is scored with the models trained without the
``linear`` family, the Stewart tests with those trained without ``contact`` (their own kind).
Writes ``reference_free.md`` and ``reference_free.json`` into ``--out``.

Usage: ``python examples/45_reference_free.py FAMILIES [--table2 T] [--stewart T]
[--families contact,linear] [--topologies 20x20] [--trainings 5] [--gates 0.05,0.1,0.2,0.5,1]
[--out DIR]``,
e.g. ``python examples/45_reference_free.py out/families_xl --table2 out/table2_linear
--stewart out/paper280_stewart --out out/reference_free`` (the sweeps of
``scenes/sweeps/families_xl.toml``, ``table2_linear.toml``, ``paper280_stewart.toml``).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

SETS = {"ANN set 1": "1", "ANN set 2": "2", "ANN set 3": "3",
        "physics-informed ANN (set 1 + surrogate)": "1,surrogate"}


def _rho(a, b):
    import numpy as np

    from rths3d.ann import pearson_rho

    a, b = np.asarray(a, float), np.asarray(b, float)
    lin = pearson_rho(a, b)
    pos = (a > 0) & (b > 0)
    log = pearson_rho(np.log10(a[pos]), np.log10(b[pos])) if pos.sum() > 2 else float("nan")
    return lin, log


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("families", type=Path, help="multi-family sweep table or folder")
    ap.add_argument("--table2", type=Path, default=None, help="Table-2 sweep (never seen)")
    ap.add_argument("--stewart", type=Path, default=None, help="Stewart sweep (never seen)")
    ap.add_argument("--families", dest="left_out", default=None,
                    help="families to leave out, comma-separated (default: each in turn)")
    ap.add_argument("--topologies", default="20x20", help="hidden layers of the nets")
    ap.add_argument("--trainings", type=int, default=5, help="nets per ensemble (>= 1)")
    ap.add_argument("--gates", default="0.05,0.1,0.2,0.5,1",
                    help="candidate largest relative spreads of the surrogate's members "
                         "trusted (one is chosen on the training families)")
    ap.add_argument("--out", type=Path, default=Path("reference_free_out"))
    args = ap.parse_args()
    from rths3d.errors import ConfigError
    from rths3d.figures import check_output

    check_output(args.out, "--out", folder=True)
    if args.trainings < 1:
        raise ConfigError("--trainings", args.trainings, ">= 1")
    try:
        gates = [float(v) for v in args.gates.split(",") if v.strip()]
    except ValueError:
        gates = []
    if not gates or min(gates) <= 0:
        raise ConfigError("--gates", args.gates, "comma-separated numbers > 0")

    import numpy as np

    from rths3d.ann import FidelityANN, parse_topologies
    from rths3d.ann.estimator import combine_members
    from rths3d.dataset import read_table, training_data
    from rths3d.dataset.table import parse_features
    from rths3d.metrics.features import SET_1, SURROGATE

    topologies = parse_topologies(args.topologies)
    frame = read_table(args.families)
    if "family" not in frame.columns:
        raise ConfigError("table", "family", "a multi-family sweep table (column 'family')")
    # every estimator is scored on the same tests: finished, every input finite
    every = list(SET_1) + list(SURROGATE)

    def usable(f):
        _, _, rows = training_data(f, every)
        return rows

    frame = usable(frame)
    present = sorted(frame["family"].unique())
    left_outs = present if args.left_out is None else [
        f.strip() for f in args.left_out.split(",") if f.strip()]
    for f in left_outs:
        if f not in present:
            raise ConfigError("--families", f, f"one of {', '.join(present)}")
    extra = []
    if args.table2 is not None:
        extra.append(("Table 2", usable(read_table(args.table2)), "linear"))
    if args.stewart is not None:
        extra.append(("Stewart tests", usable(read_table(args.stewart)), "contact"))

    def line_fit(train):
        x = np.log10(train["feature.e_rel_track"].to_numpy())
        y = np.log10(train["target.e_rel_ref"].to_numpy())
        b, a = np.polyfit(x, y, 1)
        return lambda ev: 10 ** (a + b * np.log10(ev["feature.e_rel_track"].to_numpy()))

    def gated(ev, g, fallback):
        # trusted: at least two members coupled (a spread exists), they agree within g,
        # and the part model's held-out output error is below the signal itself
        hat = ev["feature.e_rel_ref_hat"].to_numpy()
        trusted = ((ev["feature.e_rel_ref_hat_std"].to_numpy() <= g * hat)
                   & (ev["measure.surrogate_members"].to_numpy() >= 2)
                   & (ev["feature.surrogate_validation"].to_numpy() <= 1.0))
        return np.where(trusted, hat, fallback), trusted

    results = []
    models: dict[tuple[str, str], FidelityANN] = {}
    line: dict[str, object] = {}
    gate: dict[str, float] = {}
    needed = set(left_outs) | {fam for _, _, fam in extra if fam in present}
    for fam in sorted(needed):
        train = frame[frame["family"] != fam]
        line[fam] = line_fit(train)
        yt = train["target.e_rel_ref"].to_numpy()
        gate[fam] = max(gates, key=lambda g, t=train, f=fam, y=yt: _rho(
            gated(t, g, line[f](t))[0], y)[0])
        for name, text in SETS.items():
            X, y, _ = training_data(train, parse_features(text))
            models[(fam, name)] = FidelityANN(topologies=topologies,
                                              n_trainings=args.trainings, seed=0).fit(
                X, y, progress=f"without {fam}: {name}")

    def score(label: str, ev, fam: str) -> None:
        y = ev["target.e_rel_ref"].to_numpy()
        rows = {}
        pred_line = line[fam](ev)
        rows["e_rel,track alone (log line)"] = _rho(pred_line, y)
        for name, text in SETS.items():
            m = models[(fam, name)]
            X, _, _ = training_data(ev, parse_features(text))
            outs = m.predict_members(X, warn=False)
            members = [_rho(o, y) for o in outs]
            ens = _rho(combine_members(outs, m.combine), y)
            rows[name] = (ens[0], ens[1], float(np.median([r[0] for r in members])),
                          float(np.min([r[0] for r in members])))
        rows["surrogate"] = _rho(ev["feature.e_rel_ref_hat"].to_numpy(), y)
        est, trusted = gated(ev, gate[fam], pred_line)
        rows["surrogate, gated (line where the members disagree)"] = _rho(est, y)
        entry = {"evaluated": label, "trained_without": fam, "n": int(len(y)),
                 "gate": gate[fam], "n_untrusted": int((~trusted).sum()), "scores": rows}
        results.append(entry)
        print(json.dumps(entry), flush=True)

    for fam in left_outs:
        score(f"`{fam}` left out", frame[frame["family"] == fam], fam)
    for label, ev, fam in extra:
        if fam in needed:
            score(label, ev, fam)

    def pct(v):
        return "–" if v is None or not np.isfinite(v) else f"{100 * v:.1f}"

    names = list(results[0]["scores"]) if results else []
    lines = ["| tests (n) | " + " | ".join(names) + " |",
             "|---|" + "---|" * len(names)]
    for e in results:
        cells = []
        for n in names:
            v = e["scores"][n]
            if len(v) == 4:  # nets: ensemble (log10); members median / worst
                cells.append(f"{pct(v[0])} ({pct(v[1])}); {pct(v[2])} / {pct(v[3])}")
            else:
                cells.append(f"{pct(v[0])} ({pct(v[1])})")
        lines.append(f"| {e['evaluated']} ({e['n']}) | " + " | ".join(cells) + " |")
    table = "\n".join(lines)
    print(table)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "reference_free.md").write_text(table + "\n")
    (args.out / "reference_free.json").write_text(json.dumps(results, indent=1))
    print(f"written: {args.out / 'reference_free.md'}")


if __name__ == "__main__":
    import sys

    from rths3d.errors import RthsError

    try:
        main()
    except RthsError as exc:  # a user mistake (flag, file, output folder): no traceback
        print(f"error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None
