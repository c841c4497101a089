"""The diagnosis on benches made by other code than the bench model: the figures of issue 35.

The benches come from ``tests/foreign_bench.py`` (its own MJCF of platforms of other
dimensions, its own stepping loop with a zero-order-hold controller that samples every
channel at the start of the interval, 0.25 ms physics, the documented zeroing and noise) and
``tests/test_foreign_bench.py`` (the three benches, the scenes a user writes for them, the
errors in a description and the effect matrix); the diagnosis gets only the record file and
the scene. Prints, and writes to ``results.json`` in the output folder:

- null: the three benches described right (validation ≤ 1.2 units of the bench's noise);
- described wrong: one error each (hold mode, sampling instant, payload mass, centre-of-mass
  height, one anchor): found first, validation ≤ 1.2 after it;
- matrix: per-leg, geometry, FTS and payload effects hidden in bench A (``--bench servo``:
  bench D, A with its servo's lag after the hold; ``valve``: E, A with a servo-valve;
  ``physics``: F, D with a stiffer chain closure and a disc plate): right effect first,
  right leg, validation ≤ 1.2 after adding it, no statement of the description revised;
- baseline: the null and the matrix on bench A with structural damping in its frame (a
  discrepancy no candidate has), each diagnosed against a record of the healthy bench.

Run: ``python examples/66_foreign_bench.py [--quick] [--kinds null,wrong,matrix,baseline]
[--shard I/N] [--bench rigid|servo|valve|physics] [--out DIR]`` (the full set takes about an
hour on two shared cores; ``--quick`` runs one case of each kind; ``--shard 0/2`` runs every
second case, for two processes; a bad argument: one ``error:`` line, exit code 2).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1] / "tests"


def _fail(message: str) -> None:
    """Bad input: one line on stderr, exit code 2."""
    print(message, file=sys.stderr)
    raise SystemExit(2)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="one case of each kind")
    ap.add_argument("--kinds", default="null,wrong,matrix",
                    help="which sets to run (comma-separated: null, wrong, matrix, "
                         "baseline)")
    ap.add_argument("--shard", default="0/1", help="I/N: run every N-th case from the I-th")
    ap.add_argument("--bench", default="rigid",
                    help="the matrix's bench: rigid (A), servo (D: A with its servo's "
                         "3 ms lag after the hold, described with lag = \"servo\"), valve "
                         "(E: A with a 55 Hz servo-valve) or physics (F: D with a stiffer "
                         "chain closure and a disc plate)")
    ap.add_argument("--out", type=Path, default=Path("foreign_bench_results"),
                    help="output folder (results.json)")
    args = ap.parse_args()
    kinds = {k.strip() for k in args.kinds.split(",") if k.strip()}
    bad = kinds - {"null", "wrong", "matrix", "baseline"}
    try:
        i0, n = (int(v) for v in args.shard.split("/"))
        assert 0 <= i0 < n
    except (ValueError, AssertionError):
        _fail(f"error: --shard: {args.shard!r} must be I/N with 0 <= I < N")
    if bad:
        _fail(f"error: --kinds: {sorted(bad)} not among null, wrong, matrix, baseline")
    if args.bench not in ("rigid", "servo", "valve", "physics"):
        _fail(f"error: --bench: {args.bench!r} must be rigid, servo, valve or physics")
    if not (TESTS / "foreign_bench.py").is_file():
        _fail("error: tests/foreign_bench.py not found: run from a clone of the repository")
    sys.path.insert(0, str(TESTS))
    import test_foreign_bench as fb

    nulls = ["rigid"] if args.quick else list(fb.BENCHES)
    wrong = fb.WRONG[:1] if args.quick else fb.WRONG
    matrix = list(fb.MATRIX)[:1] if args.quick else list(fb.MATRIX)
    cases = [("null", c) for c in nulls if "null" in kinds] + \
        [("wrong", c) for c in wrong if "wrong" in kinds] + \
        [("matrix", c) for c in matrix if "matrix" in kinds] + \
        [("baseline", c) for c in [None, *matrix] if "baseline" in kinds]
    cases = cases[i0::n]
    nulls = [c for k, c in cases if k == "null"]
    wrong = [c for k, c in cases if k == "wrong"]
    matrix = [c for k, c in cases if k == "matrix"]
    baseline = [c for k, c in cases if k == "baseline"]
    out: dict = {"null": [], "wrong": [], "matrix": [], "baseline": []}
    t0 = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        for i, name in enumerate(nulls):
            folder = Path(tmp) / f"null{i}"
            folder.mkdir()
            spec = fb.BENCHES[name]()
            rec = fb.make_record(folder, spec, seed=11)
            diag, res = fb._diagnose(folder, spec, fb.description(spec), rec, rounds=1)
            row = {"bench": name, "proposal": res[0].proposal.effect if res[0].proposal
                   else None, "error_val": fb.validation_error(diag)}
            out["null"].append(row)
            print("null", row, flush=True)
        for i, (name, error) in enumerate(wrong):
            folder = Path(tmp) / f"wrong{i}"
            folder.mkdir()
            row = fb.described_wrong_case(folder, name, error)
            out["wrong"].append(row)
            print("wrong", {k: v for k, v in row.items() if k != "revisions"}, flush=True)
        for i, label in enumerate(matrix):
            folder = Path(tmp) / f"matrix{i}"
            folder.mkdir()
            row = fb.matrix_case(folder, label, bench=args.bench)
            out["matrix"].append(row)
            print("matrix", {k: v for k, v in row.items() if k != "revisions"}, flush=True)
        for i, label in enumerate(baseline):
            folder = Path(tmp) / f"baseline{i}"
            folder.mkdir()
            row = fb.baseline_case(folder, fb.rigid_bench(),
                                   {"frame_damping": fb.FRAME_DAMPING}, label)
            out["baseline"].append(row)
            print("baseline", {k: v for k, v in row.items() if k != "revisions"}, flush=True)

    def rate(rows, key):
        vals = [r[key] for r in rows if r.get(key) is not None]
        return f"{sum(bool(v) for v in vals)} of {len(vals)}" if vals else "–"

    fig = {
        "null_noise_only": rate([{"ok": r["proposal"] is None and r["error_val"] <= 1.2}
                                 for r in out["null"]], "ok"),
        "wrong_found_first": rate(out["wrong"], "found"),
        "wrong_fixed": rate([{"ok": r["error_val"] <= 1.2} for r in out["wrong"]], "ok"),
        "matrix_first": rate(out["matrix"], "found"),
        "matrix_right_leg": rate(out["matrix"], "right_leg"),
        "matrix_fixed": rate([{"ok": r["error_val"] <= 1.2} for r in out["matrix"]], "ok"),
        "baseline_first": rate(out["baseline"], "found"),
        "baseline_right_leg": rate(out["baseline"], "right_leg"),
        "statements_kept": rate([{"ok": not r["other_revisions"]} for r in out["matrix"]]
                                + [{"ok": r["proposal"] is None} for r in out["null"]], "ok"),
        "minutes": round((time.time() - t0) / 60, 1),
    }
    out["figures"] = fig
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / f"results_{i0}of{n}.json").write_text(json.dumps(out, indent=1, default=str))
    print(json.dumps(fig))


if __name__ == "__main__":
    main()
