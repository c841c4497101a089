"""Every compensator of the project against RoDeAC on the multi-axial benchmark (maRTHS).

For each record (El Centro, Kobe, Morgan × 0.4) and each compensator — none, polynomial,
ATS, inverse, RLS, model-based (calibrated per actuator on the open-loop targets of the
three records through the nominal plant) and RoDeAC (the benchmark's stored θ0, P0) — the
nominal plant and N perturbed plants (the benchmark's uncertainty model, seed 123) run
together; every run's status is kept and the J2, J5–J10 entries (nominal, and the mean over
the perturbed plants as the benchmark reports it) are tabulated with the winner of each
entry. This is the table of docs/marths.md.

Needs the maRTHS benchmark folder beside the repository (or RTHS3D_MARTHS_DIR).

Run: ``python examples/74_marths_compare.py [--trials 20] [--seed 123] [--t-end S]
[--json marths_compare.json]``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

from rths3d.errors import RthsError

KEYS = ("J2", "J5", "J6", "J7", "J8", "J9", "J10")


def _winners(entries: dict, source: str) -> dict[str, str]:
    """Entry label → the compensator with the lowest value (ties: all of them)."""
    from rths3d.community.marths.criteria import J_LABELS

    out = {}
    for k in KEYS:
        for i, lab in enumerate(J_LABELS[k]):
            vals = {}
            for n, e in entries.items():
                J = e["J"] if source == "nominal" else (e.get("trials") or {}).get("J")
                if J:
                    vals[n] = J[k][i]
            if vals:
                best = min(vals.values())
                out[f"{k}.{lab}"] = "/".join(n for n, v in vals.items() if v == best)
    return out


def markdown(res: dict, trials: int) -> str:
    from rths3d.community.marths.criteria import J_LABELS

    cols = [f"{k}.{lab}" for k in KEYS for lab in J_LABELS[k]]
    lines = []
    for rec, entries in res.items():
        for source in ("nominal", "trials") if trials else ("nominal",):
            title = "nominal plant" if source == "nominal" else \
                f"mean over {trials} perturbed plants"
            lines += [f"\n**{rec} × 0.4, {title}** (J in %)\n",
                      "| compensator | runs ok | " + " | ".join(cols) + " |",
                      "|---|---|" + "---|" * len(cols)]
            for n, e in entries.items():
                if source == "nominal":
                    J, ok = e["J"], "1/1" if e["status"] == "ok" else "0/1"
                else:
                    J = e["trials"]["J"]
                    ok = f"{e['trials']['ok']}/{e['trials']['n']}"
                cells = [f"{J[k][i]:.1f}" if J else "—" for k in KEYS
                         for i in range(len(J_LABELS[k]))]
                lines.append(f"| {n} | {ok} | " + " | ".join(cells) + " |")
            win = _winners(entries, source)
            lines.append("| **lowest** | | " + " | ".join(win.get(c, "") for c in cols) + " |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=20, help="perturbed plants per record")
    ap.add_argument("--seed", type=int, default=123, help="seed of the plant draws")
    ap.add_argument("--t-end", type=float, default=None, help="stop time (s)")
    ap.add_argument("--json", default="", help="also write the results to this JSON file")
    args = ap.parse_args()
    if args.trials < 0:
        ap.exit(2, f"error: --trials: {args.trials} (must be ≥ 0)\n")
    if args.t_end is not None and not args.t_end > 0:
        ap.exit(2, f"error: --t-end: {args.t_end} (must be > 0 s)\n")
    from rths3d.community.marths.data import RECORDS
    from rths3d.community.marths.summary import COMPARED, run_set

    t0 = time.perf_counter()
    try:
        res = run_set(COMPARED, RECORDS, 0.4, args.trials, args.seed, t_end=args.t_end,
                      progress=lambda r, n: print(f"{r} {n} ({time.perf_counter() - t0:.0f} s)",
                                                  file=sys.stderr))
    except RthsError as exc:
        ap.exit(2, f"error: {exc}\n")
    wall = time.perf_counter() - t0
    for rec, entries in res.items():
        for n, e in entries.items():
            tr = e.get("trials", {})
            print(f"{rec} {n}: nominal {e['status']}{' ' + e['reason'] if e['reason'] else ''}"
                  f"; perturbed {tr.get('ok', 0)}/{tr.get('n', 0)} complete"
                  + "".join(f"; stopped: {s}" for s in tr.get("stopped", [])))
    print(markdown(res, args.trials))
    print(f"\nwall time {wall:.0f} s")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"trials": args.trials, "seed": args.seed, "wall_s": wall,
                       "records": res}, f, indent=1)


if __name__ == "__main__":
    main()
