"""Fidelity at every time step: the surrogate's running RMS error against the true one.

For every finished test of a sweep run with ``keep_records`` (``rths3d sweep SPEC --out DIR
--keep-records``), the surrogate reference ẑ^r is estimated from the test's own record
(:class:`rths3d.surrogate.SurrogateReference`, the tests of a family coupled together) and
the running RMS of ê = z' − ẑ^r over a 0.25 s window is compared with the running RMS of
the true error z' − z^r (z^r: the reference solution in the record). Per test: ρ (eq. 15)
between the two running RMS over time (the dominant DOF); per family: the median and the
worst over the tests, and the share of tests with ρ ≥ 0.9. Writes ``per_step.json`` and a
plot of the test at the family's median ρ into ``--out``.

Usage: ``python examples/46_fidelity_per_step.py SWEEP_DIR [--families contact,linear]
[--window 0.25] [--out DIR]``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sweep", type=Path, help="sweep folder with records/ (keep_records)")
    ap.add_argument("--families", default=None, help="families to score (default: all)")
    ap.add_argument("--window", type=float, default=0.25, help="running-RMS window (s)")
    ap.add_argument("--out", type=Path, default=Path("per_step_out"))
    args = ap.parse_args()
    from rths3d.errors import ConfigError
    from rths3d.figures import check_output

    check_output(args.out, "--out", folder=True)
    rec_dir = args.sweep / "records"
    if not rec_dir.is_dir():
        raise ConfigError("SWEEP_DIR", str(args.sweep), "has no records/ folder (run the "
                          "sweep with --keep-records)")
    if not args.window > 0:
        raise ConfigError("--window", args.window, "s; must be > 0")

    import numpy as np

    from rths3d.ann import pearson_rho
    from rths3d.dataset import read_table
    from rths3d.metrics._signals import dominant_dof
    from rths3d.record import Record
    from rths3d.surrogate import SurrogateConfig, SurrogateReference, running_rms

    table = read_table(args.sweep)
    table = table[table["status"] == "ok"]
    fams = sorted(table["family"].unique())
    if args.families:
        want = [f.strip() for f in args.families.split(",") if f.strip()]
        for f in want:
            if f not in fams:
                raise ConfigError("--families", f, f"one of {', '.join(fams)}")
        fams = want
    cfg = SurrogateConfig(window=args.window)
    summary = {}
    args.out.mkdir(parents=True, exist_ok=True)
    for fam in fams:
        ids = [t for t in table.loc[table["family"] == fam, "test_id"]
               if (rec_dir / f"{t}.parquet").exists()]
        recs = [Record.load(rec_dir / f"{t}.parquet") for t in ids]
        if not recs:
            continue
        est = SurrogateReference(cfg).fit(recs)
        rhos = []
        for r, zr_hat in zip(recs, est.z_ref_, strict=True):
            zp = r.signal("z_meas")
            j = dominant_dof(zp, r.signal("f_meas"))
            true = running_rms(zp[:, j] - r.signal("z_ref")[:, j], r.dt, args.window)
            hat = running_rms(zp[:, j] - zr_hat[:, j], r.dt, args.window)
            rhos.append(pearson_rho(hat, true) if np.isfinite(hat).all() else np.nan)
        rho = np.asarray(rhos, dtype=float)
        ok = np.isfinite(rho)
        summary[fam] = {"n": int(len(rho)), "n_scored": int(ok.sum()),
                        "median": float(np.median(rho[ok])) if ok.any() else float("nan"),
                        "worst": float(np.min(rho[ok])) if ok.any() else float("nan"),
                        "share_ge_0.9": float(np.mean(rho[ok] >= 0.9)) if ok.any() else 0.0}
        print(json.dumps({"family": fam, **summary[fam]}), flush=True)
        if ok.any():
            from rths3d.metrics.plots import plot_fidelity
            from rths3d.surrogate import fidelity_columns

            k = int(np.argsort(np.where(ok, rho, np.inf))[ok.sum() // 2])
            r = recs[k]
            cols = dict(r.columns)
            cols.update(fidelity_columns(r, est.z_ref_[k], args.window,
                                         est.z_ref_members_[k]))
            plot_fidelity(Record(r.t, cols, r.meta), args.out / f"per_step_{fam}.png",
                          args.window)
    (args.out / "per_step.json").write_text(json.dumps(summary, indent=1))
    print(f"written: {args.out / 'per_step.json'}")


if __name__ == "__main__":
    import sys

    from rths3d.errors import RthsError

    try:
        main()
    except RthsError as exc:  # a user mistake (flag, file, output folder): no traceback
        print(f"error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None
